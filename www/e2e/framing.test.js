// The view on a real road rig (OpenCalib's scene 0001 from ../shared/data: three LiDARs,
// returns out to 200 m): it opens framed on the data's robust extent, not on the outliers, every
// preset view centres the data, focus frames everything, each sensor and the ROI; OpenCalib's folder
// loads the devices its list names, not the stitched cloud OpenCalib leaves beside them.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { SHOTS, browserSession, loadedPoints, waitForStatus, waitForView } from './harness.js';
import { haveData, opencalibFolder } from './realrigs.js';
import { afterFrame, dataPixels } from './pixels.js';
import { fileTableFits, glance } from './glance.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

test('OpenCalib 0001: framed on the data, centred by every preset, focus on each sensor', { skip: !haveData && 'no ../shared/data' }, async () => {
  const { page, problems } = await session.open();
  // OpenCalib leaves its stitched result beside the scans: a cloud, but no device.
  const files = opencalibFolder('0001');
  files.push({ ...files.find((f) => f.name.endsWith('top.pcd')), name: '0001/stitching.pcd' });
  await page.locator('#view').drop({ files });
  await waitForStatus(page, /^3 scans of 3 sensors loaded, 1 file\(s\) with problems\.$/);
  assert.match(await page.getByTestId('error').textContent(), /^0001\/stitching\.pcd: ignored: not a device in its folder's lidar_cloud_path\.txt$/);
  await fileTableFits(page);
  await waitForView(page, await loadedPoints(page));
  // On opening, the road fills the view: not a few dots in its middle.
  const opened = await dataPixels(page);
  console.log(`opened: ${opened.count} data pixels, spread ${opened.spread.map((v) => v.toFixed(2))}, centre ${opened.centre.map((v) => v.toFixed(2))}`);
  assert.ok(opened.spread[0] > 0.5 && opened.spread[1] > 0.3, JSON.stringify(opened));
  await page.screenshot({ path: `${SHOTS}/framing-opencalib-1280x720.png` });
  // Every preset: the data centred, and spread over the view.
  for (const look of ['Side', 'Front', 'Top']) {
    await afterFrame(page, () => page.getByRole('button', { name: look, exact: true }).click());
    const p = await dataPixels(page);
    console.log(`${look}: spread ${p.spread.map((v) => v.toFixed(2))}, centre ${p.centre.map((v) => v.toFixed(2))}`);
    assert.ok(Math.abs(p.centre[0] - 0.5) < 0.15 && Math.abs(p.centre[1] - 0.5) < 0.15, `${look}: centred ${JSON.stringify(p)}`);
    assert.ok(Math.max(...p.spread) > 0.5, `${look}: spread ${JSON.stringify(p)}`);
    if (look === 'Side') await page.screenshot({ path: `${SHOTS}/framing-opencalib-side-1280x720.png` });
  }
  // Zoomed far out by the wheel, focus: everything brings the data back.
  const view = await page.locator('#view').boundingBox();
  await page.mouse.move(view.x + view.width / 2, view.y + view.height / 2);
  for (let i = 0; i < 10; i++) await page.mouse.wheel(0, 400);
  await page.waitForTimeout(500);
  const far = await dataPixels(page);
  assert.ok(!far.count || Math.max(...far.spread) < 0.5, `zoomed out: ${JSON.stringify(far)}`);
  await afterFrame(page, () => page.locator('#focus').selectOption('all'));
  const all = await dataPixels(page);
  assert.ok(all.spread[0] > 0.5, `focus everything: ${JSON.stringify(all)}`);
  // Focus offers each sensor; a side LiDAR's 9k points fill the view on their own.
  assert.deepEqual(await page.locator('#focus option').allTextContents(), ['…', 'everything', 'sensor left', 'sensor right', 'sensor top']);
  await page.getByLabel('show top').uncheck();
  await page.getByLabel('show right').uncheck();
  await afterFrame(page, () => page.locator('#focus').selectOption('sensor:left'));
  const left = await dataPixels(page);
  console.log(`focus on left: spread ${left.spread.map((v) => v.toFixed(2))}`);
  await page.screenshot({ path: `${SHOTS}/framing-opencalib-focus-left-1280x720.png` });
  assert.ok(Math.max(...left.spread) > 0.3 && Math.abs(left.centre[0] - 0.5) < 0.2, JSON.stringify(left));
  await page.getByLabel('show top').check();
  await page.getByLabel('show right').check();
  // Calibrated (no target: a road): the results at a glance, framed on the result.
  await page.locator('#target-kind').selectOption('none');
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  await page.locator('#focus').selectOption('all');
  await glance(page, 'opencalib-0001');
  // The selection opened: every stage's hypothesis, how it scored, how far its ground lies
  // from the others'.
  const selection = page.getByTestId('selection');
  await selection.locator('summary').click();
  assert.ok(await selection.evaluate((d) => d.open), 'the selection opens');
  await selection.screenshot({ path: `${SHOTS}/opencalib-0001-selection.png` });
  // The table scrolls sideways in the panel: its last columns, the grounds among them.
  await selection.locator('.table-wrap').evaluate((w) => { w.scrollLeft = w.scrollWidth; });
  await selection.screenshot({ path: `${SHOTS}/opencalib-0001-selection-grounds.png` });
  assert.deepEqual(problems, []);
});
