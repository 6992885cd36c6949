// Loading files: a GMMCalib folder (3 sensors, PCD and PLY, config.yaml) through the file
// input, calibrated against its truth; a malformed file is named and the rest still calibrates.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join } from 'node:path';
import { browserSession, waitForStatus } from './harness.js';
import { calibrate } from '../pkg/gmmcalib.js';
import { configYaml, errorOf, gmmcalibFolder, pcdAscii, sampledRig } from './rigfiles.js';

// Against the truth: this synthetic rig (3 sensors, 3 frames of 3000 points, cube and no
// ground) calibrates to 0.08 and 0.06 deg, 3 mm. At 1000 points a view, one sparse frame's
// refinement is rejected and a sensor ends near 1 deg. The strongest check is that the page
// computes exactly what the wasm package computes in Node from the same data.
const UPLOAD_ERROR_BOUND = { deg: 0.3, mm: 20 };

const session = browserSession();

test('upload a GMMCalib folder through file-input and calibrate it', async () => {
  const rig = sampledRig({ sensors: 3, frames: 3, pointsPerView: 3000, seed: 2 });
  const files = gmmcalibFolder(rig, 'rig', 'initial_sigma: prior\ncomponents: 200\n');
  const { page, problems } = await session.open();
  await page.getByTestId('file-input').setInputFiles(files);
  await waitForStatus(page, /9 scans of 3 sensors loaded/);
  // Assigned by folder, nominal and ROI from the config, our keys applied.
  const rows = await page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => {
    const [file, sensor, frame, format] = tr.querySelectorAll('td');
    return [file.textContent, sensor.firstChild.value, frame.firstChild.value, format.textContent];
  }));
  assert.deepEqual(rows.slice(0, 4), [
    ['rig/sensor_1/1.pcd', 'sensor_1', '1', 'PCD ascii'],
    ['rig/sensor_1/2.pcd', 'sensor_1', '2', 'PCD ascii'],
    ['rig/sensor_1/3.pcd', 'sensor_1', '3', 'PCD ascii'],
    ['rig/sensor_2/1.pcd', 'sensor_2', '1', 'PCD ascii'],
  ]);
  assert.match(rows[8][3], /PLY binary/);
  assert.equal(await page.getByLabel('sensor_3 x', { exact: true }).inputValue(), String(+rig.nominal.sensor_3.xyz[0].toFixed(6)));
  assert.equal(await page.getByLabel('ROI max y', { exact: true }).inputValue(), '3.2');
  assert.equal(await page.locator('#initialSigma').inputValue(), 'prior');

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(result.sensors.map((s) => s.name), ['sensor_1', 'sensor_2', 'sensor_3']);
  assert.equal(result.reference, 'sensor_1');
  for (const s of result.sensors.slice(1)) {
    const e = errorOf(s.extrinsic, rig.truth[s.name]);
    console.log(`upload ${s.name}: ${e.deg.toFixed(3)} deg / ${e.mm.toFixed(1)} mm from the truth`);
    assert.ok(e.deg < UPLOAD_ERROR_BOUND.deg && e.mm < UPLOAD_ERROR_BOUND.mm, `${s.name}: ${e.deg} deg / ${e.mm} mm`);
    assert.equal(s.spread.frames, 3);
  }
  assert.equal(result.reconstruction.means.length, 3 * 200);
  // The same rig straight into the wasm package (views in the page's order: by sensor, frame).
  const views = [...rig.scans].sort((a, b) => a.sensor.localeCompare(b.sensor) || a.frame.localeCompare(b.frame));
  const direct = calibrate({ scans: views, nominal: rig.nominal, roi: rig.roi, reference: 'sensor_1', target: { kind: 'cube', edge: 0.5 }, components: 200, iterations: 100, initialSigma: 'prior' });
  result.sensors.forEach((s, i) => {
    const worst = Math.max(...s.extrinsic.map((v, k) => Math.abs(v - direct.sensors[i].extrinsic[k])));
    assert.ok(worst < 1e-12, `${s.name}: the page's extrinsic differs from the direct call by ${worst}`);
  });
  const yaml = await page.locator('[data-export=yaml] pre').textContent();
  assert.match(yaml, /^number_of_sensors: 3\ntransform_sensor_1:/m);
  assert.deepEqual(problems, []);
});

test('a malformed file shows a named error; the good files still calibrate', async () => {
  const rig = sampledRig({ sensors: 2, frames: 2, pointsPerView: 800, seed: 3 });
  const files = gmmcalibFolder(rig, 'rig', 'initial_sigma: prior\ncomponents: 150\n');
  files.push({ name: 'rig/sensor_2/3.pcd', mimeType: 'application/octet-stream', buffer: Buffer.from('VERSION 0.7\nFIELDS x y z\nDATA ascii\n1 2 3\n') });
  const { page, problems } = await session.open();
  await page.getByTestId('file-input').setInputFiles(files);
  await waitForStatus(page, /4 scans of 2 sensors loaded, 1 file\(s\) with problems/);
  const error = await page.getByTestId('error').textContent();
  assert.match(error, /^rig\/sensor_2\/3\.pcd: .*3\.pcd/);
  assert.equal(await page.getByTestId('error').isVisible(), true);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  assert.equal(await page.getByTestId('error').isHidden(), true);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.equal(result.sensors.length, 2);
  assert.equal(result.sensors[1].spread.frames, 2, 'frame 3 of sensor_2 was never loaded');
  assert.deepEqual(problems, []);
});

test('a folder picked from disk keeps its sensor_N layout', async () => {
  const rig = sampledRig({ sensors: 2, frames: 2, pointsPerView: 300, seed: 4 });
  const dir = mkdtempSync(join(tmpdir(), 'gmmcalib-e2e-'));
  try {
    for (const f of gmmcalibFolder(rig, 'rig')) {
      mkdirSync(dirname(join(dir, f.name)), { recursive: true });
      writeFileSync(join(dir, f.name), f.buffer);
    }
    const { page, problems } = await session.open();
    await page.locator('#folder-input').setInputFiles(join(dir, 'rig'));
    await waitForStatus(page, /4 scans of 2 sensors loaded\.$/);
    const sensors = await page.locator('#files tr td:nth-child(2) input').evaluateAll((inputs) => inputs.map((i) => i.value));
    assert.deepEqual(sensors, ['sensor_1', 'sensor_1', 'sensor_2', 'sensor_2']);
    assert.equal(await page.getByLabel('sensor_2 y', { exact: true }).inputValue(), String(+rig.nominal.sensor_2.xyz[1].toFixed(6)));
    assert.deepEqual(problems, []);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});

test('loose files dropped on the view are grouped by <sensor>_<frame> and can be reassigned', async () => {
  const rig = sampledRig({ sensors: 2, frames: 2, pointsPerView: 300, seed: 6 });
  const names = { sensor_1: 'left', sensor_2: 'right' };
  const files = rig.scans.map((v) => ({ name: `${names[v.sensor]}_00${v.frame}.pcd`, mimeType: 'application/octet-stream', buffer: pcdAscii(v.points) }));
  const { page, problems } = await session.open();
  await page.locator('#view').drop({ files });
  await waitForStatus(page, /4 scans of 2 sensors loaded\.$/);
  const rows = () => page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));
  assert.deepEqual(await rows(), ['left/001', 'left/002', 'right/001', 'right/002']);
  // By hand: right_002.pcd becomes a third sensor's scan.
  await page.getByLabel('sensor of right_002.pcd').fill('rear');
  await page.getByLabel('sensor of right_002.pcd').dispatchEvent('change');
  assert.deepEqual(await rows(), ['left/001', 'left/002', 'rear/002', 'right/001']);
  // The status line counts again: three sensors now.
  await waitForStatus(page, /^4 scans of 3 sensors loaded; right_002\.pcd is now rear's, frame 002\.$/);
  assert.equal(await page.getByRole('radio', { name: 'reference left' }).isChecked(), true);
  assert.equal(await page.getByLabel('rear x', { exact: true }).count(), 1);
  assert.deepEqual(problems, []);
});

test('recorded scans: a folder per sensor, timestamps for names, paired and calibrated', async () => {
  // As a bag export leaves them: per-topic folders, each scan named by its own timestamp (the
  // rear's 4 ms after the front's), and a config naming the sensors after the folders.
  const rig = sampledRig({ sensors: 2, frames: 3, pointsPerView: 3000, seed: 2 });
  const topic = { sensor_1: 'lidar_front', sensor_2: 'lidar_rear' };
  const stamp = (v) => (1700000000.1 + 0.1 * (Number(v.frame) - 1) + (v.sensor === 'sensor_2' ? 0.004 : 0)).toFixed(3);
  const files = rig.scans.map((v) => ({ name: `bag/${topic[v.sensor]}/${stamp(v)}.pcd`, mimeType: 'application/octet-stream', buffer: pcdAscii(v.points) }));
  const named = { nominal: { lidar_front: rig.nominal.sensor_1, lidar_rear: rig.nominal.sensor_2 }, roi: rig.roi };
  files.push({ name: 'bag/config.yaml', mimeType: 'text/yaml', buffer: configYaml(named, 'initial_sigma: prior\ncomponents: 200\n') });
  const { page, problems } = await session.open();
  await page.getByTestId('file-input').setInputFiles(files);
  await waitForStatus(page, /^6 scans of 2 sensors loaded \(lidar_rear's frames paired by the nearest timestamp to lidar_front's\)\.$/);
  const rows = await page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));
  const frames = ['1700000000.100', '1700000000.200', '1700000000.300'];
  assert.deepEqual(rows, [...frames.map((f) => `lidar_front/${f}`), ...frames.map((f) => `lidar_rear/${f}`)]);
  assert.equal(await page.getByLabel('lidar_rear x', { exact: true }).inputValue(), String(+rig.nominal.sensor_2.xyz[0].toFixed(6)));

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(result.sensors.map((s) => s.name), ['lidar_front', 'lidar_rear']);
  const rear = result.sensors[1];
  assert.equal(rear.spread.frames, 3, 'every frame paired');
  const e = errorOf(rear.extrinsic, rig.truth.sensor_2);
  console.log(`recorded scans lidar_rear: ${e.deg.toFixed(3)} deg / ${e.mm.toFixed(1)} mm from the truth`);
  assert.ok(e.deg < UPLOAD_ERROR_BOUND.deg && e.mm < UPLOAD_ERROR_BOUND.mm, `${e.deg} deg / ${e.mm} mm`);
  assert.deepEqual(problems, []);
});

test('recorded scans picked folder by folder pair with the first sensor', async () => {
  const rig = sampledRig({ sensors: 2, frames: 2, pointsPerView: 300, seed: 4 });
  const dir = mkdtempSync(join(tmpdir(), 'gmmcalib-e2e-'));
  try {
    const topic = { sensor_1: 'front', sensor_2: 'rear' };
    for (const v of rig.scans) {
      const stamp = 100 + 10 * Number(v.frame) + (v.sensor === 'sensor_2' ? 1 : 0);
      mkdirSync(join(dir, topic[v.sensor]), { recursive: true });
      writeFileSync(join(dir, topic[v.sensor], `${stamp}.pcd`), pcdAscii(v.points));
    }
    const { page, problems } = await session.open();
    await page.locator('#folder-input').setInputFiles(join(dir, 'front'));
    await waitForStatus(page, /^2 scans of 1 sensor loaded\.$/);
    await page.locator('#folder-input').setInputFiles(join(dir, 'rear'));
    await waitForStatus(page, /^4 scans of 2 sensors loaded \(rear's frames paired by the nearest timestamp to front's\)\.$/);
    const rows = await page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));
    assert.deepEqual(rows, ['front/110', 'front/120', 'rear/110', 'rear/120']);
    assert.deepEqual(problems, []);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});

test('a known-bad upload, one sensor given twice, shows failed with its reason', async () => {
  const rig = sampledRig({ sensors: 2, frames: 3, pointsPerView: 1500, seed: 7 });
  // sensor_2's scans are sensor_1's: the same sensor picked twice.
  const twice = { ...rig, scans: rig.scans.map((s) => (s.sensor === 'sensor_2' ? { ...s, points: rig.scans.find((t) => t.sensor === 'sensor_1' && t.frame === s.frame).points } : s)) };
  const { page, problems } = await session.open();
  await page.getByTestId('file-input').setInputFiles(gmmcalibFolder(twice, 'rig', 'initial_sigma: prior\n'));
  await waitForStatus(page, /6 scans of 2 sensors loaded/);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  const verdict = page.getByTestId('verdict');
  assert.equal(await verdict.getAttribute('data-level'), 'failed');
  assert.match(await verdict.textContent(), /Failed: do not use this extrinsic/);
  // The reason is said once, on sensor_2's card; the verdict points there.
  assert.match(await verdict.textContent(), /Reasons on the card of (sensor_1, )?sensor_2 below/);
  assert.match(await page.locator('.answer-sensor[data-sensor=sensor_2] [data-testid=sensor-reasons]').textContent(), /a scan of this sensor is, point for point, a scan of sensor_1/);
  assert.equal((await page.locator('#results').textContent()).split('point for point, a scan of sensor_1').length, 2, 'said once');
  assert.ok(await verdict.evaluate((el) => { const r = el.getBoundingClientRect(); return r.top >= 0 && r.bottom <= innerHeight; }), 'the verdict is inside the viewport');
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.equal(result.verdict.sensors.sensor_2.level, 'failed');
  assert.ok(result.verdict.sensors.sensor_2.reasons.some((r) => r.kind === 'sameScans' && r.values.other === 'sensor_1'));
  assert.deepEqual(problems, []);
});
