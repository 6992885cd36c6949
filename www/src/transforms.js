// Small rigid-transform helpers for display (the library does the real maths).
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

// Rotation angle (rad) and translation distance (m) between two poses.
export function poseDifference(a, b) {
  let trace = 0;
  for (let i = 0; i < 3; i++) for (let k = 0; k < 3; k++) trace += a[k * 4 + i] * b[k * 4 + i];
  const angle = Math.acos(Math.min(1, Math.max(-1, (trace - 1) / 2)));
  const distance = Math.hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
  return { angle, distance };
}

export const degrees = (rad) => (rad * 180) / Math.PI;

// 16 numbers -> 4 rows of 4.
export const rows = (m) => [0, 1, 2, 3].map((r) => Array.from(m.slice(r * 4, r * 4 + 4)));
