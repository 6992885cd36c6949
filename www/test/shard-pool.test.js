// The worker pool's plain parts under Node: how views are split, and that the driven session
// gives `calibrate`'s result exactly (one worker here: Node has no Web Workers; the Chromium
// test runs two).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFile } from 'node:fs/promises';
import init, * as wasm from '../pkg/gmmcalib.js';
import { calibrateSharded, splitViews } from '../src/shard-pool.js';

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

test('the driven session gives calibrate\'s result, and bad shard data is an error', async () => {
  await init({ module_or_path: await readFile(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });
  const rig = wasm.syntheticRig({ sensors: 2, frames: 3, pointsPerView: 800, seed: 5 });
  const input = () => ({ views: rig.views, nominal: rig.nominal, roi: rig.roi, components: 150, iterations: 30 });
  const progress = [];
  const direct = wasm.calibrate(input(), () => true);
  const driven = await calibrateSharded(wasm, input(), 1, (p) => progress.push(p));
  assert.deepEqual(driven.sensors, direct.sensors);
  assert.deepEqual(driven.history, direct.history);
  assert.deepEqual(Array.from(driven.target.means), Array.from(direct.target.means));
  assert.equal(progress.filter((p) => p.maxIterations === 30).length, direct.iterations);
  // An ICP method has no E-step to share: the session runs it where it is, on one worker.
  const icp = () => ({ ...input(), method: 'p2l' });
  const icpDriven = await calibrateSharded(wasm, icp(), 2, () => true);
  assert.deepEqual(icpDriven.sensors, wasm.calibrate(icp()).sensors);
  assert.equal(icpDriven.workers, 1);

  const session = new wasm.CalibrationSession(input());
  assert.throws(() => session.mStep([new Float64Array(7)]), /not a whole number of views/);
  assert.throws(() => session.shardPoints(5, 2), /views 5\.\.5\+2 of 6/);
  const shard = new wasm.JrmpcShard(session.shardPoints(0, 1), session.viewSizes().slice(0, 1));
  assert.throws(() => shard.eStep(new Float64Array([1, 2, 3]), 0), /malformed E-step input/);
  const estep = session.eStepInput();
  estep[3] = NaN;
  assert.throws(() => shard.eStep(estep, 0), /not finite/);
  assert.throws(() => new wasm.JrmpcShard(new Float64Array(5), new Uint32Array([2])), /5 coordinates for 2 points/);
  shard.free();
  session.free();
});
