// Cancel stops a run (the worker is replaced) and the page stays usable with its data.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { browserSession, waitForStatus } from './harness.js';

const session = browserSession();

test('cancel stops a run and the page stays usable', async () => {
  // Many components, a tolerance that never stops early: a run far longer than the test.
  const { page, problems } = await session.open('#demo=paper&frames=2&method=jrmpc&components=2000&iterations=1000');
  await waitForStatus(page, /Calibrate next/);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /iteration [1-9]/);
  assert.equal(await page.getByTestId('calibrate').isDisabled(), true);
  await page.getByTestId('cancel').click();
  await waitForStatus(page, /^Cancelled\.$/);
  assert.equal(await page.getByTestId('cancel').isDisabled(), true);
  assert.equal(await page.getByTestId('result-json').textContent(), '');
  assert.equal(await page.getByTestId('error').isHidden(), true);
  // The loaded scans stay; a new run (a fresh worker) finishes.
  assert.equal(await page.locator('#files tr').count(), 1 + 4);
  await page.locator('#iterations').fill('5');
  await page.locator('#iterations').dispatchEvent('change');
  await page.locator('#components').fill('100');
  await page.locator('#components').dispatchEvent('change');
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done: 5 iterations/, 60_000);
  assert.equal(JSON.parse(await page.getByTestId('result-json').textContent()).iterations, 5);
  assert.deepEqual(problems, []);
});
