// The worker pool under Node: how views are split, and that the driven session gives
// `calibrate`'s result exactly, on one worker and on several (Node has no Web Workers: the
// remote workers here are the same wasm calls in this thread, behind the same promises; the
// Chromium test runs real ones).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import init, * as wasm from '../pkg/gmmcalib.js';
import { calibrateSharded, pairGroups, splitViews } from '../src/calibrate/shard-pool.js';

test('views are split into contiguous slices of about equal points, none empty', () => {
  assert.deepEqual(splitViews([5, 5, 5, 5], 2), [{ first: 0, count: 2 }, { first: 2, count: 2 }]);
  assert.deepEqual(splitViews([100, 1, 1, 1], 2), [{ first: 0, count: 1 }, { first: 1, count: 3 }]);
  assert.deepEqual(splitViews([1, 1, 1, 100], 2), [{ first: 0, count: 3 }, { first: 3, count: 1 }]);
  assert.deepEqual(splitViews([3, 4], 3), [{ first: 0, count: 1 }, { first: 1, count: 1 }]);
  assert.deepEqual(splitViews([3, 4, 5], 1), [{ first: 0, count: 3 }]);
  assert.deepEqual(splitViews([], 2), []);
  const sizes = Array.from({ length: 212 }, (_, i) => 1500 + ((i * 37) % 700));
  const slices = splitViews(sizes, 4);
  assert.equal(slices.reduce((n, s) => n + s.count, 0), 212);
  const loads = slices.map(({ first, count }) => sizes.slice(first, first + count).reduce((a, b) => a + b, 0));
  const mean = sizes.reduce((a, b) => a + b, 0) / 4;
  for (const load of loads) assert.ok(Math.abs(load - mean) < 2200, `${loads}`);
});

test('frame pairs are grouped by reference view, the largest halved while workers would idle', () => {
  // pairs: referenceView, view per pair.
  const pairs = [0, 1, 0, 2, 3, 4, 0, 5, 3, 6];
  assert.deepEqual(pairGroups(pairs, 1), [[0, [0, 1, 3]], [3, [2, 4]]]);
  assert.deepEqual(pairGroups(pairs, 2), [[0, [0, 1, 3]], [3, [2, 4]]]);
  assert.deepEqual(pairGroups(pairs, 3), [[0, [0, 1]], [0, [3]], [3, [2, 4]]]);
  assert.deepEqual(pairGroups(pairs, 9), [[0, [0]], [0, [1]], [0, [3]], [3, [2]], [3, [4]]]);
  // A targetless scene of one frame: one reference view, its pairs shared when workers allow.
  assert.deepEqual(pairGroups([2, 0, 2, 1], 2), [[2, [0]], [2, [1]]]);
  assert.deepEqual(pairGroups([2, 0], 4), [[2, [0]]]);
  assert.deepEqual(pairGroups([], 2), []);
});

// A remote worker in this thread: shard-worker.js's calls, answered as promises.
const inProcess = () => {
  let shard = null;
  return {
    ready: async () => null,
    init: async (points, sizes) => { shard = new wasm.JrmpcShard(points, sizes); },
    eStep: async (input, first) => shard.eStep(input, first),
    align: async (icp, target, sources, starts) => wasm.alignPairs(icp, target, sources, starts),
    alignGlobal: async (job) => wasm.alignGlobal(job),
    terminate: () => shard?.free(),
  };
};

test('the driven session gives calibrate\'s result, and bad shard data is an error', async () => {
  await init({ module_or_path: await readFile(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });
  const rig = wasm.simulateRig({ preset: 'sampled', sensors: 2, frames: 3, pointsPerView: 800, seed: 5 });
  const input = () => ({ scans: rig.scans, nominal: rig.nominal, roi: rig.roi, components: 150, iterations: 30 });
  const progress = [];
  const direct = wasm.calibrate(input(), () => true);
  const driven = await calibrateSharded(wasm, input(), 1, (p) => progress.push(p));
  assert.deepEqual(driven.sensors, direct.sensors);
  assert.deepEqual(driven.history, direct.history);
  assert.deepEqual(Array.from(driven.reconstruction.means), Array.from(direct.reconstruction.means));
  assert.equal(progress.filter((p) => p.stage === 'jrmpc').length, direct.iterations);
  // Every stage the plan names is said, in its order; the run's own steps as they begin.
  const said = progress.map((p) => p.stage).filter((stage, i, all) => stage !== all[i - 1]);
  assert.deepEqual(said, progress[0].stages);
  assert.deepEqual(said, ['views', 'jrmpc', 'framePairs', 'finish'], 'the sampled twin\'s scans show no ground to align by');
  // gmm's frame pairs come after EM's iterations: their beginning (none done), then one
  // progress each, however they are shared; each of the 3 frames is refined from every start
  // the selection weighs (JRMPC's result, the nominal, ...).
  const pairs = progress.filter((p) => p.stage === 'framePairs');
  const count = pairs.length - 1;
  assert.ok(count >= 3 && count % 3 === 0, `${count} frame pairs`);
  assert.deepEqual(pairs.map((p) => [p.stage, p.iteration]).sort(), Array.from({ length: count + 1 }, (_, i) => ['framePairs', i]).sort());
  assert.equal(pairs[0].iteration, 0, 'the stage begins before its first pair is done');
  for (const workers of [2, 3]) {
    const shared = [];
    const result = await calibrateSharded(wasm, input(), workers, (p) => shared.push(p), inProcess);
    assert.deepEqual(result.sensors, direct.sensors);
    assert.deepEqual(result.history, direct.history);
    assert.deepEqual(Array.from(result.reconstruction.means), Array.from(direct.reconstruction.means));
    assert.equal(result.workers, workers);
    assert.equal(shared.filter((p) => p.maxIterations === pairs[0].maxIterations).length, count + 1);
  }
  // A pool worker that fails mid-way fails the calibration with its message, once every loop
  // has stopped (none touches the freed session afterwards).
  let alignCalls = 0;
  const failing = () => ({
    ...inProcess(),
    align: async (...args) => {
      if (++alignCalls === 2) throw new Error('a calculation worker failed: boom');
      return wasm.alignPairs(...args);
    },
  });
  const proto = wasm.CalibrationSession.prototype;
  const original = { free: proto.free, registerPairs: proto.registerPairs, recordPair: proto.recordPair, viewPoints: proto.viewPoints };
  const late = [];
  proto.free = function free() { this.freed = true; return original.free.call(this); };
  for (const name of ['registerPairs', 'recordPair', 'viewPoints']) {
    proto[name] = function (...args) {
      if (this.freed) late.push(name);
      return original[name].apply(this, args);
    };
  }
  try {
    const many = wasm.simulateRig({ preset: 'sampled', sensors: 2, frames: 8, pointsPerView: 400, seed: 2 });
    const manyInput = { scans: many.scans, nominal: many.nominal, roi: many.roi, components: 100, iterations: 5 };
    await assert.rejects(calibrateSharded(wasm, manyInput, 2, () => true, failing), /boom/);
    await new Promise((resolve) => setTimeout(resolve, 100));
  } finally {
    Object.assign(proto, original);
  }
  assert.deepEqual(late, [], 'nothing touches the session once it is freed');
  // An ICP method has no E-step: its frame pairs alone are shared.
  const icp = () => ({ ...input(), method: 'p2l' });
  const icpDriven = await calibrateSharded(wasm, icp(), 2, () => true, inProcess);
  assert.deepEqual(icpDriven.sensors, wasm.calibrate(icp()).sensors);
  assert.equal(icpDriven.workers, 2);
  // Without a target and with one frame there is no EM and one group of frame pairs: the
  // remote is never started (it would only take a core to load its wasm), and the result says
  // one worker did the work.
  const lone = wasm.simulateRig({ preset: 'sampled', sensors: 2, frames: 1, pointsPerView: 800, seed: 5 });
  const loneInput = () => ({ scans: lone.scans, nominal: lone.nominal, target: { kind: 'none' } });
  let spawned = 0;
  const counted = () => {
    spawned += 1;
    return inProcess();
  };
  const loneDriven = await calibrateSharded(wasm, loneInput(), 2, () => true, counted);
  assert.deepEqual(loneDriven.sensors, wasm.calibrate(loneInput()).sensors);
  assert.equal(spawned, 0);
  assert.equal(loneDriven.workers, 1);
  // OpenCalib's real road rig, three LiDARs: the global stage has two sensors to align, so a
  // remote takes one (its job through structured clone, as between workers) while this worker
  // aligns the other, and likewise one of the two frame pairs; the result is calibrate's
  // whole, the verdict and notes included.
  const fixture = new URL('../../tests/fixtures/opencalib/0001/', import.meta.url);
  const text = async (name) => readFile(new URL(name, fixture), 'utf8');
  const road = wasm.parseOpenCalib(await text('lidar_cloud_path.txt'), 'lidar_cloud_path.txt', await text('initial_extrinsic.txt'), 'initial_extrinsic.txt');
  const roadScans = await Promise.all(road.devices.map(async (d) => ({ sensor: d.name, frame: '1', points: wasm.parseCloud(await readFile(new URL(d.file, fixture)), d.file).points })));
  const trioInput = () => ({ scans: roadScans, nominal: road.nominal, reference: road.reference, target: { kind: 'none' } });
  const remoteSensors = [];
  let remotePairs = 0;
  const cloned = () => ({
    ...inProcess(),
    align: async (icp, target, sources, starts) => {
      remotePairs += sources.length;
      return wasm.alignPairs(icp, target, sources, starts);
    },
    alignGlobal: async (job) => {
      remoteSensors.push(job.seed);
      return structuredClone(wasm.alignGlobal(structuredClone(job)));
    },
  });
  const seen = { driven: [], direct: [] };
  const { workers: trioWorkers, ...trioDriven } = await calibrateSharded(wasm, trioInput(), 2, (p) => seen.driven.push(p), cloned);
  const { workers: one, ...trioDirect } = wasm.calibrate(trioInput(), (p) => seen.direct.push(p) > 0);
  assert.deepEqual(trioDriven, trioDirect);
  // The global stage reports as it begins and after each sensor, before the frame pairs, with
  // each aligned sensor's motion as its correction.
  for (const progress of Object.values(seen)) {
    const global = progress.filter((p) => p.stage === 'global');
    assert.deepEqual(global.map((p) => [p.iteration, p.maxIterations]), [[0, 2], [1, 2], [2, 2]]);
    assert.ok(progress.slice(0, 3).every((p) => p.stage === 'global' && p.method === 'gmm'));
    assert.deepEqual(global[0].corrections[1], [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    assert.notDeepEqual(global[2].corrections[1], global[0].corrections[1], 'OpenCalib\'s far-off start moved');
  }
  assert.equal(remoteSensors.length, 1);
  // One reference view, its pairs (each side sensor from each start the selection weighs)
  // shared between the two workers.
  assert.ok(remotePairs >= 1, 'the lone reference view\'s pairs are shared too');
  assert.equal(typeof remoteSensors[0], 'bigint', 'the seed crosses as a BigInt, never rounded');
  assert.equal(trioWorkers, 2);
  // The global stage's calls, out of turn or with bad data, are errors, not crashes.
  const aligning = new wasm.CalibrationSession(trioInput());
  assert.equal(aligning.stage(), 'global');
  assert.deepEqual(Array.from(aligning.globalJobs()), [1, 2]);
  assert.equal(aligning.globalProgress().iteration, 0);
  assert.throws(() => aligning.globalJob(0), /sensor 0 is not waiting for its global alignment/);
  assert.throws(() => aligning.alignGlobally(Uint32Array.of(7)), /sensor 7 is not waiting/);
  const job = aligning.globalJob(2);
  assert.throws(() => wasm.alignGlobal({ ...job, scan: new Float32Array(4) }), /scan's 4 numbers are not points/);
  assert.throws(() => wasm.alignGlobal({ ...job, reference: new Float64Array(5) }), /reference's 5 numbers are not points/);
  assert.throws(() => wasm.alignGlobal({ ...job, nominal: [0, 0, 0, 2, 0, 0, 0] }), /unit quaternion/);
  assert.throws(() => wasm.alignGlobal({ ...job, settings: 'fast' }), /alignGlobal: invalid job/);
  assert.throws(() => aligning.recordGlobal(2, { applied: 'here' }), /not a global alignment/);
  const found = wasm.alignGlobal(job);
  const skewed = structuredClone(found);
  skewed.applied.rotation[3] *= 2;
  assert.throws(() => aligning.recordGlobal(2, skewed), /unit quaternion/);
  assert.equal(aligning.recordGlobal(2, found).iteration, 1);
  assert.throws(() => aligning.recordGlobal(2, found), /sensor 2 is not waiting/);
  assert.equal(aligning.alignGlobally(Uint32Array.of(1)).iteration, 2);
  assert.deepEqual(Array.from(aligning.globalJobs()), []);
  aligning.advance();
  assert.equal(aligning.stage(), 'views', 'the views are prepared from the alignments');
  assert.throws(() => aligning.globalJobs(), /not in its global stage/);
  assert.throws(() => aligning.globalProgress(), /not in its global stage/);
  aligning.free();
  // Compare all through the pool: the session runs every method in turn, as `calibrate` does.
  const all = () => ({ ...input(), method: 'all', iterations: 10 });
  const compared = await calibrateSharded(wasm, all(), 2, () => true, inProcess);
  const expected = wasm.calibrate(all());
  assert.deepEqual(compared.map((r) => r.method), ['gmm', 'jrmpc', 'cad', 'p2p', 'p2l', 'gicp']);
  for (const [a, b] of compared.map((r, i) => [r, expected[i]])) assert.deepEqual(a.sensors, b.sensors, a.method);

  const session = new wasm.CalibrationSession(input());
  assert.throws(() => session.mStep([new Float64Array(7)]), /not in its jrmpc stage/, 'the views are not prepared yet');
  session.advance();
  assert.throws(() => session.mStep([new Float64Array(7)]), /not a whole number of views/);
  assert.throws(() => session.shardPoints(5, 2), /views 5\.\.5\+2 of 6/);
  const shardOf = (driven) => new wasm.JrmpcShard(driven.shardPoints(0, driven.viewSizes().length), driven.viewSizes());
  const shard = new wasm.JrmpcShard(session.shardPoints(0, 1), session.viewSizes().slice(0, 1));
  assert.throws(() => shard.eStep(new Float64Array([1, 2, 3]), 0), /malformed E-step input/);
  const estep = session.eStepInput();
  assert.equal(estep[3], 0, 'the fast E-step unless exact');
  assert.throws(() => shard.eStep(Float64Array.of(...estep.slice(0, 3), 0.5, ...estep.slice(4)), 0), /malformed E-step input/);
  estep[4] = NaN; // the first mean's x
  assert.throws(() => shard.eStep(estep, 0), /not finite/);
  assert.throws(() => new wasm.JrmpcShard(new Float64Array(5), new Uint32Array([2])), /5 coordinates for 2 points/);
  shard.free();
  session.free();

  // Frame pairs: a bad plan, cloud, start or outcome is an error, not a crash.
  const pairsOf = new wasm.CalibrationSession(input());
  assert.equal(pairsOf.stage(), 'views');
  assert.deepEqual([pairsOf.progress().stage, pairsOf.progress().iteration], ['views', 0]);
  pairsOf.advance();
  assert.equal(pairsOf.stage(), 'jrmpc');
  assert.throws(() => pairsOf.framePairs(), /not registering frame pairs/);
  while (!pairsOf.finished()) pairsOf.mStep([shardOf(pairsOf).eStep(pairsOf.eStepInput(), 0)]);
  pairsOf.advance();
  assert.equal(pairsOf.stage(), 'framePairs');
  const work = pairsOf.framePairs();
  const [reference, view] = work.pairs;
  const target = pairsOf.viewPoints(reference);
  const source = pairsOf.viewPoints(view);
  const start = work.starts.slice(0, 7);
  const [aligned] = wasm.alignPairs(work.icp, target, [source], start);
  assert.ok(aligned instanceof Float64Array && aligned.length === 7);
  assert.throws(() => wasm.alignPairs({ settings: { metric: 'nope' } }, target, [source], start), /invalid icp/);
  assert.throws(() => wasm.alignPairs(work.icp, target, [source], start.slice(0, 6)), /6 numbers of starts for 1 sources/);
  assert.throws(() => wasm.alignPairs(work.icp, target.slice(0, 4), [source], start), /target's 4 numbers/);
  assert.throws(() => wasm.alignPairs(work.icp, target, [[1, 2, 3]], start), /source 0 is not a Float32Array/);
  assert.throws(() => wasm.alignPairs(work.icp, target, [source], new Float64Array(7)), /unit quaternion/);
  const [tooFew] = wasm.alignPairs(work.icp, new Float32Array(3), [source], start);
  assert.match(tooFew, /./, 'a target ICP cannot use is a message for that pair');
  assert.throws(() => pairsOf.viewPoints(99), /no view 99 of 6/);
  assert.throws(() => pairsOf.recordPair(99, aligned), /no frame pair 99 of \d+/);
  assert.throws(() => pairsOf.registerPairs(new Uint32Array([99]), () => true), /no frame pair 99 of \d+/);
  assert.throws(() => pairsOf.recordPair(0, 5), /a pose or a message/);
  assert.throws(() => pairsOf.recordPair(0, new Float64Array([0, 0, 0, 2, 0, 0, 0])), /unit quaternion/);
  assert.equal(pairsOf.recordPair(0, aligned).iteration, 1);
  assert.equal(pairsOf.recordPair(1, 'gicp could not converge').iteration, 2);
  assert.throws(() => pairsOf.result(), /has not finished/);
  pairsOf.advance();
  assert.equal(pairsOf.stage(), 'finish');
  pairsOf.advance();
  assert.equal(pairsOf.stage(), 'done');
  const finished = pairsOf.result();
  assert.ok(finished.skipped.some((note) => /could not converge/.test(note.reason)), JSON.stringify(finished.skipped));
  pairsOf.free();
});
