// Small rigid-transform helpers for display and export (the library does the real maths).
// Matrices are row-major 4x4 arrays of 16 numbers; R = Rz(yaw) Ry(pitch) Rx(roll).

export function matrixFromXyzRpy([x, y, z], [roll, pitch, yaw]) {
  const [cr, sr, cp, sp, cy, sy] = [Math.cos(roll), Math.sin(roll), Math.cos(pitch), Math.sin(pitch), Math.cos(yaw), Math.sin(yaw)];
  return [
    cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, x,
    sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, y,
    -sp, cp * sr, cp * cr, z,
    0, 0, 0, 1,
  ];
}

// Roll, pitch, yaw (rad) of a matrix; yaw and roll split evenly at gimbal lock.
export function rpyOf(m) {
  const pitch = Math.asin(Math.max(-1, Math.min(1, -m[8])));
  if (Math.abs(m[8]) > 1 - 1e-12) {
    const yaw = Math.atan2(-m[1], m[5]) / 2;
    return [-Math.sign(m[8]) * yaw, pitch, yaw];
  }
  return [Math.atan2(m[9], m[10]), pitch, Math.atan2(m[4], m[0])];
}

export const xyzOf = (m) => [m[3], m[7], m[11]];

export function multiply(a, b) {
  const out = new Array(16).fill(0);
  for (let r = 0; r < 4; r++) for (let c = 0; c < 4; c++) for (let k = 0; k < 4; k++) out[r * 4 + c] += a[r * 4 + k] * b[k * 4 + c];
  return out;
}

export function inverse(m) {
  const R = [m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]]; // transpose
  const t = [m[3], m[7], m[11]];
  const ti = [0, 1, 2].map((r) => -(R[r * 3] * t[0] + R[r * 3 + 1] * t[1] + R[r * 3 + 2] * t[2]));
  return [R[0], R[1], R[2], ti[0], R[3], R[4], R[5], ti[1], R[6], R[7], R[8], ti[2], 0, 0, 0, 1];
}

// Unit quaternion [x, y, z, w] of the rotation part, w >= 0.
export function quaternionOf(m) {
  const [a, b, c, d, e, f, g, h, i] = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];
  const trace = a + e + i;
  let q;
  if (trace > 0) {
    const s = 2 * Math.sqrt(trace + 1);
    q = [(h - f) / s, (c - g) / s, (d - b) / s, s / 4];
  } else if (a > e && a > i) {
    const s = 2 * Math.sqrt(1 + a - e - i);
    q = [s / 4, (b + d) / s, (c + g) / s, (h - f) / s];
  } else if (e > i) {
    const s = 2 * Math.sqrt(1 + e - a - i);
    q = [(b + d) / s, s / 4, (f + h) / s, (c - g) / s];
  } else {
    const s = 2 * Math.sqrt(1 + i - a - e);
    q = [(c + g) / s, (f + h) / s, s / 4, (d - b) / s];
  }
  return q[3] < 0 ? q.map((v) => -v) : q;
}

// Rotation angle (rad) and translation distance (m) between two poses.
export function poseDifference(a, b) {
  let trace = 0;
  for (let i = 0; i < 3; i++) for (let k = 0; k < 3; k++) trace += a[k * 4 + i] * b[k * 4 + i];
  const angle = Math.acos(Math.min(1, Math.max(-1, (trace - 1) / 2)));
  const distance = Math.hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
  return { angle, distance };
}

export const degrees = (rad) => (rad * 180) / Math.PI;
export const radians = (deg) => (deg * Math.PI) / 180;

// 16 numbers -> 4 rows of 4.
export const rows = (m) => [0, 1, 2, 3].map((r) => Array.from(m.slice(r * 4, r * 4 + 4)));
