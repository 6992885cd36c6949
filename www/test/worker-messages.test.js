// What one worker hands another (a sensor's global job and its settings, frame pairs to align),
// mutated many ways (seeded): each call returns or throws an Error that says what is wrong, and
// never traps (a Rust panic in wasm is a RuntimeError that leaves the instance unusable).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import init, * as wasm from '../pkg/gmmcalib.js';

// A small seeded generator (mulberry32): the same mutations on every run.
function random(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

const SPECIALS = [NaN, Infinity, -Infinity, 1e30, -1e30, 3e38, 0, -0, 1e-30];

// A copy of typed array `a` with a few numbers replaced, or cut short.
function mutated(a, next) {
  const b = a.slice();
  if (next() < 0.15) return b.slice(0, Math.floor(next() * b.length));
  for (let n = 1 + Math.floor(next() * 3); n > 0 && b.length; n--) {
    b[Math.floor(next() * b.length)] = SPECIALS[Math.floor(next() * SPECIALS.length)];
  }
  return b;
}

// Runs `call`; returns 'result' or 'error', failing on a trap, and on an error whose message
// does not match `message` when one is given.
function survives(call, what, message = /./) {
  try {
    call();
    return 'result';
  } catch (error) {
    if (error instanceof assert.AssertionError) throw error;
    assert.ok(!(error instanceof WebAssembly.RuntimeError), `${what}: trapped: ${error}`);
    assert.ok(error instanceof Error, `${what}: ${error}`);
    assert.match(error.message, message, what);
    return 'error';
  }
}

test('mutated global jobs and frame pairs are errors or results, never a trap', async () => {
  await init({ module_or_path: await readFile(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });
  const next = random(11);

  // A global job: OpenCalib's real road rig, its second sensor's alignment onto the top LiDAR.
  const fixture = new URL('../../tests/fixtures/opencalib/0001/', import.meta.url);
  const text = async (name) => readFile(new URL(name, fixture), 'utf8');
  const road = wasm.parseOpenCalib(await text('lidar_cloud_path.txt'), 'lidar_cloud_path.txt', await text('initial_extrinsic.txt'), 'initial_extrinsic.txt');
  const scans = await Promise.all(road.devices.map(async (d) => ({ sensor: d.name, frame: '1', points: wasm.parseCloud(await readFile(new URL(d.file, fixture)), d.file).points })));
  const session = new wasm.CalibrationSession({ scans, nominal: road.nominal, reference: road.reference, target: { kind: 'none' } });
  assert.equal(session.stage(), 'global');
  const job = session.globalJob(2);
  session.free();
  const outcomes = { result: 0, error: 0 };
  for (let trial = 0; trial < 24; trial++) {
    const part = ['scan', 'reference', 'nominal', 'ground'][trial % 4];
    const bad = { ...job };
    if (part === 'nominal') bad.nominal = Array.from(mutated(Float64Array.from(job.nominal), next));
    else if (part === 'ground') bad.ground = { ...job.ground, normal: Array.from(mutated(Float64Array.from(job.ground.normal), next)) };
    else bad[part] = mutated(job[part], next);
    const what = `global job, ${part}, trial ${trial}`;
    outcomes[survives(() => {
      const { applied } = wasm.alignGlobal(bad);
      assert.ok([...applied.rotation, ...applied.translation].every(Number.isFinite), `${what}: ${JSON.stringify(applied)}`);
    }, what)] += 1;
  }
  const found = wasm.alignGlobal(job);
  assert.ok(found.applied, 'the instance still works after the mutations');

  // Its settings, each number in turn set to one of a few out-of-range values: an Error that
  // names the setting (a grid or a search too large for the page is one), or a result.
  const numbers = (o, path = []) => Object.entries(o).flatMap(([k, v]) => {
    if (typeof v === 'number') return [[...path, k]];
    return v && typeof v === 'object' && !Array.isArray(v) ? numbers(v, [...path, k]) : [];
  });
  const BAD = [0, -1, NaN, 1e-9, 1e9];
  const settings = { result: 0, error: 0 };
  numbers(job.settings).forEach((path, i) => {
    const bad = structuredClone(job.settings);
    const value = BAD[(i + Math.floor(next() * BAD.length)) % BAD.length];
    path.slice(0, -1).reduce((o, k) => o[k], bad)[path.at(-1)] = value;
    const what = `global job, settings.${path.join('.')} = ${value}`;
    settings[survives(() => {
      const { applied } = wasm.alignGlobal({ ...job, settings: bad });
      assert.ok([...applied.rotation, ...applied.translation].every(Number.isFinite), what);
    }, what, /^alignGlobal: /)] += 1;
  });
  console.log(`settings: ${JSON.stringify(settings)}`);
  assert.ok(settings.error > 5 && settings.result > 2, JSON.stringify(settings));
  assert.throws(() => wasm.alignGlobal({ ...job, settings: { ...job.settings, correlate: { ...job.settings.correlate, fine_cell: 1e-6 } } }),
    /alignGlobal: global: correlate's cells are too small for its radius and shift/);

  // Frame pairs: a sampled twin's first pair, its target, source and start mutated.
  const rig = wasm.simulateRig({ preset: 'sampled', sensors: 2, frames: 2, pointsPerView: 600, seed: 5 });
  const pairs = new wasm.CalibrationSession({ scans: rig.scans, nominal: rig.nominal, roi: rig.roi, method: 'gicp' });
  pairs.advance(); // the views prepared
  assert.equal(pairs.stage(), 'framePairs');
  const work = pairs.framePairs();
  const [reference, view] = work.pairs;
  const target = pairs.viewPoints(reference);
  const source = pairs.viewPoints(view);
  const start = work.starts.slice(0, 7);
  pairs.free();
  for (let trial = 0; trial < 60; trial++) {
    const part = ['target', 'source', 'start'][trial % 3];
    const args = { target, source, start };
    args[part] = mutated(args[part], next);
    const what = `frame pair, ${part}, trial ${trial}`;
    outcomes[survives(() => {
      // Per pair: its pose (7 finite numbers) or the message why it has none.
      const [outcome] = wasm.alignPairs(work.icp, args.target, [args.source], args.start);
      assert.ok(typeof outcome === 'string' || outcome.every(Number.isFinite), `${what}: ${outcome}`);
    }, what)] += 1;
  }
  // Both kinds occur: the mutations reach the checks and the computations alike.
  console.log(`outcomes: ${JSON.stringify(outcomes)}`);
  assert.ok(outcomes.result > 10 && outcomes.error > 10, JSON.stringify(outcomes));
  const [aligned] = wasm.alignPairs(work.icp, target, [source], start);
  assert.ok(aligned instanceof Float64Array && aligned.length === 7, 'the instance still works');
});
