// Test data for the browser tests, made in Node from the wasm package (independent of the page
// and of any CLI): a synthetic rig with its truth, written in GMMCalib's layout as PCD (ascii)
// and PLY (binary little-endian) files plus config.yaml, as file payloads for setInputFiles.
import { readFileSync, readdirSync } from 'node:fs';
import { initSync, simulateRig } from '../pkg/gmmcalib.js';

initSync({ module: readFileSync(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });

// The twin's sampled preset: a cube seen by `sensors` sensors, `pointsPerView` points a scan.
export const sampledRig = (options) => simulateRig({ preset: 'sampled', ...options });

export { simulateRig };

export function pcdAscii(points) {
  const n = points.length / 3;
  const header = ['# .PCD v0.7', 'VERSION 0.7', 'FIELDS x y z', 'SIZE 4 4 4', 'TYPE F F F', 'COUNT 1 1 1',
    `WIDTH ${n}`, 'HEIGHT 1', 'VIEWPOINT 0 0 0 1 0 0 0', `POINTS ${n}`, 'DATA ascii'];
  const lines = [];
  for (let i = 0; i < n; i++) lines.push(`${points[3 * i]} ${points[3 * i + 1]} ${points[3 * i + 2]}`);
  return Buffer.from(`${[...header, ...lines].join('\n')}\n`);
}

export function plyBinary(points) {
  const n = points.length / 3;
  const header = Buffer.from(`ply\nformat binary_little_endian 1.0\nelement vertex ${n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n`);
  const body = Buffer.from(new Float32Array(points).buffer);
  return Buffer.concat([header, body]);
}

// GMMCalib's config: transform_<sensor>: - [roll, pitch, yaw, x, y, z]; ROI; our optional keys.
export function configYaml(rig, extra = '') {
  const lines = [`number_of_sensors: ${Object.keys(rig.nominal).length}`];
  for (const [name, { xyz, rpy }] of Object.entries(rig.nominal)) lines.push(`transform_${name}:`, `  - [${[...rpy, ...xyz].join(', ')}]`);
  lines.push('min_bound:', `  - [${rig.roi.min.join(', ')}]`, 'max_bound:', `  - [${rig.roi.max.join(', ')}]`);
  return Buffer.from(`${lines.join('\n')}\n${extra}`);
}

// Payloads named with their folder path (`<root>/sensor_N/<frame>.ext`), as a folder pick gives.
// The last sensor's frames are PLY, the others PCD.
export function gmmcalibFolder(rig, root, extraYaml = '') {
  const sensors = Object.keys(rig.nominal);
  const files = rig.scans.map((v) => {
    const ply = v.sensor === sensors.at(-1);
    return {
      name: `${root}/${v.sensor}/${v.frame}.${ply ? 'ply' : 'pcd'}`,
      mimeType: 'application/octet-stream',
      buffer: ply ? plyBinary(v.points) : pcdAscii(v.points),
    };
  });
  files.push({ name: `${root}/config.yaml`, mimeType: 'text/yaml', buffer: configYaml(rig, extraYaml) });
  return files;
}

// Rotation (deg) and translation (mm) between a row-major extrinsic and {xyz, rpy}.
export function errorOf(m, { xyz, rpy }) {
  const [cr, sr, cp, sp, cy, sy] = [Math.cos(rpy[0]), Math.sin(rpy[0]), Math.cos(rpy[1]), Math.sin(rpy[1]), Math.cos(rpy[2]), Math.sin(rpy[2])];
  const t = [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr];
  const r = [m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]];
  let trace = 0;
  for (let k = 0; k < 9; k++) trace += r[k] * t[k];
  const deg = (Math.acos(Math.min(1, Math.max(-1, (trace - 1) / 2))) * 180) / Math.PI;
  const mm = Math.hypot(m[3] - xyz[0], m[7] - xyz[1], m[11] - xyz[2]) * 1000;
  return { deg, mm };
}

// An OpenCalib scene (tests/fixtures/opencalib/<scene>) as a folder drop gives it: `<scene>/<file>`
// for every file in it.
export function opencalibFolder(scene) {
  const dir = new URL(`../../tests/fixtures/opencalib/${scene}/`, import.meta.url).pathname;
  return readdirSync(dir).map((name) => ({ name: `${scene}/${name}`, mimeType: 'application/octet-stream', buffer: readFileSync(dir + name) }));
}
