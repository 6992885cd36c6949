// Where the camera looks. A robust box around the data, the 2nd-98th percentile of the points
// per axis: a road rig's few returns 200 m away (or a stray zero) would otherwise set the box
// and leave the scene a few dots in the middle. And the distance from which a box fills the
// view, for any direction, so every preset view centres the data and shows all of it.

const LOW = 0.02;
const HIGH = 0.98;
const SAMPLE = 30_000; // points sampled in all: enough for a percentile, cheap to sort
const MARGIN = 1.08; // a little room around the box in the view

// The robust box {min, max} of `scans` ({sensor, points}) placed by `poses` (sensor -> row-major
// T_vehicle_sensor; identity when absent), sensors in `hidden` left out, only `sensor`'s when
// given; each placed sensor's origin is inside it. Null when there is no point.
export function robustBounds(scans, poses = {}, { hidden = new Set(), sensor = null } = {}) {
  const shown = scans.filter((s) => !hidden.has(s.sensor) && (sensor === null || s.sensor === sensor));
  const total = shown.reduce((n, s) => n + s.points.length / 3, 0);
  if (!total) return null;
  const step = Math.max(1, Math.ceil(total / SAMPLE));
  const axes = [[], [], []];
  for (const scan of shown) {
    const p = scan.points;
    const m = poses[scan.sensor] ?? [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0];
    for (let i = 0; i + 2 < p.length; i += 3 * step) {
      for (let a = 0; a < 3; a++) axes[a].push(m[4 * a] * p[i] + m[4 * a + 1] * p[i + 1] + m[4 * a + 2] * p[i + 2] + m[4 * a + 3]);
    }
  }
  const min = [], max = [];
  for (let a = 0; a < 3; a++) {
    const sorted = Float64Array.from(axes[a]).sort();
    min[a] = sorted[Math.floor(LOW * (sorted.length - 1))];
    max[a] = sorted[Math.ceil(HIGH * (sorted.length - 1))];
  }
  for (const name of new Set(shown.map((s) => s.sensor))) {
    const m = poses[name];
    if (m) for (let a = 0; a < 3; a++) [min[a], max[a]] = [Math.min(min[a], m[4 * a + 3]), Math.max(max[a], m[4 * a + 3])];
  }
  return { min, max };
}

// The box around a point with half-width `half` (m).
export const boxAround = (centre, half) => ({ min: centre.map((c) => c - half), max: centre.map((c) => c + half) });

const sub = (a, b) => a.map((v, i) => v - b[i]);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => a.map((v) => v / Math.hypot(...a));

// The camera that frames `box` from `direction` (from the box's centre towards the camera, any
// length), z up, with a vertical field of view `fovDeg` and `aspect` (width / height): {target,
// position}. The distance is the least at which every corner of the box is in view.
export function frame({ min, max }, direction, fovDeg, aspect) {
  const target = min.map((v, i) => (v + max[i]) / 2);
  const back = unit(direction);
  const forward = back.map((v) => -v);
  // The camera's right and up, as three.js's lookAt makes them with up = z.
  let right = cross(forward, [0, 0, 1]);
  right = Math.hypot(...right) < 1e-9 ? [0, -1, 0] : unit(right);
  const up = cross(right, forward);
  const tanV = Math.tan((fovDeg * Math.PI) / 360);
  const tanH = tanV * aspect;
  let distance = 0.5;
  for (let k = 0; k < 8; k++) {
    const corner = [k & 1 ? max[0] : min[0], k & 2 ? max[1] : min[1], k & 4 ? max[2] : min[2]];
    const d = sub(corner, target);
    const depth = dot(d, back); // towards the camera
    distance = Math.max(distance, depth + Math.abs(dot(d, right)) / tanH, depth + Math.abs(dot(d, up)) / tanV);
  }
  distance *= MARGIN;
  return { target, position: target.map((t, i) => t + back[i] * distance) };
}
