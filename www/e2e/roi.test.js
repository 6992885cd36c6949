// The ROI on a real recording: GMMCalib's cube sample recorded as a ROS 2 rig would
// record it (an MCAP, e2e/realrigs.js). With ROI auto no cube is found: the page says so in the
// verdict and the rig panel, and offers to draw the ROI; the ROI is then a box in the view whose
// handles are dragged by the mouse, the six numbers following, and typed numbers move the box.
// Around the cubes the calibration is good. Sensors are named by their frame ids and the vehicle
// frame is base_link, in the panel, the answer and every export.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { SHOTS, browserSession, waitForStatus } from './harness.js';
import { fileTableFits, glance } from './glance.js';
import { cubeRecording, haveData } from './realrigs.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

const handles = async (page) => JSON.parse((await page.locator('#view').getAttribute('data-handles')) || '{}');
const roiInput = (page, bound, axis) => page.getByLabel(`ROI ${bound} ${axis}`, { exact: true });

test('the cube sample as an MCAP: ROI auto finds no cube and says so; the ROI drawn in the view makes it good', { skip: !haveData && 'no ../shared/data' }, async () => {
  const { page, problems } = await session.open();
  await page.locator('#view').drop({ files: [cubeRecording()] });
  await waitForStatus(page, /^cube\.mcap: pick the topics, then Load scans\.$/);
  // No reference picked: the sensor with the most points.
  await page.getByTestId('recording-load').click();
  await waitForStatus(page, /^6 scans of 2 sensors loaded from cube\.mcap \(3 instants, offsets up to 5\.0 ms\)\.$/);
  const points = { lidar_1: 0, lidar_2: 0 };
  for (const [sensor, n] of await page.locator('#files tr:not(.bad)').evaluateAll((trs) => trs.slice(1).map((tr) => [tr.querySelectorAll('input')[0].value, Number(tr.cells[4].textContent.replaceAll(',', ''))]))) points[sensor] += n;
  const most = points.lidar_1 > points.lidar_2 ? 'lidar_1' : 'lidar_2';
  assert.equal(await page.getByRole('radio', { name: `reference ${most}`, exact: true }).isChecked(), true, JSON.stringify(points));
  assert.equal(await page.getByLabel('vehicle frame name').inputValue(), 'base_link');
  assert.equal(await page.getByTestId('roi-auto').isChecked(), true);
  await fileTableFits(page);
  assert.equal(await page.locator('#view').getAttribute('data-handles'), '', 'no handles while auto');

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 300_000);
  // Cube-sized objects stand in the scene and the library put the region around them (the
  // result says how many), but no cube stands out of the reconstruction: the verdict says so,
  // once, where the ROI was, and what to do.
  const roi = JSON.parse(await page.getByTestId('result-json').textContent()).roi;
  assert.equal(roi.source, 'targets', JSON.stringify(roi));
  const advice = page.getByTestId('advice');
  assert.match(await advice.textContent(), new RegExp(`^No cube:0\\.5 found: no target stands out of the reconstruction\\. The ROI was auto: around ${roi.found} objects? of its size standing in the reference's scans, none of which stood out as it\\. Set the target to none`));
  assert.equal((await page.locator('#results').textContent()).split('no target stands out of the reconstruction').length, 2, 'said once');
  await page.locator('#rig-panel summary').click();
  const found = await page.getByTestId('roi-found').textContent();
  const size = found.match(/the ROI was put around \d+ objects? of the target's size standing in the reference's scans, ([\d.]+) × ([\d.]+) × ([\d.]+) m .*but no cube:0\.5 stood out/);
  assert.ok(size && Number(size[1]) > 10, found);
  await page.screenshot({ path: `${SHOTS}/roi-auto-no-cube-1280x720.png` });

  // Draw the ROI: the auto box becomes editable, its handles in the view.
  const auto = JSON.parse(await page.getByTestId('result-json').textContent()).roi;
  await advice.getByRole('button', { name: 'Draw the ROI' }).click();
  await waitForStatus(page, /^Drag the white handles of the ROI in the view/);
  assert.equal(await page.getByTestId('roi-auto').isChecked(), false);
  assert.equal(Number(await roiInput(page, 'max', 'x').inputValue()), Math.round(auto.max[0] * 100) / 100);
  await page.waitForFunction(() => document.querySelector('#view').dataset.handles);
  const before = await handles(page);
  assert.deepEqual(Object.keys(before).sort(), ['max.x', 'max.y', 'max.z', 'min.x', 'min.y', 'min.z']);
  // Drag max.x (seen from above, x is up the screen) towards the box's centre.
  const view = await page.locator('#view').boundingBox();
  const [hx, hy] = before['max.x'];
  const [cx, cy] = before['min.x'];
  const maxX = Number(await roiInput(page, 'max', 'x').inputValue());
  await page.mouse.move(view.x + hx, view.y + hy);
  await page.mouse.down();
  await page.mouse.move(view.x + hx + (cx - hx) * 0.3, view.y + hy + (cy - hy) * 0.3, { steps: 6 });
  await page.mouse.up();
  const dragged = Number(await roiInput(page, 'max', 'x').inputValue());
  console.log(`max x dragged from ${maxX} to ${dragged} m`);
  assert.ok(dragged < maxX - 1, `${maxX} -> ${dragged}`);
  assert.equal(Number(await roiInput(page, 'min', 'x').inputValue()), Math.round(auto.min[0] * 100) / 100, 'the other faces stay');
  await waitForStatus(page, /The ROI changed: the result below is out of date/);
  const moved = await handles(page);
  assert.ok(Math.hypot(moved['max.x'][0] - hx, moved['max.x'][1] - hy) > 20, 'the handle moved with the face');
  // Typed numbers move the box: the cubes' region (GMMCalib's config).
  for (const [bound, values] of [['min', [8.5, -3, -1]], ['max', [11, 4, 2]]]) {
    for (const [k, axis] of ['x', 'y', 'z'].entries()) {
      await roiInput(page, bound, axis).fill(String(values[k]));
      await roiInput(page, bound, axis).press('Tab');
    }
  }
  const typed = await handles(page);
  assert.notDeepEqual(typed['max.x'], moved['max.x'], 'the box follows the numbers');
  // Focus on the ROI: its six handles in the view.
  await page.locator('#focus').selectOption('roi');
  await page.waitForFunction((h) => document.querySelector('#view').dataset.handles !== h, JSON.stringify(typed));
  const framed = await handles(page);
  for (const [x, y] of Object.values(framed)) assert.ok(x > 0 && y > 0 && x < view.width && y < view.height, JSON.stringify(framed));
  await page.waitForTimeout(500);
  await page.screenshot({ path: `${SHOTS}/roi-drawn-1280x720.png` });
  assert.match(page.url(), /roi=8\.5%2C-3%2C-1%2C11%2C4%2C2/, 'the link holds the ROI');

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  const seconds = Number((await page.getByTestId('status').textContent()).match(/in ([\d.]+) s/)[1]);
  console.log(`around the cubes: ${await page.getByTestId('verdict').getAttribute('data-level')} in ${seconds} s`);
  assert.equal(await page.getByTestId('verdict').getAttribute('data-level'), 'good');
  assert.equal(await page.getByTestId('advice').count(), 0);
  // One name per sensor and for the vehicle frame, everywhere.
  assert.equal(await page.locator('.answer-table > .direction').textContent(), 'T_base_link_s: maps each sensor\'s points into base_link');
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(result.sensors.map((s) => s.name), ['lidar_1', 'lidar_2']);
  const yaml = await page.locator('[data-export=yaml] pre').textContent();
  assert.match(yaml, /^transform_lidar_1: {2}# lidar_1 -> base_link\n/m);
  assert.doesNotMatch(yaml, /transform_\//);
  assert.match(await page.locator('[data-export=urdf] pre').textContent(), /<parent link="base_link"\/>\s*<child link="lidar_1"\/>/);
  await glance(page, 'recording-cube-mcap');

  // The vehicle frame renamed after the run: the library writes the exports again for it; the
  // JSON names no frame and stays as it was.
  const json = await page.locator('[data-export=json] pre').textContent();
  await page.locator('#rig-panel').evaluate((d) => (d.open = true));
  await page.getByLabel('vehicle frame name').fill('chassis');
  await page.getByLabel('vehicle frame name').press('Enter');
  await page.waitForFunction(() => /<parent link="chassis"\/>/.test(document.querySelector('[data-export=urdf] pre').textContent));
  assert.match(await page.locator('[data-export=yaml] pre').textContent(), /^transform_lidar_1: {2}# lidar_1 -> chassis\n/m);
  assert.match(await page.locator('[data-export=ply] pre').textContent(), /\(chassis frame, m\)/);
  assert.equal(await page.locator('[data-export=json] pre').textContent(), json);
  await page.locator('#export-box').evaluate((d) => (d.open = true));
  await page.locator('[data-export=urdf]').evaluate((d) => (d.open = true));
  await page.locator('[data-export=urdf]').scrollIntoViewIfNeeded();
  await page.screenshot({ path: `${SHOTS}/exports-renamed-frame-1280x720.png` });
  assert.deepEqual(problems, []);
});
