// Per-point colours for the main view, computed in the render worker: by sensor (one colour),
// by height (vehicle z), by intensity, or by the distance to the reference sensor's points
// after calibration. Height and intensity span a robust range (2nd to 98th percentile of the
// points shown), so a few bright returns (GMMCalib's scans: median 45, max 5615) do not paint
// everything blue; distance (to the reference's surface, a plane fitted to its points around
// each point) has a fixed range, so two runs read alike.

export const DISTANCE_RANGE = [0, 0.05]; // m: 0 blue, 5 cm and beyond red
const LOW = 0.02, HIGH = 0.98;

// A blue-cyan-green-yellow-red ramp: [r, g, b] in 0..1 for t in 0..1.
// It starts at a light blue (0.2 along the jet ramp) so low values show on the dark background.
export function ramp(t) {
  const x = 0.2 + 0.8 * Math.min(1, Math.max(0, t));
  return [
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 3))),
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 2))),
    Math.min(1, Math.max(0, 1.5 - Math.abs(4 * x - 1))),
  ];
}

// The ramp's colours at five stops (CSS), for the colour scale beside the view and in a PNG.
export const rampStops = () => [0, 0.25, 0.5, 0.75, 1].map((t) => `rgb(${ramp(t).map((c) => Math.round(c * 255)).join(',')})`);
export const rampCss = () => `linear-gradient(to right, ${rampStops().join(', ')})`;

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

// Fills `out` (linear rgb, 3 per point) from `value(i)` over [lo, hi], for `count` points; a
// NaN value is grey (nothing to measure).
export function fillRamp(out, count, value, [lo, hi]) {
  const steps = 256;
  const table = Float32Array.from({ length: 3 * steps }, (_, k) => linear(ramp(Math.floor(k / 3) / (steps - 1))[k % 3]));
  const grey = linear(0x5c / 255);
  for (let i = 0; i < count; i++) {
    const x = value(i);
    if (Number.isNaN(x)) {
      out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = grey;
      continue;
    }
    const k = 3 * Math.round(Math.min(1, Math.max(0, (x - lo) / (hi - lo))) * (steps - 1));
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

// Distances from points to the reference sensor's surface: the reference's points kept one
// per `voxel` (m) cube in a hash grid of `radius` cubes; a query fits a plane to the reference
// points within `radius` (their covariance's least direction) and returns the distance to it,
// or NaN where there is no surface to measure against: fewer than MIN_POINTS points near, or
// points along a line only (one scan ring), whose plane is not defined.
const MIN_POINTS = 6;
const FLAT = 0.05; // second-largest over largest spread below this: a line, not a surface

export class SurfaceGrid {
  #cells = new Map();
  #seen = new Set();

  constructor(radius = 0.25, voxel = 0.02) {
    this.radius = radius;
    this.voxel = voxel;
  }

  add(x, y, z) {
    const v = `${Math.floor(x / this.voxel)},${Math.floor(y / this.voxel)},${Math.floor(z / this.voxel)}`;
    if (this.#seen.has(v)) return;
    this.#seen.add(v);
    const key = `${Math.floor(x / this.radius)},${Math.floor(y / this.radius)},${Math.floor(z / this.radius)}`;
    let list = this.#cells.get(key);
    if (!list) this.#cells.set(key, (list = []));
    list.push(x, y, z);
  }

  distance(x, y, z) {
    const r2 = this.radius * this.radius;
    const [ix, iy, iz] = [Math.floor(x / this.radius), Math.floor(y / this.radius), Math.floor(z / this.radius)];
    let n = 0, sx = 0, sy = 0, sz = 0, xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
    for (let dx = -1; dx <= 1; dx++) for (let dy = -1; dy <= 1; dy++) for (let dz = -1; dz <= 1; dz++) {
      const list = this.#cells.get(`${ix + dx},${iy + dy},${iz + dz}`);
      if (!list) continue;
      for (let k = 0; k < list.length; k += 3) {
        const [px, py, pz] = [list[k] - x, list[k + 1] - y, list[k + 2] - z];
        if (px * px + py * py + pz * pz > r2) continue;
        n++;
        sx += px; sy += py; sz += pz;
        xx += px * px; xy += px * py; xz += px * pz; yy += py * py; yz += py * pz; zz += pz * pz;
      }
    }
    if (n < MIN_POINTS) return NaN;
    const [cx, cy, cz] = [sx / n, sy / n, sz / n];
    const c = [xx / n - cx * cx, xy / n - cx * cy, xz / n - cx * cz, yy / n - cy * cy, yz / n - cy * cz, zz / n - cz * cz];
    const { values, normal } = leastAxis(c);
    if (values[1] < FLAT * values[2]) return NaN;
    // The query is the origin here: its distance to the plane through the centroid.
    return Math.abs(normal[0] * cx + normal[1] * cy + normal[2] * cz);
  }
}

// Eigenvalues (ascending) of a symmetric 3x3 [a, b, c, d, e, f] = [[a b c] [b d e] [c e f]] and
// the unit eigenvector of the least, by Jacobi rotations.
export function leastAxis([a, b, c, d, e, f]) {
  const m = [[a, b, c], [b, d, e], [c, e, f]];
  const v = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  for (let sweep = 0; sweep < 12; sweep++) {
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      if (Math.abs(m[p][q]) < 1e-18) continue;
      const theta = (m[q][q] - m[p][p]) / (2 * m[p][q]);
      const t = Math.sign(theta || 1) / (Math.abs(theta) + Math.sqrt(theta * theta + 1));
      const [cs, sn] = [1 / Math.sqrt(t * t + 1), t / Math.sqrt(t * t + 1)];
      for (let k = 0; k < 3; k++) {
        const [mkp, mkq] = [m[k][p], m[k][q]];
        m[k][p] = cs * mkp - sn * mkq;
        m[k][q] = sn * mkp + cs * mkq;
      }
      for (let k = 0; k < 3; k++) {
        const [mpk, mqk] = [m[p][k], m[q][k]];
        m[p][k] = cs * mpk - sn * mqk;
        m[q][k] = sn * mpk + cs * mqk;
      }
      for (let k = 0; k < 3; k++) {
        const [vkp, vkq] = [v[k][p], v[k][q]];
        v[k][p] = cs * vkp - sn * vkq;
        v[k][q] = sn * vkp + cs * vkq;
      }
    }
  }
  const order = [0, 1, 2].sort((i, j) => m[i][i] - m[j][j]);
  return { values: order.map((i) => m[i][i]), normal: [v[0][order[0]], v[1][order[0]], v[2][order[0]]] };
}
