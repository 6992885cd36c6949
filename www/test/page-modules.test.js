// Plain modules under Node: framing the view, the ROI's handles, the default
// reference, files named as users name them, the link, a result file read back, the advice.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { frame, robustBounds } from '../src/view/framing.js';
import { alongAxis, handlesOf } from '../src/view/roi-editor.js';
import { mostPoints, rebuildRig } from '../src/state/state.js';
import { readEntries } from '../src/files/files.js';
import { DEFAULTS, explicitSettings, hashOf, readRig } from '../src/state/url.js';
import { readResult } from '../src/panels/result-file.js';
import { adviceForError, adviceForResult, autoRoiFound } from '../src/panels/advice.js';
import { calibrateBlocker } from '../src/panels/summary.js';

test('the view frames the 2nd-98th percentile of the points, and a framed box is wholly in view from every side', () => {
  // A road scene: 10,000 points within 20 m, and 50 returns 200 m away.
  const points = [];
  for (let i = 0; i < 10_000; i++) points.push(20 * Math.sin(i), 20 * Math.cos(i * 1.3), 0.5 * Math.sin(i * 0.7));
  for (let i = 0; i < 50; i++) points.push(200, 200, 30);
  const box = robustBounds([{ sensor: 'top', points: new Float32Array(points) }], { top: [1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 1.8] });
  assert.ok(box.max[0] < 26 && box.max[1] < 21 && box.max[2] < 3, JSON.stringify(box));
  assert.ok(box.min[0] > -16 && box.max[0] > 24, 'placed by the pose (x + 5 m)');
  assert.equal(robustBounds([], {}), null);
  assert.equal(robustBounds([{ sensor: 'a', points: new Float32Array(3) }], {}, { hidden: new Set(['a']) }), null);
  // Every corner of the box projects into the view, for each direction and aspect.
  for (const direction of [[-1.3, -0.5, 0.7], [-0.001, 0, 1.6], [0, -1.6, 0.001], [-1.6, 0, 0.001]]) {
    for (const aspect of [0.6, 1.6]) {
      const { target, position } = frame(box, direction, 50, aspect);
      assert.deepEqual(target, box.min.map((v, i) => (v + box.max[i]) / 2), 'centred');
      const back = position.map((p, i) => p - target[i]);
      const d = Math.hypot(...back);
      const f = back.map((v) => -v / d);
      let right = [f[1], -f[0], 0]; // f x z
      right = Math.hypot(...right) < 1e-9 ? [0, -1, 0] : right.map((v) => v / Math.hypot(...right));
      const up = [right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]];
      const tan = Math.tan((25 * Math.PI) / 180);
      let widest = 0;
      for (let k = 0; k < 8; k++) {
        const c = [k & 1 ? box.max[0] : box.min[0], k & 2 ? box.max[1] : box.min[1], k & 4 ? box.max[2] : box.min[2]].map((v, i) => v - position[i]);
        const depth = c[0] * f[0] + c[1] * f[1] + c[2] * f[2];
        const x = Math.abs(c[0] * right[0] + c[1] * right[1] + c[2] * right[2]) / (depth * tan * aspect);
        const y = Math.abs(c[0] * up[0] + c[1] * up[1] + c[2] * up[2]) / (depth * tan);
        assert.ok(depth > 0 && x <= 1 && y <= 1, `${direction}: corner ${k} at ${x}, ${y}`);
        widest = Math.max(widest, x, y);
      }
      assert.ok(widest > 0.8, `${direction}, ${aspect}: the box fills the view (${widest})`);
    }
  }
});

test('the ROI\'s handles sit on its faces, and a drag follows the pointer\'s ray along the face\'s axis', () => {
  const roi = { min: [8, -3, -1], max: [11, 4, 2] };
  const handles = handlesOf(roi);
  assert.deepEqual(handles.map((h) => h.key), ['min.x', 'min.y', 'min.z', 'max.x', 'max.y', 'max.z']);
  assert.deepEqual(handles[3].point, [11, 0.5, 0.5]);
  // From above, the ray through (12.5, 0.5) meets the x axis through max.x's handle at 12.5.
  assert.ok(Math.abs(alongAxis([11, 0.5, 0.5], 0, { origin: [12.5, 0.4, 20], direction: [0, 0, -1] }) - 12.5) < 1e-12);
  // A slanted ray: the closest point of the two lines.
  const at = alongAxis([0, 0, 0], 2, { origin: [1, 0, 5], direction: [-1, 0, 0] });
  assert.ok(Math.abs(at - 5) < 1e-12, String(at));
  assert.equal(alongAxis([0, 0, 0], 2, { origin: [0, 0, 5], direction: [0, 0, -1] }), null, 'a ray along the axis moves nothing');
});

test('the default reference: the one the config names, else the sensor with the most points', () => {
  const scan = (sensor, n) => ({ sensor, frame: '1', points: new Float32Array(3 * n) });
  const state = { scans: [scan('down', 100), scan('up', 5000), scan('side', 5000)], rig: { sensors: [], nominal: {}, roi: null, reference: '' }, settings: { ...DEFAULTS } };
  assert.equal(mostPoints(state.scans), 'side', 'a tie goes to the first in natural order');
  rebuildRig(state, {});
  assert.equal(state.rig.reference, 'side');
  rebuildRig(state, { reference: 'down' });
  assert.equal(state.rig.reference, 'down', 'named by the config');
  // A reference that cannot be registered against: the sensor to choose instead, named.
  const advice = adviceForError("no frame of sensor 'up' could be registered: every frame failed", { ...state, settings: DEFAULTS });
  assert.match(advice.text, /up could not be registered onto down, the reference\. Choose another reference: side has the most points after down \(or try up\)\./);
  assert.deepEqual(advice.action, { label: 'Make side the reference', what: 'reference', value: 'side' });
  assert.equal(adviceForError('something else', { ...state, settings: DEFAULTS }), null);
});

test('files as users name them: OpenCalib\'s folder reads the devices its list names; a frame_sensor naming reads as sensors', async () => {
  const file = (text) => ({ text: async () => text, arrayBuffer: async () => new ArrayBuffer(12) });
  const entries = ['s/lidar_cloud_path.txt', 's/top.pcd', 's/left.pcd', 's/stitching.pcd'].map((path) => ({ path, file: file('') }));
  const read = {
    opencalib: async () => ({ devices: [{ name: 'top', file: 'top.pcd' }, { name: 'left', file: 'left.pcd' }], reference: 'top', nominal: {} }),
    cloud: async () => ({ points: new Float32Array(3), count: 1, dropped: 0, format: 'PCD' }),
    config: async () => ({}),
  };
  const { scans, bad } = await readEntries(entries, read, () => {});
  assert.deepEqual(scans.map((s) => `${s.sensor}/${s.frame}`), ['left/s', 'top/s']);
  assert.deepEqual(bad, [{ path: 's/stitching.pcd', error: 'ignored: not a device in its folder\'s lidar_cloud_path.txt' }]);
  // Loose files' places (the Livox units' <frame>_<sensor> names among them) are the library's:
  // modules.test.js.
  // Sensors without a shared frame cannot calibrate: Calibrate says so.
  const scans3 = ['L0', 'L1'].map((sensor) => ({ sensor, frame: sensor }));
  assert.match(calibrateBlocker({ scans: scans3, rig: { sensors: ['L0', 'L1'] } }), /No frame is shared by two sensors/);
});

test('the link: settings, the rig\'s ROI, reference and vehicle frame; a demo\'s keys only with a demo', () => {
  const settings = { ...DEFAULTS, method: 'jrmpc', seed: 3, frames: 2 };
  const rig = { roi: { min: [8.5, -3, -1], max: [11, 4, 2] }, reference: 'sensor_2', parent: 'base_link' };
  const hash = hashOf(settings, rig);
  assert.equal(hash, 'method=jrmpc&roi=8.5%2C-3%2C-1%2C11%2C4%2C2&reference=sensor_2&vehicle=base_link', 'no seed without a demo');
  assert.deepEqual(readRig(`#${hash}`), rig);
  assert.deepEqual(explicitSettings(`#${hash}`), { method: 'jrmpc' });
  assert.equal(hashOf({ ...settings, demo: 'paper' }, rig), 'method=jrmpc&demo=paper&frames=2&seed=3&roi=8.5%2C-3%2C-1%2C11%2C4%2C2&vehicle=base_link');
  assert.equal(readRig('#roi=1,2,3,0,5,6').roi, null, 'a box inside out is no ROI');
  // The E-step's device and its exactness are two settings, each by its input's name.
  const exact = hashOf({ ...DEFAULTS, eStepDevice: 'gpu', exact: true });
  assert.equal(exact, 'eStepDevice=gpu&exact=true');
  assert.deepEqual(explicitSettings(`#${exact}`), { eStepDevice: 'gpu', exact: true });
  assert.deepEqual(explicitSettings('#exact=maybe'), {}, 'not a boolean');
  // A link saved when one `estep` setting held both opens with the same choice.
  assert.deepEqual(explicitSettings('#estep=exact'), { exact: true });
  assert.deepEqual(explicitSettings('#estep=gpu'), { eStepDevice: 'gpu' });
});

test('a result file: the JSON of Export read back; anything else named', () => {
  const m = Array.from({ length: 16 }, (_, i) => (i % 5 === 0 ? 1 : 0));
  const report = {
    method: 'gmm', reference: 'a', verdict: { level: 'good', reasons: [], sensors: {} },
    sensors: [{ name: 'a', extrinsic: m, relative: m, correction: m, spread: { xyz: [0, 0, 0], rpy: [0, 0, 0], frames: 1 } }],
    reconstruction: { means: [], sigmas: [], priors: [], fits: [] }, history: { meanSigma: [] }, roi: { min: [0, 0, 0], max: [1, 1, 1] },
  };
  assert.deepEqual(readResult(JSON.stringify(report), 'r.json').results, [report]);
  const all = readResult(JSON.stringify([report, { method: 'p2p', error: 'no points' }]), 'r.json');
  assert.deepEqual(all.failures, [{ method: 'p2p', error: 'no points' }]);
  assert.throws(() => readResult('{"sensors": [', 'r.json'), /^Error: r\.json: not JSON/);
  assert.throws(() => readResult('{"reference": "a", "sensors": []}', 'r.json'), /r\.json: not a gmmcalib result/);
  assert.throws(() => readResult(JSON.stringify({ ...report, roi: null }), 'r.json'), /not a gmmcalib result/);
});

test('what ROI auto held: targets found, objects that were not, none found, or the overlap, as the library says', () => {
  const r = (fits, reasons = [], source = 'overlap', found) => ({ roi: { min: [-20, -13, -2], max: [24, 13, 4], source, found }, reconstruction: { fits }, verdict: { reasons } });
  const cube = { target: 'cube:0.5', roiAuto: true };
  const missing = [{ kind: 'noTarget', text: 'no target stands out of the reconstruction' }];
  assert.match(autoRoiFound(r([{}, {}, {}], [], 'targets', 3), cube).text, /3 targets found; the ROI around them, 44\.0 × 26\.0 × 6\.0 m/);
  // Cube-sized objects stood in the scans, the region went around them, no cube stood out.
  const notIt = autoRoiFound(r([], missing, 'targets', 4), cube);
  assert.equal(notIt.level, 'failed');
  assert.match(notIt.text, /the ROI was put around 4 objects of the target's size .* 44\.0 × 26\.0 × 6\.0 m .*but no cube:0\.5 stood out/);
  // The reconstruction fitted a cube, but the region was not narrowed to it: the overlap.
  assert.match(autoRoiFound(r([{}]), cube).text, /clouds overlap in 44\.0 × 26\.0 × 6\.0 m/);
  const none = autoRoiFound(r([], missing), cube);
  assert.equal(none.level, 'failed');
  assert.match(none.text, /no cube:0\.5 found, so the ROI was the clouds' whole overlap/);
  assert.match(autoRoiFound(r([]), { target: 'none', roiAuto: true }).text, /clouds overlap in 44\.0 × 26\.0 × 6\.0 m/);
  assert.equal(autoRoiFound(r([]), { target: 'none', roiAuto: false }), null, 'a ROI given: nothing to say');
  // The advice on the result says where the auto ROI was, as the library says it.
  const [around] = adviceForResult(r([], missing, 'targets', 4), cube);
  assert.match(around.html, /^No cube:0\.5 found: no target stands out of the reconstruction\. The ROI was auto: around 4 objects of its size standing in the reference's scans, none of which stood out as it\. Set the target to none/);
  const [overlap] = adviceForResult(r([], missing), cube);
  assert.match(overlap.html, /The ROI was auto: with no target found it is where the clouds overlap\./);
  assert.deepEqual(adviceForResult(r([], missing), { target: 'none', roiAuto: true }), []);
});
