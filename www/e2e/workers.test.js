// JRMPC's E-step and the frame pairs' ICP shared by workers. The same demo on one
// worker and on two gives the same result, bit for bit (the M-step takes every view's
// statistics in view order; the frame pairs' outcomes are kept in pair order).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { browserSession, waitForStatus } from './harness.js';

const session = browserSession();

async function run(workers, method = 'gmm', { extra = '', exact = false } = {}) {
  const { page, problems } = await session.open(`#demo=paper&frames=2&seed=3&workers=${workers}&method=${method}${extra}`);
  await waitForStatus(page, /Calibrate next/);
  assert.equal(await page.locator('#workers').inputValue(), String(workers));
  if (exact) {
    if (!(await page.locator('#exact').isVisible())) await page.locator('#exact').locator('xpath=ancestor::details[1]/summary').click();
    await page.locator('#exact').check();
    assert.ok(await page.locator('#eStepDevice').isDisabled(), 'the exact E-step runs on the CPU');
    assert.match(page.url(), /exact=true/);
  }
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const status = await page.getByTestId('status').textContent();
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(problems, []);
  await page.close();
  return { status, result };
}

test('one worker and two give the same calibration', async () => {
  const one = await run(1);
  const two = await run(2);
  console.log(`1 worker: ${one.status}\n2 workers: ${two.status}`);
  assert.doesNotMatch(one.status, /workers/);
  assert.match(two.status, /on 2 workers\.$/);
  assert.equal(one.result.workers, 1);
  assert.equal(two.result.workers, 2);
  assert.ok(one.result.iterations > 10);
  assert.deepEqual(two.result.sensors, one.result.sensors);
  assert.deepEqual(two.result.history, one.result.history);
  assert.deepEqual(two.result.target, one.result.target);
});

test('an ICP method\'s frame pairs on two workers give the one-worker result', async () => {
  const one = await run(1, 'gicp');
  const two = await run(2, 'gicp');
  assert.equal(two.result.workers, 2);
  assert.equal(two.result.method, 'gicp');
  assert.match(two.status, /^Done: 2 frame pairs registered in [\d.]+ s on 2 workers\.$/);
  assert.deepEqual(two.result.sensors, one.result.sensors);
  assert.deepEqual(two.result.skipped, one.result.skipped);
});

test('the exact E-step, chosen in the settings, runs in every worker and says so', async () => {
  // Fewer components and iterations: the exact E-step evaluates every term in f64.
  const small = { extra: '&components=100&iterations=20' };
  const fast = await run(2, 'jrmpc', small);
  const one = await run(1, 'jrmpc', { ...small, exact: true });
  const two = await run(2, 'jrmpc', { ...small, exact: true });
  assert.match(two.status, /^Done: 20 iterations in [\d.]+ s on 2 workers, exact E-step\.$/);
  assert.equal(two.result.exact, true);
  assert.equal(fast.result.exact, false);
  // Every iteration evaluates every point against every component, in both workers' shards:
  // the two-worker run is the one-worker run, bit for bit, and not the fast path's.
  const terms = two.result.history.terms;
  assert.ok(terms.every((t) => t === terms[0] && t % 100 === 0), JSON.stringify(terms));
  assert.deepEqual(two.result.history, one.result.history);
  assert.deepEqual(two.result.sensors, one.result.sensors);
  assert.notDeepEqual(two.result.sensors, fast.result.sensors);
});
