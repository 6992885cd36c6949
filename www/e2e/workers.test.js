// Issue 8: JRMPC's E-step shared by workers. The same demo on one worker and on two gives the
// same result, bit for bit (the M-step takes every view's statistics in view order).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { browserSession, waitForStatus } from './harness.js';

const session = browserSession();

async function run(workers) {
  const { page, problems } = await session.open(`#demo=paper&frames=2&seed=3&workers=${workers}`);
  await waitForStatus(page, /Calibrate next/);
  assert.equal(await page.locator('#workers').inputValue(), String(workers));
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
