// A long run on a real rig: the Livox Mid-100's three units (../shared/data, read at
// test time, never copied: GPL), dropped as the three loose files they come as, read as three
// sensors, calibrated with no target. The library says each stage as it begins (the views
// prepared and the result made among them) and the frame pairs take about a second here: the
// status says what runs, the bar moves, the time line under the bar counts the seconds from the
// start. (The time left, once a stage has a
// measure of it, is checked on JRMPC's iterations in e2e/page.test.js: here every start's
// refinements end together.) Then the results at a glance (e2e/glance.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { SHOTS, browserSession, waitForStatus } from './harness.js';
import { haveData, livoxFiles } from './realrigs.js';
import { fileTableFits, glance } from './glance.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

test('the Livox rig: its files read as three sensors; the bar and the time line move through every stage', { skip: !haveData && 'no ../shared/data' }, async () => {
  const { page, problems } = await session.open();
  await page.locator('#view').drop({ files: livoxFiles() });
  await waitForStatus(page, /^3 scans of 3 sensors loaded; the names end in a sensor, not a frame number: sensors L0, L1, L2, frame scene1_pose10\.$/);
  await fileTableFits(page);
  await page.locator('#target-kind').selectOption('none');
  // What the bar, the status line and the time line say, at every change of any of them: a
  // stage that ends between two polls of a timer would be missed on a faster machine.
  await page.evaluate(() => {
    window.samples = [];
    const t0 = performance.now();
    const $ = (id) => document.querySelector(`[data-testid=${id}]`);
    const sample = () => window.samples.push({
      t: (performance.now() - t0) / 1000,
      status: $('status').textContent,
      time: $('progress-time').textContent,
      bar: $('progress').value,
    });
    window.sampler = new MutationObserver(sample);
    for (const id of ['status', 'progress-time', 'progress']) {
      window.sampler.observe($(id), { subtree: true, childList: true, characterData: true, attributes: true });
    }
  });
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 300_000);
  const samples = await page.evaluate(() => { window.sampler.disconnect(); return window.samples; });
  console.log(samples.filter((s, i) => i === 0 || s.status !== samples[i - 1].status || s.t - samples[i - 1].t > 1).map((s) => `${s.t.toFixed(1)} s: ${s.status} [${s.time}] ${s.bar.toFixed(3)}`).join('\n'));
  // The global stage, then the views' step (levelling, the bird's-eye search, the crop): the
  // status says what it does.
  assert.ok(samples.some((s) => /^global alignment: 0 of 2 sensors aligned/.test(s.status)), 'the global stage');
  assert.ok(samples.some((s) => /^levelling the grounds, the bird's-eye search and the crop to the ROI$/.test(s.status)), 'the views\' step named');
  // The frame pairs (each sensor refined from the stages' several starts) take about a
  // second: the status names them while the first runs, and while they run the time line
  // counts on and the bar moves.
  assert.ok(samples.some((s) => /^frame pair 0\/\d+$/.test(s.status)), 'the first pairs named while they run');
  // (The sample taken as the run ends may catch the time line cleared.)
  const pairs = samples.filter((s) => /^frame pair \d+\/\d+/.test(s.status) && / s elapsed/.test(s.time));
  assert.ok(pairs.length >= 2, `the frame pairs were seen ${pairs.length} times`);
  const elapsed = pairs.map((s) => Number(s.time.match(/^([\d.]+) s elapsed/)?.[1]));
  assert.ok(elapsed.every(Number.isFinite) && elapsed.at(-1) > elapsed[0], JSON.stringify(pairs.map((s) => s.time)));
  assert.ok(pairs.at(-1).bar > pairs[0].bar, `the bar ${pairs[0].bar} -> ${pairs.at(-1).bar}`);
  const bars = samples.map((s) => s.bar);
  assert.ok(bars.every((v, i) => i === 0 || v >= bars[i - 1]), 'the bar never goes back');
  assert.ok(samples.some((s) => /^the plane adjustment and the verdict$/.test(s.status)), 'the last stage named');
  const r = await glance(page, 'livox');
  // L0 keeps identity as the reference: T_L0_Lk is T_vehicle_Lk, printed once.
  assert.equal(r.reference, 'L0');
  assert.match(await page.locator('[data-testid=relative][data-sensor=L1]').textContent(), /T_L0_L1 = T_vehicle_L1/);
  assert.deepEqual(problems, []);
});
