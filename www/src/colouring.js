// Per-point colours for the main view, computed in the render worker: by sensor (one colour),
// by height (vehicle z), by intensity, or by the distance to the reference sensor's points
// after calibration. Height and intensity span a robust range (2nd to 98th percentile of the
// points shown), so a few bright returns (GMMCalib's scans: median 45, max 5615) do not paint
// everything blue; distance has a fixed range, so two runs read alike.

export const DISTANCE_RANGE = [0, 0.05]; // m: 0 blue, 5 cm and beyond red
const LOW = 0.02, HIGH = 0.98;

// A blue-cyan-green-yellow-red ramp: [r, g, b] in 0..1 for t in 0..1.
export function ramp(t) {
  const x = Math.min(1, Math.max(0, t));
  return [
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 3))),
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 2))),
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 1))),
  ];
}

// CSS gradient stops of the ramp, for the colour scale beside the view.
export const rampCss = () => `linear-gradient(to right, ${[0, 0.25, 0.5, 0.75, 1].map((t) => `rgb(${ramp(t).map((c) => Math.round(c * 255)).join(',')})`).join(', ')})`;

// The 2nd and 98th percentiles of `values` (any iterable of numbers), or null when empty. A
// range of zero width is widened so a ramp over it is defined.
export function robustRange(values) {
  const sorted = Float64Array.from(values).sort();
  if (!sorted.length) return null;
  const at = (q) => sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))];
  const [lo, hi] = [at(LOW), at(HIGH)];
  return hi > lo ? [lo, hi] : [lo - 0.5, lo + 0.5];
}

// Vertex colours are linear for three.js, which encodes its output as sRGB: a colour meant
// as sRGB (the CSS scale, the legend's dots) goes in decoded.
export const linear = (c) => (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);

// Fills `out` (linear rgb, 3 per point) from `value(i)` over [lo, hi], for `count` points.
export function fillRamp(out, count, value, [lo, hi]) {
  const steps = 256;
  const table = Float32Array.from({ length: 3 * steps }, (_, k) => linear(ramp(Math.floor(k / 3) / (steps - 1))[k % 3]));
  for (let i = 0; i < count; i++) {
    const k = 3 * Math.round(Math.min(1, Math.max(0, (value(i) - lo) / (hi - lo))) * (steps - 1));
    out[3 * i] = table[k];
    out[3 * i + 1] = table[k + 1];
    out[3 * i + 2] = table[k + 2];
  }
}

export function fillSolid(out, count, hex) {
  const [r, g, b] = [(hex >> 16) & 255, (hex >> 8) & 255, hex & 255].map((c) => linear(c / 255));
  for (let i = 0; i < count; i++) {
    out[3 * i] = r;
    out[3 * i + 1] = g;
    out[3 * i + 2] = b;
  }
}

// Vehicle z of point i of flat `positions` placed by `e` (THREE's column-major Matrix4 elements).
export const heightOf = (positions, e) => (i) => e[2] * positions[3 * i] + e[6] * positions[3 * i + 1] + e[10] * positions[3 * i + 2] + e[14];

// Distances from points to a reference cloud: the reference's points kept one per `voxel`
// (m) cube in a hash grid of `cell` cubes; a query looks in its cell and the 26 around it, so
// distances up to `cell` are exact (to the voxel), beyond that they read as `cell`.
export class NearestGrid {
  #cells = new Map();
  #cell;

  constructor(cell = 0.1, voxel = 0.02) {
    this.#cell = cell;
    this.voxel = voxel;
    this.seen = new Set();
  }

  #key(ix, iy, iz) {
    return `${ix},${iy},${iz}`;
  }

  add(x, y, z) {
    const v = `${Math.floor(x / this.voxel)},${Math.floor(y / this.voxel)},${Math.floor(z / this.voxel)}`;
    if (this.seen.has(v)) return;
    this.seen.add(v);
    const key = this.#key(Math.floor(x / this.#cell), Math.floor(y / this.#cell), Math.floor(z / this.#cell));
    let list = this.#cells.get(key);
    if (!list) this.#cells.set(key, (list = []));
    list.push(x, y, z);
  }

  distance(x, y, z) {
    const [ix, iy, iz] = [Math.floor(x / this.#cell), Math.floor(y / this.#cell), Math.floor(z / this.#cell)];
    let best = this.#cell * this.#cell;
    for (let dx = -1; dx <= 1; dx++) for (let dy = -1; dy <= 1; dy++) for (let dz = -1; dz <= 1; dz++) {
      const list = this.#cells.get(this.#key(ix + dx, iy + dy, iz + dz));
      if (!list) continue;
      for (let k = 0; k < list.length; k += 3) {
        const d = (list[k] - x) ** 2 + (list[k + 1] - y) ** 2 + (list[k + 2] - z) ** 2;
        if (d < best) best = d;
      }
    }
    return Math.sqrt(best);
  }
}
