// The demo end to end in real Chromium: simulate the paper rig in the worker, calibrate, check
// the result against the simulated truth, keep a screenshot; a shared link reproduces the demo.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { browserSession, loadedPoints, waitForStatus, waitForView } from './harness.js';
import { errorOf, simulateRig } from './rigfiles.js';

// The bound for every start on the twin: within 0.1 deg and 1 cm (docs/accuracy.md, "Accuracy on
// the digital twin"; the demo's seed-1 rig ends well inside it).
const DEMO_ERROR_BOUND = { deg: 0.1, mm: 10 };
// No main-thread task over 100 ms during a run. WebGL draws in a worker (viewer.js), so
// the page's own work is what is left: none over 50 ms in 10 runs on this 2-core machine at a
// load of 7-8 (docs/web-app.md, "Main-thread budget"). Drawing on the page's canvas took 45-260 ms a frame
// here (software WebGL, read back on the main thread).
const LONGEST_TASK_MS = 100;

const session = browserSession();

test('demo: simulate, calibrate, and land within the bound of the truth', async () => {
  const { page, problems } = await session.open();
  await page.getByTestId('demo').click();
  await waitForStatus(page, /Calibrate next/);
  assert.match(page.url(), /demo=paper/);
  mkdirSync('e2e/artifacts', { recursive: true });
  // The view draws the first frame of each sensor (in its worker).
  const firstFrame = await loadedPoints(page, '1');
  await waitForView(page, firstFrame);
  await page.screenshot({ path: 'e2e/artifacts/demo-before.png' });
  // Long main-thread tasks during the run (the page must stay responsive).
  await page.evaluate(() => {
    window.longTasks = [];
    new PerformanceObserver((list) => window.longTasks.push(...list.getEntries().map((e) => e.duration))).observe({ type: 'longtask' });
  });
  // What the status line and the bar say on the way.
  await page.evaluate(() => {
    window.statuses = [];
    const status = document.querySelector('[data-testid=status]');
    new MutationObserver(() => window.statuses.push([status.textContent, document.getElementById('progress').value]))
      .observe(status, { childList: true, characterData: true, subtree: true });
  });
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  // JRMPC's iterations, then the frame pairs (the last always reported), on one rising bar.
  const statuses = await page.evaluate(() => window.statuses);
  assert.ok(statuses.some(([text]) => /^JRMPC iteration \d+\/100, σ \d\.\d\d cm.*then the frame pairs$/.test(text)), JSON.stringify(statuses));
  assert.ok(statuses.some(([text]) => /^frame pair (\d+)\/\1$/.test(text)), JSON.stringify(statuses));
  // The views' step before JRMPC, the result's last.
  const views = statuses.findIndex(([text]) => /^levelling the grounds/.test(text));
  assert.ok(views >= 0 && views < statuses.findIndex(([text]) => /^JRMPC/.test(text)), JSON.stringify(statuses.slice(0, 5)));
  assert.equal(statuses.filter(([text]) => !/^Done/.test(text)).at(-1)[0], 'the plane adjustment and the verdict');
  const bar = statuses.map(([, value]) => value);
  assert.ok(bar.every((v, i) => i === 0 || v >= bar[i - 1]), `the bar went back: ${bar}`);
  const longTasks = await page.evaluate(() => window.longTasks);
  console.log(`main-thread tasks over 50 ms during the run: ${longTasks.map((d) => d.toFixed(0)).join(', ') || 'none'}`);
  assert.ok(longTasks.every((d) => d < LONGEST_TASK_MS), `main-thread tasks of ${longTasks.join(', ')} ms`);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.equal(result.method, 'gmm');
  assert.equal(result.reference, 'front_left');
  // The verdict, good, in view without the user scrolling.
  const verdict = page.getByTestId('verdict');
  assert.equal(await verdict.getAttribute('data-level'), 'good');
  assert.equal(result.verdict.level, 'good');
  assert.ok(await verdict.evaluate((el) => { const r = el.getBoundingClientRect(); return r.top >= 0 && r.bottom <= innerHeight; }), 'the verdict is inside the viewport');
  assert.equal(await page.locator('[data-testid=sensor-verdict][data-sensor=front_right]').getAttribute('data-level'), 'good');
  assert.deepEqual(result.sensors.map((s) => s.name), ['front_left', 'front_right']);
  assert.equal(result.sensors[1].extrinsic.length, 16);
  assert.ok(Array.isArray(result.reconstruction.means) && result.history.meanSigma.length === result.iterations);
  // The paper scene's three 0.5 m cubes, each fitted on its own, standing 12.3 m ahead.
  const fits = result.reconstruction.fits;
  assert.equal(fits.length, 3, JSON.stringify(fits));
  for (const fit of fits) {
    // Reconstructed edges of the paper twin, seeds 1-6 (4 frames): 0.433-0.486 m; the bound
    // held for the demo's draw before the twin's seed rule was unified only by that draw.
    assert.ok(Math.abs(fit.size - 0.5) < 0.075 && fit.rms < 0.03 && Math.abs(fit.centre[0] - 12.3) < 0.1, JSON.stringify(fit));
  }
  assert.match(await page.locator('#results').textContent(), /3 targets: edge 0\.\d{3} m/);
  // The joint plane adjustment moved the second sensor, and the page says by how much.
  assert.equal(result.planeAdjustment.length, 1, JSON.stringify(result.planeAdjustment));
  assert.match(result.planeAdjustment[0].reason, /^plane adjustment: moved/);
  assert.match(await page.locator('#results').textContent(), /front_right\/all: plane adjustment: moved \d\.\d{4} deg/);
  // A precision is claimed for the adjusted sensor only (the truth must be near: below).
  const [reference, adjusted] = result.sensors;
  assert.equal(reference.precision, null);
  assert.ok(adjusted.precision.position.every((v) => v > 0 && v < 0.01), JSON.stringify(adjusted.precision));
  assert.match(await page.locator('#results .precision').first().textContent(), /^precision \(1 sigma\): position [\d.]+, [\d.]+, [\d.]+ mm/);

  // Truth from the twin directly (Node), not from the page.
  const { truth } = simulateRig({ preset: 'paper', frames: 1, seed: 1 });
  for (const s of result.sensors) {
    const e = errorOf(s.extrinsic, truth[s.name]);
    console.log(`demo ${s.name}: ${e.deg.toFixed(3)} deg / ${e.mm.toFixed(1)} mm from the truth`);
    assert.ok(e.deg < DEMO_ERROR_BOUND.deg && e.mm < DEMO_ERROR_BOUND.mm, `${s.name}: ${e.deg} deg / ${e.mm} mm`);
    if (s.precision) {
      // Within four sigma of the claim.
      const sigmaMm = Math.hypot(...s.precision.position) * 1000;
      console.log(`demo ${s.name}: claimed precision ${sigmaMm.toFixed(1)} mm (1 sigma, position)`);
      assert.ok(e.mm < 4 * sigmaMm, `${s.name}: ${e.mm} mm from the truth, claimed ${sigmaMm} mm`);
    }
    // The page shows the same error.
    const shown = await page.locator(`.truth[data-sensor="${s.name}"] b`).textContent();
    assert.equal(shown, `${e.deg.toFixed(3)} deg / ${e.mm.toFixed(1)} mm`);
  }
  assert.equal(await page.getByTestId('error').isHidden(), true);
  // Every export is offered, with its frame direction stated.
  const exports = await page.locator('#exports details').evaluateAll((d) => d.map((e) => e.dataset.export));
  assert.deepEqual(exports, ['json', 'yaml', 'urdf', 'ros2', 'ros1', 'tfYaml', 'autoware', 'kitti', 'ply']);
  const ros = await page.locator('[data-export=ros2] pre').textContent();
  assert.match(ros, /--frame-id vehicle --child-frame-id front_right/);

  await waitForView(page, firstFrame); // all of them again after the run's previews
  assert.equal(await page.getByTestId('warning').count(), 0, 'no warning on a rig within the spec');
  await page.screenshot({ path: 'e2e/artifacts/demo.png' });
  assert.deepEqual(problems, []);
});

test('a shared link loads the same demo, preset included', async () => {
  const { page, problems } = await session.open('#demo=os1-128&frames=1&seed=5&method=jrmpc');
  await waitForStatus(page, /Calibrate next/);
  assert.match(await page.getByTestId('status').textContent(), /os1-128 rig, seed 5, 1 frames/);
  assert.equal(await page.locator('#demo-preset').inputValue(), 'os1-128');
  assert.equal(await page.locator('#method').inputValue(), 'jrmpc');
  assert.equal(await page.locator('#files tr').count(), 1 + 2);
  assert.deepEqual(problems, []);
});

test('compare all keeps the methods that ran when others fail', async () => {
  // The demo with front_right's nominal up to 40 deg and 2 m off (seed 3: the twin's one seed
  // rule makes it the rig `gmmcalib simulate --seed 3 --max-angle-deg 40 --max-translation 2`
  // writes for the CLI's test of the same): cropped in that nominal, front_right has no ROI
  // points for jrmpc and the ICP methods; gmm's global alignment places it before the crop,
  // so it runs.
  const { page, problems } = await session.open('#demo=paper&frames=2&seed=3&maxAngleDeg=40&maxTranslation=2&method=all&iterations=20');
  await waitForStatus(page, /Calibrate next/);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/);
  assert.match(await page.getByTestId('status').textContent(), /^Done: 2 of 6 methods in [\d.]+ s.*; jrmpc, p2p, p2l, gicp failed \(see Results\)\.$/);
  assert.equal(await page.getByTestId('error').isHidden(), true, 'a failed method is a finding, not an error');
  const failed = await page.locator('table.compare tr.failed').allTextContents();
  assert.equal(failed.length, 4);
  for (const [row, method] of failed.map((row, i) => [row, ['jrmpc', 'p2p', 'p2l', 'gicp'][i]])) {
    assert.match(row, new RegExp(`^${method}failed: .*front_right.*ROI`));
  }
  assert.match(await page.locator('#results').textContent(), /The answer of gmm \(the first method that ran\)/);
  assert.match(await page.locator('.compare-box summary').textContent(), /^All methods: 2 ran, 4 failed$/);
  const json = JSON.parse(await page.getByTestId('result-json').textContent());
  // The global stage found front_right from 40 deg / 2 m off, clearly.
  assert.ok(json[0].global[1].overlay.best.score > 0.5, JSON.stringify(json[0].global[1]));
  assert.deepEqual(json.map((r) => r.method), ['gmm', 'jrmpc', 'cad', 'p2p', 'p2l', 'gicp']);
  assert.equal(json[0].sensors.length, 2);
  assert.match(json[1].error, /front_right.*ROI/);
  assert.deepEqual(problems, []);
});
