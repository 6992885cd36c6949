// The package as a user gets it: packed, installed offline into a fresh project, then the
// Node command calibrates twin rigs and runs the drift check, against the native CLI.
// Needs `make package` (the wasm in wasm/) and the native CLI (target/release/gmmcalib).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const pkg = path.resolve(here, '..');
const native = path.resolve(pkg, '../../target/release/gmmcalib');
let dir; // the fresh project
let node; // its installed command

/** Runs `cmd args` in the fresh project: { status, stdout, stderr }. */
function run(cmd, args) {
  const r = spawnSync(cmd, args, { cwd: dir, encoding: 'utf8' });
  if (r.error) throw r.error;
  return { status: r.status, stdout: r.stdout, stderr: r.stderr };
}

before(() => {
  assert.ok(fs.existsSync(native), `${native} missing: cargo build --release --bin gmmcalib`);
  dir = fs.mkdtempSync(path.join(os.tmpdir(), 'gmmcalib-package-'));
  const out = execFileSync('npm', ['pack', '--pack-destination', dir, '--json'], { cwd: pkg, encoding: 'utf8' });
  const tarball = JSON.parse(out)[0].filename;
  fs.writeFileSync(path.join(dir, 'package.json'), JSON.stringify({ name: 'ci-check', private: true, type: 'module' }));
  // No network: an unreachable registry and --offline; the tarball has no dependencies.
  execFileSync('npm', ['install', '--offline', '--no-audit', '--no-fund', `./${tarball}`], {
    cwd: dir,
    env: { ...process.env, npm_config_registry: 'http://127.0.0.1:9/' },
    stdio: 'pipe',
  });
  node = path.join(dir, 'node_modules/.bin/gmmcalib');
  // Twin rigs: a and b the same rig recorded twice; c is b with sensor_2 turned 0.5 deg.
  for (const [name, ...extra] of [['a', '--seed', '1'], ['b', '--seed', '2'], ['c', '--seed', '2', '--move', 'sensor_2:0,0,0.5,0,0,0']]) {
    execFileSync(native, ['simulate', '--out', path.join(dir, name), '--frames', '5', ...extra]);
  }
});

after(() => fs.rmSync(dir, { recursive: true, force: true }));

const calibrateArgs = (rig, json) => ['calibrate', '--data', `${rig}/data`, '--config', `${rig}/config.yaml`, '--json', json];

/** Paths (`a.b[3].c`) where two JSON values differ, with both values. */
function differences(a, b, at = '') {
  if (typeof a !== 'object' || a === null) return Object.is(a, b) ? [] : [[at, a, b]];
  if (Array.isArray(a) && a.length !== b?.length) return [[at, a.length, b?.length]];
  return Object.keys({ ...a, ...b }).flatMap((k) => differences(a[k], b?.[k], Array.isArray(a) ? `${at}[${k}]` : `${at}.${k}`));
}

test('the Node command writes the native CLI calibration bit for bit, and the same text', () => {
  const fromNode = run(node, calibrateArgs('a', 'a.node.json'));
  const fromNative = run(native, calibrateArgs('a', 'a.native.json'));
  assert.equal(fromNode.status, 0, fromNode.stderr);
  assert.equal(fromNative.status, 0, fromNative.stderr);
  const read = (f) => fs.readFileSync(path.join(dir, f), 'utf8');
  // The calibration itself (every sensor's correction, extrinsic and relative pose) is bit for
  // bit the native one. What comes through trig or exp after it may differ in its last digit:
  // Rust's libm in wasm and the system's natively round a few inputs differently (roll, pitch,
  // yaw by asin and atan2, the frames' spread and the precision from them: 1 ulp apart here);
  // the target's shape fit, an iterative fit, by a few micrometres (3e-6 of its size here), as
  // in the recordings' test below; its orientation is left out: on the second cube of this
  // rig it is ill-conditioned (the fits' rotation vectors 1 deg apart on a last-digit change).
  const fit = /^(\.reconstruction\.fits\[\d+\]|\.verdict\.reasons\[\d+\]\.values)\.(rms|size|extents|centre|rotation)/;
  const pose = /^\.sensors\[\d+\]\.(correction|extrinsic|relative)\[/;
  const diff = differences(JSON.parse(read('a.node.json')), JSON.parse(read('a.native.json')));
  assert.deepEqual(diff.filter(([at]) => pose.test(at)), []);
  for (const [at, a, b] of diff.filter(([at]) => !/^\.reconstruction\.fits\[\d+\]\.rotation/.test(at))) {
    const bound = fit.test(at) ? 1e-4 : 1e-14;
    assert.ok(typeof a === 'number' && Math.abs(a - b) <= bound * Math.max(1, Math.abs(b)), `${at}: ${a} vs ${b}`);
  }
  assert.ok(JSON.parse(read('a.node.json')).sensors[1].precision, 'gmm gives a precision');
  assert.equal(fromNode.stdout, fromNative.stdout);
  assert.match(fromNode.stdout, /verdict: GOOD/);
});

test('one input door: a folder per sensor named by timestamps places and pairs as natively', () => {
  // Rig a as a bag export leaves it: front/ and rear/, each scan named by its own time stamp.
  const bag = path.join(dir, 'bag');
  for (const [sensor, folder, offset] of [['sensor_1', 'front', 0], ['sensor_2', 'rear', 0.004]]) {
    fs.mkdirSync(path.join(bag, 'data', folder), { recursive: true });
    for (const name of fs.readdirSync(path.join(dir, 'a/data', sensor))) {
      const stamp = (1700000000 + 0.1 * Number(name.split('.')[0]) + offset).toFixed(3);
      fs.copyFileSync(path.join(dir, 'a/data', sensor, name), path.join(bag, 'data', folder, `${stamp}.pcd`));
    }
  }
  const config = fs.readFileSync(path.join(dir, 'a/config.yaml'), 'utf8').replace('transform_sensor_1:', 'transform_front:').replace('transform_sensor_2:', 'transform_rear:').replace('reference: sensor_1', 'reference: front');
  fs.writeFileSync(path.join(bag, 'config.yaml'), config);
  const args = (json) => [...calibrateArgs('bag', json), '--method', 'jrmpc', '--iterations', '10'];
  const fromNode = run(node, args('bag.node.json'));
  const fromNative = run(native, args('bag.native.json'));
  assert.ok([0, 2].includes(fromNode.status), fromNode.stderr);
  assert.equal(fromNode.stderr, fromNative.stderr);
  assert.match(fromNode.stderr, /rear's frames paired by the nearest timestamp to front's\n/);
  const read = (f) => JSON.parse(fs.readFileSync(path.join(dir, f), 'utf8'));
  const [a, b] = [read('bag.node.json'), read('bag.native.json')];
  assert.deepEqual(a.sensors.map((s) => [s.name, s.spread.frames]), [['front', 5], ['rear', 5]]);
  assert.deepEqual(a.sensors.map((s) => s.extrinsic), b.sensors.map((s) => s.extrinsic));
});

test('recordings under Node: MCAP and ROS 1 bag calibrate to the native JSON, with the same text', () => {
  const fixtures = path.resolve(pkg, '../../tests/fixtures/recording');
  for (const file of ['calib_zstd.mcap', 'calib_bz2.bag']) {
    const args = (out) => ['calibrate', '--bag', path.join(fixtures, file), '--export', 'urdf', '--json', out];
    const fromNode = run(node, args(`${file}.node.json`));
    const fromNative = run(native, args(`${file}.native.json`));
    assert.equal(fromNode.status, fromNative.status, fromNode.stderr);
    // The same text, but the URDF's origins: the nominals come through trig (tf quaternions,
    // rpy), libm's in wasm and the system's natively, so their last digit may differ.
    const digits = (t) => t.replace(/-?\d+\.\d+(e-?\d+)?/g, (m) => Number(m).toPrecision(12));
    assert.equal(digits(fromNode.stdout), digits(fromNative.stdout), file);
    assert.equal(fromNode.stderr, fromNative.stderr, file);
    assert.match(fromNode.stdout, /<robot name="gmmcalib_calibration">/);
    const read = (f) => JSON.parse(fs.readFileSync(path.join(dir, f), 'utf8'));
    // Not bit for bit: the nominals come from /tf_static's quaternions through trig, libm's
    // in wasm and the system's natively, so every later number may differ in its last digits;
    // the target's shape fit, an iterative fit, by a few micrometres (1e-5 of its size).
    const fit = /^(\.reconstruction\.fits\[\d+\]|\.verdict\.reasons\[\d+\]\.values)\.(rms|size|extents|centre|rotation)/;
    const diff = differences(read(`${file}.node.json`), read(`${file}.native.json`));
    for (const [at, a, b] of diff) {
      const bound = fit.test(at) ? 1e-4 : 1e-9;
      assert.ok(typeof a === 'number' && Math.abs(a - b) <= bound * Math.max(1, Math.abs(b)), `${file} ${at}: ${a} vs ${b}`);
    }
  }
});

test('drift check: the same rig passes, a sensor turned 0.5 deg fails and is named', () => {
  for (const rig of ['b', 'c']) assert.equal(run(node, calibrateArgs(rig, `${rig}.json`)).status, 0);
  const still = run(node, ['drift', 'a.node.json', 'b.json', '--json', 'still.json']);
  assert.equal(still.status, 0, still.stdout + still.stderr);
  assert.match(still.stdout, /passed: no sensor moved/);
  const report = JSON.parse(fs.readFileSync(path.join(dir, 'still.json'), 'utf8'));
  assert.equal(report.passed, true);
  assert.ok(report.sensors[0].angle < (0.1 * Math.PI) / 180, JSON.stringify(report.sensors[0]));

  const moved = run(node, ['drift', 'a.node.json', 'c.json']);
  assert.equal(moved.status, 3, moved.stdout + moved.stderr);
  const line = moved.stderr.match(/gmmcalib: drift: sensor_2 moved ([\d.]+) deg/);
  assert.ok(line, moved.stderr);
  assert.ok(Math.abs(Number(line[1]) - 0.5) < 0.1, line[0]);
  // The native CLI says the same.
  const nativeMoved = run(native, ['compare', 'a.node.json', 'c.json']);
  assert.deepEqual(nativeMoved, moved);
});

test('bad input: the same one-line named errors as the native CLI, no stack trace', () => {
  fs.writeFileSync(path.join(dir, 'broken.json'), '{"reference": "sensor_1", "sensors": [}');
  fs.writeFileSync(path.join(dir, 'bad.yaml'), 'transform_sensor_1: [1, 2]\n');
  const cases = [
    ['calibrate', '--data', 'nowhere'],
    ['calibrate', '--data', 'a/data', '--config', 'missing.yaml'],
    ['calibrate', '--data', 'a/data', '--config', 'bad.yaml'],
    ['calibrate', '--data', 'a/data', '--iterations', '0'],
    ['calibrate', '--data', 'a/data', '--bogus', '1'],
    ['drift', 'broken.json', 'b.json'],
    ['compare', 'a.node.json'],
    ['frobnicate'],
  ];
  for (const args of cases) {
    const n = run(node, args);
    const r = run(native, args);
    assert.equal(n.status, 1, `${args.join(' ')}: ${n.stderr}`);
    assert.equal(n.stderr, r.stderr.replace(/, drift, inspect, simulate, experiment or study/, ' or drift'), args.join(' '));
    assert.match(n.stderr, /^gmmcalib: [^\n]+\n$/);
    assert.doesNotMatch(n.stderr, /\n\s+at /);
  }
  assert.match(run(node, ['calibrate', '--data', 'nowhere']).stderr, /nowhere: No such file or directory/);
  assert.match(run(node, ['drift', 'broken.json', 'b.json']).stderr, /broken\.json: line 1 column \d+/);
});

test('the API: import { calibrate } from "gmmcalib" just works, and the types check strictly', () => {
  const script = `
    import { simulateRig, calibrate, compareCalibrations } from 'gmmcalib';
    const rig = simulateRig({ preset: 'sampled', frames: 2, seed: 4 });
    const r = calibrate({ scans: rig.scans, nominal: rig.nominal, roi: rig.roi, method: 'p2l' });
    const text = JSON.stringify({ ...r, reconstruction: {} });
    const d = compareCalibrations(text, 'old.json', text, 'new.json');
    console.log(JSON.stringify({ sensors: r.sensors.length, passed: d.passed, angle: d.sensors[0].angle < 1e-12 }));`;
  fs.writeFileSync(path.join(dir, 'use.mjs'), script);
  const out = JSON.parse(execFileSync('node', ['use.mjs'], { cwd: dir, encoding: 'utf8' }));
  assert.deepEqual(out, { sensors: 2, passed: true, angle: true });

  for (const f of ['types.ts', 'tsconfig.json']) fs.copyFileSync(path.join(here, f), path.join(dir, f));
  const tsc = spawnSync(path.join(pkg, 'node_modules/.bin/tsc'), ['-p', 'tsconfig.json'], { cwd: dir, encoding: 'utf8' });
  assert.equal(tsc.status, 0, tsc.stdout + tsc.stderr);
  // The check can fail: a wrong type is caught.
  fs.writeFileSync(path.join(dir, 'types.ts'), fs.readFileSync(path.join(here, 'types.ts'), 'utf8') + '\nconst wrong: string = drift.passed;\n');
  const bad = spawnSync(path.join(pkg, 'node_modules/.bin/tsc'), ['-p', 'tsconfig.json'], { cwd: dir, encoding: 'utf8' });
  assert.notEqual(bad.status, 0);
  assert.match(bad.stdout, /Type 'boolean' is not assignable to type 'string'/);
});
