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

test('state never goes stale: edits mark the result out of date, Clear resets, Calibrate says why it waits', async () => {
  const { page, problems } = await session.open('#demo=paper&frames=2&iterations=30');
  await waitForStatus(page, /Calibrate next/);
  // The time left comes from measured iterations: none for the first few.
  await page.evaluate(() => {
    window.statuses = [];
    const status = document.querySelector('[data-testid=status]');
    new MutationObserver(() => window.statuses.push(status.textContent)).observe(status, { childList: true, characterData: true, subtree: true });
  });
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const statuses = await page.evaluate(() => window.statuses);
  const early = statuses.filter((t) => /^JRMPC iteration [123]\//.test(t));
  assert.ok(early.length && early.every((t) => !/left/.test(t)), JSON.stringify(early));
  assert.ok(statuses.some((t) => /^JRMPC iteration \d+\/30, .*about \d+\.\d s left/.test(t)), JSON.stringify(statuses));
  assert.equal(await page.getByTestId('stale').isHidden(), true);

  // A sensor renamed in the file table (panel 1 folded after the run: opened as a user would).
  await page.locator('#load-panel summary').click();
  await page.getByLabel('sensor of front_right_2', { exact: true }).fill('rear');
  await page.getByLabel('sensor of front_right_2', { exact: true }).press('Enter');
  await page.getByLabel('sensor of front_right_2', { exact: true }).blur();
  await waitForStatus(page, /The sensors changed: the result below is out of date\. Calibrate again\./);
  assert.equal(await page.getByTestId('stale').isVisible(), true);
  assert.equal(await page.getByTestId('calibrate').isEnabled(), true);
  assert.ok(await page.getByTestId('verdict').count(), 'the old result stays readable');
  await page.getByLabel('sensor of front_right_2', { exact: true }).fill('front_right');
  await page.getByLabel('sensor of front_right_2', { exact: true }).blur();

  // A setting changed: out of date too; a new run is current again.
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  assert.equal(await page.getByTestId('stale').isHidden(), true);
  await page.locator('#rig-panel summary').click();
  await page.locator('#iterations').fill('20');
  await page.locator('#iterations').blur();
  await waitForStatus(page, /The settings changed: the result below is out of date/);
  assert.match(await page.getByTestId('stale').textContent(), /Out of date: the settings changed after this run/);
  await page.getByLabel('front_right yaw', { exact: true }).fill('1');
  await page.getByLabel('front_right yaw', { exact: true }).blur();
  await waitForStatus(page, /The nominal extrinsics changed/);

  // Clear: no progress left over, and Calibrate says why it waits.
  assert.equal(await page.getByTestId('progress').evaluate((p) => p.value), 1);
  await page.locator('#load-panel summary').click();
  await page.locator('#clear').click();
  assert.equal(await page.getByTestId('progress').evaluate((p) => p.value), 0);
  assert.equal(await page.getByTestId('calibrate').isDisabled(), true);
  assert.match(await page.getByTestId('calibrate-why').textContent(), /Load scans/);
  // One sensor only: why it cannot run, named.
  const { pcdAscii } = await import('./rigfiles.js');
  const cube = new Float32Array(300).map((_, i) => (i % 3 === 0 ? 10 : 0) + Math.sin(i));
  await page.getByTestId('file-input').setInputFiles(['left_1.pcd', 'left_2.pcd'].map((name) => ({ name, mimeType: 'application/octet-stream', buffer: pcdAscii(cube) })));
  await waitForStatus(page, /2 scans of 1 sensor loaded/);
  assert.equal(await page.getByTestId('calibrate').isDisabled(), true);
  assert.match(await page.getByTestId('calibrate-why').textContent(), /Needs scans of two sensors or more; all 2 scans belong to left/);
  assert.equal(await page.getByTestId('calibrate').getAttribute('aria-describedby'), 'calibrate-why');
  assert.deepEqual(problems, []);
});

test('layout: from 1024 px to a wide screen, a resizable and collapsible side panel, nothing cut off', async () => {
  const { page, problems } = await session.open('#demo=paper&frames=2');
  await waitForStatus(page, /Calibrate next/);
  // Before a run: no empty inset, no empty convergence plot.
  assert.equal(await page.getByTestId('inset').isHidden(), true);
  assert.equal(await page.locator('#convergence-box').isHidden(), true);
  for (const width of [1024, 1280, 1920]) {
    await page.setViewportSize({ width, height: 768 });
    const side = await page.locator('#side').evaluate((el) => ({ width: el.clientWidth, overflow: el.scrollWidth - el.clientWidth }));
    const view = await page.locator('#view').boundingBox();
    assert.ok(side.overflow <= 0, `${width}: the side panel overflows by ${side.overflow} px`);
    assert.ok(view.width >= width * 0.55, `${width}: the view is ${view.width} px wide`);
    // Every nominal shows in full in its input.
    const cut = await page.locator('#rig input[type=number]').evaluateAll((inputs) => inputs.filter((i) => i.scrollWidth > i.clientWidth).map((i) => i.value));
    assert.deepEqual(cut, [], `${width}: values cut off`);
  }
  // The separator: arrow keys make the panel narrower, the Panel button hides it.
  await page.setViewportSize({ width: 1280, height: 720 });
  const before = (await page.locator('#side').boundingBox()).width;
  await page.locator('#resizer').focus();
  for (let i = 0; i < 3; i++) await page.keyboard.press('ArrowLeft');
  const after = (await page.locator('#side').boundingBox()).width;
  assert.ok(Math.abs(before - after - 72) < 2, `${before} -> ${after}`);
  // Dragged by mouse too.
  const bar = await page.locator('#resizer').boundingBox();
  await page.mouse.move(bar.x + 3, bar.y + 200);
  await page.mouse.down();
  await page.mouse.move(bar.x + 103, bar.y + 200, { steps: 4 });
  await page.mouse.up();
  assert.ok(Math.abs((await page.locator('#side').boundingBox()).width - after - 100) < 3);
  await page.getByRole('button', { name: 'Panel' }).click();
  assert.equal(await page.locator('#side').isHidden(), true);
  assert.ok((await page.locator('#view').boundingBox()).width >= 1270);
  await page.getByRole('button', { name: 'Panel' }).click();
  assert.equal(await page.locator('#side').isVisible(), true);
  assert.deepEqual(problems, []);
});
