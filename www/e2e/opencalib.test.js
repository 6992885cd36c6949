// Real scans from someone else's rig: OpenCalib's road scene (three LiDARs, the side ones pitched
// about 45 deg, OpenCalib's own guess saying they are level) dropped as its folder is, with its
// `lidar_cloud_path.txt` and `initial_extrinsic.txt`; no target. The page must name the
// sensors, take the guess, align globally (on two workers) and calibrate to what the library
// computes in Node, with a verdict; a screenshot of the aligned clouds is kept.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { browserSession, waitForStatus } from './harness.js';
import { opencalibFolder } from './rigfiles.js';
import { calibrate, initSync, parseCloud, parseOpenCalib } from '../pkg/gmmcalib.js';

initSync({ module: readFileSync(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });

const DATA = new URL('../../tests/fixtures/opencalib/', import.meta.url).pathname;

const session = browserSession();

// The same scene calibrated by the wasm package in Node, as the page's input would be.
function inNode(scene) {
  const read = (name) => readFileSync(`${DATA}${scene}/${name}`, 'utf8');
  const rig = parseOpenCalib(read('lidar_cloud_path.txt'), 'lidar_cloud_path.txt', read('initial_extrinsic.txt'), 'initial_extrinsic.txt');
  const scans = rig.devices.map((d) => ({ sensor: d.name, frame: scene, points: parseCloud(readFileSync(`${DATA}${scene}/${d.file}`), d.file).points }));
  return calibrate({ scans, nominal: rig.nominal, reference: rig.reference, target: { kind: 'none' } });
}

// Rotation angle (deg) and translation distance (mm) between two row-major 4x4 poses.
function difference(a, b) {
  let trace = 0;
  for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) trace += a[4 * i + j] * b[4 * i + j];
  const deg = (Math.acos(Math.min(1, Math.max(-1, (trace - 1) / 2))) * 180) / Math.PI;
  const mm = 1000 * Math.hypot(a[3] - b[3], a[7] - b[7], a[11] - b[11]);
  return { deg, mm };
}

test('OpenCalib\'s road scene dropped as its folder calibrates from its own guess, no target', async () => {
  // Two workers: the global stage's two side sensors are aligned side by side, one in a pool
  // worker (the frame pairs, all against the one reference view, stay in one).
  const { page, problems } = await session.open('#workers=2');
  await page.locator('#view').drop({ files: opencalibFolder('0001') });
  await waitForStatus(page, /^3 scans of 3 sensors loaded\.$/);
  const rows = await page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));
  assert.deepEqual(rows, ['left/0001', 'right/0001', 'top/0001']);
  assert.equal(await page.getByRole('radio', { name: 'reference top' }).isChecked(), true);
  assert.equal(await page.getByLabel('left yaw', { exact: true }).inputValue(), '90');
  assert.equal(await page.getByLabel('right yaw', { exact: true }).inputValue(), '-90');
  assert.equal(await page.getByTestId('roi-auto').isChecked(), true);

  await page.locator('#target-kind').selectOption('none');
  assert.equal(await page.locator('#target-size').isDisabled(), true);
  await page.evaluate(() => {
    window.statuses = [];
    const status = document.querySelector('[data-testid=status]');
    new MutationObserver(() => window.statuses.push(status.textContent)).observe(status, { childList: true, characterData: true, subtree: true });
  });
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  assert.match(await page.getByTestId('status').textContent(), /on 2 workers\.$/);
  // The global stage says what it does (its first and last messages always reach the page),
  // then the frame pairs.
  const statuses = await page.evaluate(() => window.statuses);
  const global = statuses.filter((t) => t.startsWith('global alignment'));
  assert.equal(global[0], 'global alignment: 0 of 2 sensors aligned', JSON.stringify(statuses));
  // Then the views' step, said as it begins, before the frame pairs.
  assert.equal(global.at(-1), 'global alignment: 2 of 2 sensors aligned', JSON.stringify(statuses));
  const views = statuses.indexOf('levelling the grounds, the bird\'s-eye search and the crop to the ROI');
  assert.ok(statuses.indexOf(global.at(-1)) < views && views < statuses.findIndex((t) => t.startsWith('frame pair')), JSON.stringify(statuses));
  assert.equal(await page.getByTestId('verdict').getAttribute('data-level'), 'good');
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(result.sensors.map((s) => s.name), ['left', 'right', 'top']);
  assert.equal(result.reference, 'top');
  assert.equal(result.global.length, 3, 'the global stage ran');
  assert.ok(result.roi.max[0] - result.roi.min[0] > 10, `the overlap region spans the road: ${JSON.stringify(result.roi)}`);

  // The page computes what the library computes (its workers share the work, bit for bit).
  const node = inNode('0001');
  const named = (r, name) => r.sensors.find((s) => s.name === name).extrinsic;
  for (const s of result.sensors) {
    const d = difference(s.extrinsic, named(node, s.name));
    assert.ok(d.deg < 1e-9 && d.mm < 1e-6, `${s.name}: page and Node differ by ${d.deg} deg / ${d.mm} mm`);
  }
  // Same rig minutes later: scene 0002 gives the same extrinsics (no truth; this is the check).
  const later = inNode('0002');
  for (const s of result.sensors) {
    const d = difference(s.extrinsic, named(later, s.name));
    console.log(`OpenCalib ${s.name}: scenes 0001 and 0002 differ by ${d.deg.toFixed(3)} deg / ${d.mm.toFixed(1)} mm`);
    assert.ok(d.deg < 0.3 && d.mm < 30, `${s.name}: ${d.deg} deg / ${d.mm} mm`);
  }
  await page.screenshot({ path: 'e2e/artifacts/opencalib.png' });
  assert.deepEqual(problems, []);
});

test('OpenCalib\'s guess without its path list is named, and the scans still load', async () => {
  const { page, problems } = await session.open();
  const files = opencalibFolder('0002').filter((f) => !f.name.endsWith('lidar_cloud_path.txt'));
  await page.getByTestId('file-input').setInputFiles(files);
  await waitForStatus(page, /^3 scans of .* loaded/);
  assert.match(await page.getByTestId('error').textContent(), /initial_extrinsic\.txt: ignored: OpenCalib's guess needs its lidar_cloud_path\.txt/);
  assert.deepEqual(problems, []);
});
