// Issue 23, the page as a daily tool, through the paths a user takes: the answer first and in
// view at 1280x720, state that never goes stale, a layout from a laptop to a wide monitor, the
// view's tools (sensors shown, point size, colour scales, preset views, focus, picking,
// measuring, PNG), help on every control. Screenshots at 1280x720 and 1920x1080 land in
// e2e/artifacts/.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import { browserSession, loadedPoints, waitForStatus, waitForView } from './harness.js';

const session = browserSession();
mkdirSync('e2e/artifacts', { recursive: true });

const inViewport = (locator) => locator.evaluate((el) => {
  const r = el.getBoundingClientRect();
  return r.top >= 0 && r.left >= 0 && r.bottom <= innerHeight && r.right <= innerWidth && r.height > 0;
});

// A demo run of the paper rig (2 frames, few iterations: the layout is under test, not the
// accuracy), at the page's 1280x720.
async function demoRun(hash = '#demo=paper&frames=2') {
  const { page, problems } = await session.open(hash);
  await waitForStatus(page, /Calibrate next/);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  return { page, problems };
}

test('the answer first: verdict and the first extrinsic in view at 1280x720 without scrolling', async () => {
  const { page, problems } = await demoRun();
  assert.deepEqual(page.viewportSize(), { width: 1280, height: 720 });
  assert.equal(await page.locator('#side').evaluate((el) => el.scrollTop), 0, 'nothing scrolled');
  assert.ok(await inViewport(page.getByTestId('verdict')), 'the verdict is in view');
  const extrinsic = page.getByTestId('extrinsic').first();
  assert.ok(await inViewport(extrinsic), 'the first sensor\'s extrinsic is in view');
  // Each transform says which way it maps; the sensor-to-sensor transform is there; the
  // reference is one line.
  assert.match(await extrinsic.textContent(), /T_vehicle_front_right: maps front_right's points into vehicle/);
  assert.match(await extrinsic.textContent(), /xyz \(m\)\s+-?\d+\.\d{6} -?\d+\.\d{6} -?\d+\.\d{6}\s+rpy \(deg\)\s+(-?\d+\.\d{5} ?){3}\s+quat \(x y z w\)\s+(-?\d\.\d{7} ?){4}/);
  const relative = page.getByTestId('relative').first();
  assert.match(await relative.textContent(), /T_front_left_front_right: maps front_right's points into front_left/);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  const shownXyz = (await relative.locator('pre').textContent()).split('\n')[0].trim().split(/\s+/).slice(2).map(Number);
  assert.deepEqual(shownXyz, [3, 7, 11].map((k) => +result.sensors[1].relative[k].toFixed(6)));
  assert.match(await page.getByTestId('reference-line').textContent(), /front_left is the reference: it keeps its nominal/);
  // EM's convergence, as the JSON has it.
  const run = page.getByTestId('run-summary');
  assert.equal(await run.getAttribute('data-converged'), String(result.converged));
  assert.match(await run.textContent(), result.converged ? /converged/ : /not converged/);
  // The rest folds below; the setup panels fold to one line each and say what they hold.
  assert.equal(await page.locator('details.more').evaluate((d) => d.open), false);
  assert.match(await page.locator('#load-panel summary').textContent(), /4 scans of 2 sensors, 2 frames/);
  assert.match(await page.locator('#rig-panel summary').textContent(), /reference front_left, gmm, target cube:0\.5/);
  // The inset is labelled and shown now that there is a target.
  assert.equal(await page.getByTestId('inset').isVisible(), true);
  assert.match(await page.getByTestId('inset').textContent(), /Reconstructed target/);
  await waitForView(page, await loadedPoints(page, '1'));
  await page.screenshot({ path: 'e2e/artifacts/page-1280x720.png' });
  await page.setViewportSize({ width: 1920, height: 1080 });
  assert.ok(await inViewport(page.getByTestId('extrinsic').first()));
  await page.waitForTimeout(300);
  await page.screenshot({ path: 'e2e/artifacts/page-1920x1080.png' });
  assert.deepEqual(problems, []);
});
