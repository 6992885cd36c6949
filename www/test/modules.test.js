// The page's plain modules under Node: file assignment, config parsing, pose maths, exports
// (round trip through GMMCalib YAML), URL settings.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { groupNameless, natural, placeAll, splitNameless } from '../src/files/files.js';
import { readFileSync } from 'node:fs';
import { exportsOf, initSync, parseConfig, placeScans } from '../pkg/gmmcalib.js';
import { inverse, matrixFromXyzRpy, multiply, quaternionOf, rpyOf, xyzOf } from '../src/transforms.js';
import { exportItems, exportTexts, resultJson } from '../src/results/exports.js';
import { DEFAULTS, readHash } from '../src/state/url.js';
import { rebuildRig } from '../src/state/state.js';
import { MIN_MEASURED, RunProgress, StageClock, describeDone, describeProgress, describeTime } from '../src/calibrate/progress.js';

// The config reader is the library's, through the wasm package.
initSync({ module: readFileSync(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });

// The stages each method runs, as the library's `methods()` lists them.
const GMM = ['views', 'jrmpc', 'framePairs', 'finish'];
const JRMPC = ['views', 'jrmpc', 'finish'];

const close = (a, b, tol = 1e-12) => a.every((v, i) => Math.abs(v - b[i]) < tol);

// The page places files by the library's layout (`placeScans`, the CLI's too), as placeAll
// asks it.
const place = async (paths, already = []) => {
  const scans = [...already, ...paths.map((path) => ({ path }))];
  const found = await placeAll(scans, (list) => placeScans(list));
  return { found, scans, rows: scans.map((s) => `${s.sensor}/${s.frame}`) };
};

test('files are placed by folder, else by the last underscore of the name', async () => {
  assert.deepEqual((await place(['data/sensor_2/7.pcd', 'data/sensor_1/7.pcd'])).rows, ['sensor_2/7', 'sensor_1/7']);
  assert.deepEqual((await place(['sensor_2_7.pcd', 'sensor_2_8.pcd', 'left_7.ply', 'left_8.ply'])).rows, ['sensor_2/7', 'sensor_2/8', 'left/7', 'left/8']);
  // One snapshot each under other names: paired, the first sensor's name kept.
  assert.deepEqual((await place(['sensor_2_7.pcd', 'left_003.ply'])).rows, ['sensor_2/003', 'left/003']);
  // A folder of one sensor's named files is that folder's sensor.
  assert.deepEqual((await place(['scans/left_003.ply'])).rows, ['scans/left_003']);
  assert.deepEqual((await place(['scan.bin'])).rows, ['scan/1']);
  assert.deepEqual(['sensor_10', 'sensor_2', 'sensor_1'].sort(natural), ['sensor_1', 'sensor_2', 'sensor_10']);
  // Named by a rig file, by hand or by a recording: left as they are.
  const kept = [{ path: 'x.pcd', sensor: 'top', frame: '0001', named: true }, { path: 'y_2.pcd', sensor: 'rear', frame: '9', manual: true }];
  assert.deepEqual((await place([], kept)).rows, ['top/0001', 'rear/9']);
});

test('recorded scans: a folder per sensor, frames paired by timestamp or order', async () => {
  // A bag export: per-topic folders, stems are timestamps 0.1 s apart, each sensor's own; rear
  // has one scan more and misses one, and 1700000000.55 is nowhere near front's.
  const front = ['1700000000.100', '1700000000.200', '1700000000.300', '1700000000.400'];
  const rear = ['1700000000.103', '1700000000.198', '1700000000.405', '1700000000.550'];
  const bag = await place([...front.map((t) => `bag/lidar_front/${t}.pcd`), ...rear.map((t) => `bag/lidar_rear/${t}.pcd`)]);
  assert.deepEqual(bag.found.pairings, ["lidar_rear's frames paired by the nearest timestamp to lidar_front's (3 of 4; the others have no scan of lidar_front near them)"]);
  assert.deepEqual(bag.rows, [
    ...front.map((t) => `lidar_front/${t}`),
    'lidar_rear/1700000000.100', 'lidar_rear/1700000000.200', 'lidar_rear/1700000000.400', 'lidar_rear/1700000000.550',
  ]);
  // Two of rear's scans near one of front's: only the closer is paired.
  assert.deepEqual((await place(['f/10.pcd', 'f/20.pcd', 'r/19.pcd', 'r/21.5.pcd'])).rows, ['f/10', 'f/20', 'r/20', 'r/21.5']);
  // Names that are not numbers: in natural order.
  const named = await place(['a/scan-2.ply', 'a/scan-10.ply', 'b/x9.ply', 'b/x11.ply', 'b/x12.ply']);
  assert.deepEqual(named.found.pairings, ["b's frames paired in name order with a's (2)"]);
  assert.deepEqual(named.rows, ['a/scan-2', 'a/scan-10', 'b/scan-2', 'b/scan-10', 'b/x12']);
  // One snapshot per sensor folder.
  assert.deepEqual((await place(['x/front/5.pcd', 'x/rear/9.pcd'])).rows, ['front/5', 'rear/5']);
  // Folder by folder, as the folder picker loads them: the second pairs with the first.
  const frontOnly = await place(['front/10.pcd', 'front/20.pcd']);
  assert.deepEqual(frontOnly.found.pairings, []);
  const both = await place(['rear/11.pcd', 'rear/21.pcd'], frontOnly.scans);
  assert.deepEqual(both.found.pairings, ["rear's frames paired by the nearest timestamp to front's"]);
  assert.deepEqual(both.rows, ['front/10', 'front/20', 'rear/10', 'rear/20']);
  // Layouts that already pair are left alone: GMMCalib's, loose <sensor>_<frame> files.
  for (const [paths, rows] of [
    [['d/sensor_1/1.pcd', 'd/sensor_1/2.pcd', 'd/sensor_2/1.pcd', 'd/sensor_2/2.pcd'], ['sensor_1/1', 'sensor_1/2', 'sensor_2/1', 'sensor_2/2']],
    [['left_001.pcd', 'right_001.pcd'], ['left/001', 'right/001']],
  ]) {
    const got = await place(paths);
    assert.deepEqual({ pairings: got.found.pairings, rows: got.rows }, { pairings: [], rows }, paths.join(' '));
  }
  // The Livox Mid-100's units: the sensor last in the name.
  const livox = await place(['scene1_pose10_L0.pcd', 'scene1_pose10_L1.pcd', 'scene1_pose10_L2.pcd']);
  assert.equal(livox.found.sensorsLast, 'scene1_pose10');
  assert.deepEqual(livox.rows, ['L0/scene1_pose10', 'L1/scene1_pose10', 'L2/scene1_pose10']);
  // Two files for one frame of one sensor: the second is named, not placed.
  const twice = await place(['sensor_1/3.pcd', 'sensor_1/3.ply']);
  assert.deepEqual(twice.found.duplicates, [{ first: 'sensor_1/3.pcd', second: 'sensor_1/3.ply', frame: '3' }]);
});

test('GMMCalib config: nested and plain lists, our keys, errors naming file and key', () => {
  const config = parseConfig(
    'number_of_sensors: 2\ntransform_sensor_1:\n  - [0.1, 0.2, 0.3, 1, 2, 3]\ntransform_sensor_2: [0, 0, 0, 4, 5, 6]\n' +
      'min_bound:\n  - [-1, -2, -3]\nmax_bound: [1, 2, 3]\ninitial_sigma: prior\ntarget_edge: 0.4\nother: ignored\n',
    'config.yaml',
  );
  assert.deepEqual(config.nominal.sensor_1, { xyz: [1, 2, 3], rpy: [0.1, 0.2, 0.3] });
  assert.deepEqual(config.nominal.sensor_2.xyz, [4, 5, 6]);
  assert.deepEqual(config.roi, { min: [-1, -2, -3], max: [1, 2, 3] });
  assert.equal(config.initialSigma, 'prior');
  assert.equal(config.target, 'cube:0.4', "GMMCalib's target_edge is the settings' target");
  assert.equal(config.exact, undefined, 'not set');
  // The config's settings reach the page's, `exact` by its own name.
  const state = { scans: [{ sensor: 'sensor_1', points: new Float32Array(3) }], rig: { sensors: [], nominal: {}, roi: null, reference: '' }, settings: { ...DEFAULTS } };
  rebuildRig(state, parseConfig('transform_sensor_1: [0, 0, 0, 1, 2, 3]\nmethod: jrmpc\ncomponents: 50\nexact: true\n', 'c.yaml'));
  assert.deepEqual([state.settings.method, state.settings.components, state.settings.exact], ['jrmpc', 50, true]);
  rebuildRig(state, parseConfig('transform_sensor_1: [0, 0, 0, 1, 2, 3]\nexact: false\n', 'c.yaml'));
  assert.equal(state.settings.exact, false);
  assert.throws(() => parseConfig('exact: maybe\n', 'c.yaml'), /c\.yaml: exact: expected true or false, got maybe/);
  assert.throws(() => parseConfig('transform_a: [1, 2]\n', 'c.yaml'), /c\.yaml: transform_a: expected \[roll, pitch, yaw, x, y, z\], \[x, y, z, qx, qy, qz, qw\] or a 4x4 row-major, got 2 numbers/);
  assert.throws(() => parseConfig('a: [1, 2\n', 'c.yaml'), /c\.yaml: bad YAML/);
  assert.throws(() => parseConfig('- 1\n', 'c.yaml'), /c\.yaml: expected a mapping/);
  assert.throws(() => parseConfig('min_bound: [1, 2, 3]\n', 'c.yaml'), /c\.yaml: missing key max_bound/);
});

test('pose maths: rpy and quaternion of a matrix, inverse', () => {
  const xyz = [1, -2, 0.5];
  const rpy = [0.3, -0.2, 2.5];
  const m = matrixFromXyzRpy(xyz, rpy);
  assert.ok(close(rpyOf(m), rpy) && close(xyzOf(m), xyz));
  assert.ok(close(multiply(m, inverse(m)), matrixFromXyzRpy([0, 0, 0], [0, 0, 0])));
  // 90 deg about z: q = (0, 0, sin 45, cos 45).
  assert.ok(close(quaternionOf(matrixFromXyzRpy([0, 0, 0], [0, 0, Math.PI / 2])), [0, 0, Math.SQRT1_2, Math.SQRT1_2]));
  assert.ok(close(quaternionOf(matrixFromXyzRpy([0, 0, 0], [Math.PI, 0, 0])), [1, 0, 0, 0]));
});

test('exports: the result\'s own texts, the library\'s again for a renamed frame (YAML round trip, ROS forms, PLY)', async () => {
  const extrinsic = matrixFromXyzRpy([2.3, -0.6, 1.6], [-0.35, 0.01, -0.02]);
  const roi = { min: [1, -2, -0.5], max: [3, 2, 1] };
  const result = {
    sensors: [{ name: 'a', extrinsic: matrixFromXyzRpy([0, 0, 1], [0, 0, 0]) }, { name: 'b_frame', extrinsic }],
    reconstruction: { means: new Float32Array([1, 2, 3, 4, 5, 6]), sigmas: new Float32Array([0.1, 0.2]), priors: new Float32Array([0.5, 0]) },
    roi: { ...roi, source: 'given' },
    exports: { parent: 'vehicle', json: '{ "the": "CLI\'s" }\n', urdf: 'as made' },
  };
  const remade = [];
  const remake = async (input) => (remade.push(input.parent), exportsOf(input));
  // The frame named at the run: the result's own texts, nothing made again.
  assert.equal((await exportTexts(result, 'vehicle', remake)).urdf, 'as made');
  assert.deepEqual(remade, []);
  // A renamed frame: the library's writers again; the JSON (no frame in it) as it was.
  const items = exportItems(await exportTexts(result, 'base_link', remake));
  assert.deepEqual(remade, ['base_link']);
  const text = (key) => items.find((i) => i.key === key).text;
  assert.equal(text('json'), result.exports.json);
  // GMMCalib's YAML reads back to the same extrinsics and ROI.
  const back = parseConfig(text('yaml'), 'out.yaml');
  const b = back.nominal.b_frame;
  assert.ok(close(matrixFromXyzRpy(b.xyz, b.rpy), extrinsic, 1e-12));
  assert.deepEqual(back.roi, roi);
  // One name per sensor in every export, the parent's name too.
  assert.match(text('yaml'), /^transform_b_frame: {2}# b_frame -> base_link\n/m);
  assert.deepEqual(items.map((i) => i.key), ['json', 'yaml', 'urdf', 'ros2', 'ros1', 'tfYaml', 'autoware', 'kitti', 'ply']);
  const joint = text('urdf').match(/<parent link="base_link"\/>\n\s*<child link="b_frame"\/>\n\s*<origin xyz="([^"]+)" rpy="([^"]+)"\/>/);
  assert.ok(joint && close(joint[1].split(' ').map(Number), [2.3, -0.6, 1.6], 1e-12) && close(joint[2].split(' ').map(Number), [-0.35, 0.01, -0.02], 1e-12), text('urdf'));
  assert.match(text('ros2'), /^ros2 run tf2_ros static_transform_publisher --x 2\.3 --y -0\.6 --z 1\.6 --qx \S+ --qy \S+ --qz \S+ --qw \S+ --frame-id base_link --child-frame-id b_frame$/m);
  assert.match(text('ros1'), /static_transform_publisher 2\.3 -0\.6 1\.6 \S+ \S+ \S+ base_link b_frame$/m);
  // The components holding data, as the f32 the file declares.
  assert.match(text('ply'), /\(base_link frame, m\)\nelement vertex 1\n/);
  assert.match(text('ply'), /end_header\n1 2 3 0\.1 0\.5\n$/);
  // The JSON view: typed arrays as plain arrays, the exports left to their panel.
  const view = JSON.parse(resultJson(result));
  assert.deepEqual(view.reconstruction.means, [1, 2, 3, 4, 5, 6]);
  assert.equal(view.exports, undefined);
});

test('URL hash: known keys only, numbers checked, defaults otherwise', () => {
  const s = readHash('#method=jrmpc&seed=7&frames=x&evil=1&demo=paper');
  assert.equal(s.method, 'jrmpc');
  assert.equal(s.seed, 7);
  assert.equal(s.frames, DEFAULTS.frames);
  assert.equal(s.demo, 'paper');
  assert.ok(!('evil' in s));
});

test('progress: every stage has its share of one bar, each with its own wording', () => {
  const em = { stage: 'jrmpc', iteration: 50, maxIterations: 100, meanSigma: 0.0123 };
  const pairs = { stage: 'framePairs', iteration: 3, maxIterations: 4, meanSigma: 0 };
  const near = (a, b) => Math.abs(a - b) < 1e-12;
  // gmm with a target, no global stage: views 0.3, JRMPC 0.42, pairs 0.15, finish 0.05.
  const total = 0.3 + 0.42 + 0.15 + 0.05;
  assert.ok(near(describeProgress(GMM, em).fraction, (0.3 + 0.21) / total));
  assert.equal(describeProgress(GMM, em, 5).text, 'JRMPC iteration 50/100, σ 1.23 cm, about 5.0 s left, then the frame pairs');
  assert.ok(near(describeProgress(GMM, pairs).fraction, (0.3 + 0.42 + 0.75 * 0.15) / total));
  assert.equal(describeProgress(GMM, pairs, 1).text, 'frame pair 3/4, about 1.0 s left');
  assert.equal(describeProgress(GMM, pairs, null).text, 'frame pair 3/4');
  assert.doesNotMatch(describeProgress(JRMPC, em, 5).text, /frame pairs/);
  assert.equal(describeProgress(GMM, { ...pairs, iteration: 4 }, null).text, 'frame pair 4/4');
  const global = { stage: 'global', iteration: 1, maxIterations: 2, meanSigma: 0 };
  assert.equal(describeProgress(['global', ...GMM], global).text, 'global alignment: 1 of 2 sensors aligned');
  // The run's own steps say what they do.
  assert.match(describeProgress(GMM, { stage: 'views', iteration: 0, maxIterations: 1 }).text, /^levelling the grounds/);
  assert.equal(describeProgress(GMM, { stage: 'finish', iteration: 0, maxIterations: 1 }).text, 'the plane adjustment and the verdict');
});

test('a run\'s time and bar: elapsed always, the time left once measured, the bar moving between messages and through the steps', () => {
  const stages = ['global', 'views', 'framePairs', 'finish'];
  const run = new RunProgress(['gmm'], 100);
  assert.deepEqual(run.at(103), { fraction: 0, text: null, elapsed: 3, left: null });
  const g = (iteration) => ({ method: 'gmm', stage: 'global', stages, iteration, maxIterations: 3, meanSigma: 0 });
  assert.equal(run.message(g(0), 101).left, null);
  assert.equal(run.at(108).left, null, 'no sensor aligned yet: no estimate');
  assert.ok(run.at(108).fraction > run.at(102).fraction, 'the bar creeps before any measure');
  assert.ok(run.at(1000).fraction < describeProgress(stages, g(1)).fraction, 'never to the first sensor\'s mark');
  const one = run.message(g(1), 110); // 9 s for the first sensor
  assert.equal(one.left, 18);
  assert.equal(run.at(114).left, 14, 'the estimate counts down');
  assert.ok(run.at(114).fraction > one.fraction, 'the bar moves between messages');
  assert.ok(run.at(150).fraction < describeProgress(stages, g(2)).fraction, 'never to the next sensor\'s mark');
  assert.equal(describeTime(run.at(114)), '14.0 s elapsed, about 14 s left in this stage');
  assert.equal(describeTime({ elapsed: 2.04, left: null }), '2.0 s elapsed');
  const done = run.message(g(3), 120);
  // The views' step begun: the bar creeps through its share and the status says what it does.
  const step = (stage, at) => run.message({ method: 'gmm', stage, stages, iteration: 0, maxIterations: 1, meanSigma: 0 }, at);
  const views = step('views', 120);
  assert.equal(views.text, 'levelling the grounds, the bird\'s-eye search and the crop to the ROI');
  assert.ok(views.fraction >= done.fraction);
  const pair = (iteration) => ({ method: 'gmm', stage: 'framePairs', stages, iteration, maxIterations: 3, meanSigma: 0 });
  assert.ok(run.at(130).fraction > views.fraction && run.at(1000).fraction < describeProgress(stages, pair(0)).fraction, 'never past its share');
  // Frame pairs: one pair is a measure.
  assert.equal(run.message(pair(0), 135).left, null, 'a new stage measures again');
  assert.equal(run.message(pair(1), 141).left, 12);
  assert.equal(run.at(141).text, 'frame pair 1/3');
  run.message(pair(3), 150);
  assert.equal(step('finish', 150).text, 'the plane adjustment and the verdict');
  // Comparing methods: each has its part of the bar and is named.
  const all = new RunProgress(['gmm', 'p2l'], 0);
  const p2l = all.message({ method: 'p2l', stage: 'views', stages: ['views', 'framePairs', 'finish'], iteration: 0, maxIterations: 1, meanSigma: 0 }, 5);
  assert.match(p2l.text, /^p2l \(2\/2\): levelling the grounds/);
  assert.ok(p2l.fraction >= 0.5 && p2l.fraction < 0.75);
});

test('the time left comes from measured iterations, not from the setup before the first', () => {
  const clock = new StageClock();
  const p = (iteration) => ({ iteration, maxIterations: 100 });
  // Iteration 1 arrives 2 s in (setup), then one every 0.02 s: 2.1 s in all.
  assert.equal(clock.left(p(1), 2.0), null);
  for (let i = 2; i <= MIN_MEASURED; i++) assert.equal(clock.left(p(i), 2.0 + 0.02 * (i - 1)), null);
  const left = clock.left(p(MIN_MEASURED + 1), 2.0 + 0.02 * MIN_MEASURED);
  assert.ok(Math.abs(left - 0.02 * (100 - MIN_MEASURED - 1)) < 1e-9, String(left));
  assert.equal(clock.left(p(100), 4.0), null, 'nothing left at the end');
});

test('the status once done: iterations for the GMM methods, frame pairs for ICP, methods for compare all', () => {
  const sensors = [{ name: 'a', spread: { frames: 4 } }, { name: 'b', spread: { frames: 3 } }, { name: 'c', spread: { frames: 4 } }];
  const gmm = { reference: 'a', iterations: 100, converged: false, workers: 2, sensors };
  assert.equal(describeDone([gmm], 1.234), 'Done: 100 iterations in 1.2 s on 2 workers.');
  assert.equal(describeDone([{ ...gmm, iterations: 40, converged: true, workers: 1 }], 0.5), 'Done: 40 iterations (converged) in 0.5 s.');
  assert.equal(describeDone([{ ...gmm, exact: true }], 9.87), 'Done: 100 iterations in 9.9 s on 2 workers, exact E-step.');
  assert.equal(describeDone([{ ...gmm, iterations: 0, converged: true }], 0.1), 'Done: 7 frame pairs registered in 0.1 s on 2 workers.');
  assert.equal(describeDone([gmm, gmm], 3), 'Done: 2 methods in 3.0 s on 2 workers.');
  const failed = [{ method: 'p2p', error: 'x' }, { method: 'p2l', error: 'y' }];
  assert.equal(describeDone([gmm], 3, failed), 'Done: 1 of 3 methods in 3.0 s on 2 workers; p2p, p2l failed (see Results).');
});

test('view colours: robust range, the ramp, distance to a plane of reference points', async () => {
  const { robustRange, ramp, SurfaceGrid, leastAxis } = await import('../src/view/colouring.js');
  // GMMCalib's intensity: mostly about 45, a few bright returns up to 5615.
  const values = Array.from({ length: 1000 }, (_, i) => (i < 990 ? 30 + (i % 30) : 5615));
  const [lo, hi] = robustRange(values);
  assert.ok(lo >= 30 && hi <= 60, `${lo}..${hi}`);
  assert.deepEqual(ramp(0).map(Math.round), [0, 0, 1]);
  assert.deepEqual(ramp(1).map(Math.round), [1, 0, 0]);
  const { normal } = leastAxis([1, 0, 0, 2, 0, 0.001]);
  assert.ok(Math.abs(Math.abs(normal[2]) - 1) < 1e-9);
  // A tilted plane z = 0.1 x sampled on a grid: a point 3 cm off it along its normal.
  const grid = new SurfaceGrid();
  for (let x = -1; x <= 1; x += 0.04) for (let y = -1; y <= 1; y += 0.04) grid.add(x, y, 0.1 * x);
  const n = [-0.1, 0, 1].map((v) => v / Math.hypot(0.1, 1));
  const d = grid.distance(0.2 + 0.03 * n[0], 0.1, 0.02 + 0.03 * n[2]);
  assert.ok(Math.abs(d - 0.03) < 1e-3, String(d));
  // Points on a line only (one ring) or none near: no surface.
  const ring = new SurfaceGrid();
  for (let x = -1; x <= 1; x += 0.01) ring.add(x, 0, 0);
  assert.ok(Number.isNaN(ring.distance(0, 0.05, 0)));
  assert.ok(Number.isNaN(grid.distance(5, 5, 5)));
});

test('loose files without a sensor in their names: one sensor with several frames, said and undoable', async () => {
  const { found, scans } = await place(['1.pcd', '2.pcd', '10.pcd', 'left_1.pcd', 'rig/sensor_1/1.pcd']);
  assert.deepEqual(found.nameless, ['1.pcd', '2.pcd', '10.pcd']);
  const nameless = scans.filter((s) => found.nameless.includes(s.path));
  const group = groupNameless(nameless, ['sensor_1']);
  assert.equal(group.sensor, 'sensor_2');
  assert.deepEqual(scans.map((s) => `${s.sensor}/${s.frame}`), ['sensor_2/1', 'sensor_2/2', 'sensor_2/10', 'left/1', 'sensor_1/1']);
  splitNameless(group.scans);
  assert.deepEqual(scans.slice(0, 3).map((s) => `${s.sensor}/${s.frame}`), ['1/1', '2/1', '10/1']);
  assert.equal(groupNameless(nameless.slice(0, 1)), null, 'one file: nothing to ask');
});
