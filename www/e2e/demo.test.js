// The page in real Chromium: generate a synthetic rig, calibrate in the worker, read the result.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { serveDist, launch, openPage } from './harness.js';

let server;
let browser;
before(async () => {
  server = await serveDist();
  browser = await launch();
});
after(async () => {
  await browser?.close();
  server?.close();
});

test('demo: calibrates a synthetic rig in the worker and shows the result', async () => {
  const { page, problems } = await openPage(browser, server.url);
  await page.getByTestId('demo').click();
  await page.waitForFunction(() => document.querySelector('[data-testid=result-json]').textContent.length > 0, null, { timeout: 120_000 });
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.equal(result.reference, 'sensor_1');
  assert.equal(result.sensors.length, 2);
  assert.equal(result.sensors[1].extrinsic.length, 4);
  // The page computes the error against the simulated truth; read it from the table.
  const errorText = await page.locator('#result-table tr:nth-child(3) td:last-child').textContent();
  const [deg, mm] = errorText.match(/[\d.]+/g).map(Number);
  assert.ok(deg < 0.5 && mm < 20, `error vs truth ${errorText}`);
  assert.equal(await page.getByTestId('error').isHidden(), true);
  mkdirSync('test-results', { recursive: true });
  await page.screenshot({ path: 'test-results/demo.png', fullPage: true });
  assert.deepEqual(problems, []);
});

test('cancel stops a run and the page stays usable', async () => {
  const { page, problems } = await openPage(browser, server.url);
  await page.locator('#frames').fill('40');
  await page.getByTestId('demo').click();
  await page.waitForFunction(() => /Iteration/.test(document.querySelector('[data-testid=status]').textContent), null, { timeout: 60_000 });
  await page.getByTestId('cancel').click();
  await page.waitForFunction(() => document.querySelector('[data-testid=status]').textContent === 'Cancelled.');
  assert.equal(await page.getByTestId('demo').isEnabled(), true);
  // A new run after the cancel works (a fresh worker).
  await page.locator('#frames').fill('2');
  await page.getByTestId('demo').click();
  await page.waitForFunction(() => /^Done/.test(document.querySelector('[data-testid=status]').textContent), null, { timeout: 120_000 });
  assert.deepEqual(problems, []);
});
