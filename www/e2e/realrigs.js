// The real rigs of ../shared/data (its README says where each comes from and under which
// licence), as a user drops them: file payloads named with their folder path. Read at test
// time, never copied into the repository (the Livox scans are GPL). A recording of GMMCalib's
// cube sample is written here too (e2e/mcapfile.js): what a rig that records ROS topics gives.
import { existsSync, readFileSync, readdirSync, statSync } from 'node:fs';
import { join } from 'node:path';
import { tmpdir } from 'node:os';
import { parseCloud } from '../pkg/gmmcalib.js';
import './rigfiles.js'; // initialises the wasm package in Node
import { McapFile, pointCloud2, tfMessage } from './mcapfile.js';

export const DATA = process.env.GMMCALIB_DATA ?? new URL('../../../shared/data/', import.meta.url).pathname;
export const haveData = existsSync(join(DATA, 'README.md'));

const payload = (path, name) => ({ name, mimeType: 'application/octet-stream', buffer: readFileSync(path) });

// Every file under `dir`, named `<as>/<relative path>`.
function folder(dir, as) {
  const out = [];
  const walk = (d, prefix) => {
    for (const entry of readdirSync(d).sort()) {
      const path = join(d, entry);
      if (statSync(path).isDirectory()) walk(path, `${prefix}${entry}/`);
      else out.push(payload(path, `${as}/${prefix}${entry}`));
    }
  };
  walk(dir, '');
  return out.filter((f) => !/LICENSE|README/.test(f.name));
}

// GMMCalib's samples: `cube/data/sensor_N/K.pcd` and `config.yaml` (chair: and `chair.obj`).
export const cubeFolder = () => folder(join(DATA, 'gmmcalib/cube'), 'cube');
export const chairFolder = () => folder(join(DATA, 'gmmcalib/chair'), 'chair');
// OpenCalib's road scenes and its Hesai rig: the scans, lidar_cloud_path.txt, initial_extrinsic.txt.
export const opencalibFolder = (scene) => folder(join(DATA, 'opencalib', scene), scene).filter((f) => !f.name.includes('reference'));
export const hesaiFolder = () => folder(join(DATA, 'hesai'), 'hesai');
// The Livox Mid-100's three units as three loose files (scene1_pose10_L0.pcd ...).
export const livoxFiles = () => [0, 1, 2].map((k) => payload(join(DATA, `livox_mid100/scene1_pose10_L${k}.pcd`), `scene1_pose10_L${k}.pcd`));

// GMMCalib's nominals ([roll, pitch, yaw, x, y, z] per sensor) from its config.yaml.
function gmmcalibNominals(configPath) {
  const text = readFileSync(configPath, 'utf8');
  const out = {};
  for (const m of text.matchAll(/transform_(\w+):\s*\n\s*-\s*\[([^\]]+)\]/g)) {
    const v = m[2].split(',').map(Number);
    out[m[1]] = { rpy: v.slice(0, 3), xyz: v.slice(3, 6) };
  }
  return out;
}

// GMMCalib's cube sample recorded as a ROS 2 rig would record it: an MCAP with
// /lidar_1/points and /lidar_2/points (PointCloud2, frame ids lidar_1 and lidar_2, its three
// frames at 10 Hz, the second sensor 5 ms after the first) and a /tf_static from base_link to
// each sensor with the config's nominals. Returns the file's payload.
export function cubeRecording() {
  const root = join(DATA, 'gmmcalib/cube');
  const nominal = gmmcalibNominals(join(root, 'config.yaml'));
  const path = join(tmpdir(), `gmmcalib-cube-${process.pid}.mcap`);
  const file = new McapFile(path);
  const T0 = 1_700_000_000_000_000_000n;
  const tf = file.channel('/tf_static', 'tf2_msgs/msg/TFMessage');
  const sensors = ['sensor_1', 'sensor_2'];
  const frameId = (s) => `lidar_${s.split('_')[1]}`;
  const topics = sensors.map((s) => file.channel(`/${frameId(s)}/points`, 'sensor_msgs/msg/PointCloud2'));
  file.chunk([{ channel: tf, timeNs: T0, data: tfMessage(sensors.map((s) => ({ parent: 'base_link', child: frameId(s), ...nominal[s] })), T0) }]);
  for (let k = 1; k <= 3; k++) {
    const t = T0 + BigInt(k) * 100_000_000n;
    file.chunk(sensors.map((s, i) => {
      const stamp = t + BigInt(i) * 5_000_000n;
      const points = parseCloud(readFileSync(join(root, `data/${s}/${k}.pcd`)), `${k}.pcd`).points;
      return { channel: topics[i], timeNs: stamp, data: pointCloud2(points, stamp, frameId(s)) };
    }));
  }
  file.close();
  return payload(path, 'cube.mcap');
}
