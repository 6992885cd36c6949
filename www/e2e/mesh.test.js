// A CAD-model target, as a user gives one: the chair twin's folder dropped with its target.obj
// beside the scans (the page takes the model, the library finds where the chairs stand and fits
// the model to the reconstruction), the chairs demo, and a bad model file that is named and
// changes nothing.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { browserSession, waitForStatus } from './harness.js';
import { errorOf, gmmcalibFolder, simulateRig } from './rigfiles.js';

const session = browserSession();

test('a chair rig dropped with its target.obj calibrates with the model placed from the data', async () => {
  const { page, problems } = await session.open();
  const rig = simulateRig({ preset: 'paper-chair', frames: 2, seed: 3 });
  assert.equal(rig.target, 'mesh:target.obj');
  const files = gmmcalibFolder(rig, 'chairs');
  files.push({ name: 'chairs/target.obj', mimeType: 'text/plain', buffer: Buffer.from(rig.targetObj) });
  await page.locator('#view').drop({ files });
  await waitForStatus(page, /^4 scans of 2 sensors loaded/);
  assert.equal(await page.locator('#target-kind').inputValue(), 'mesh');
  assert.equal(await page.locator('#target-size').inputValue(), '0.45,0.45,0.90');
  assert.equal(await page.locator('#target-size').isDisabled(), true);

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  const t = result.reconstruction;
  assert.equal(t.placements.length, 3, 'three chairs found standing in the reference\'s scans');
  for (const p of t.placements) assert.ok(p.inliers > 0.9 && p.rms < 0.02, JSON.stringify(p));
  assert.equal(t.fits.length, 3);
  for (const f of t.fits) assert.equal(f.shape, 'mesh');
  const sensor = result.sensors.find((s) => s.name !== result.reference);
  const e = errorOf(sensor.extrinsic, rig.truth[sensor.name]);
  assert.ok(e.deg < 0.5 && e.mm < 50, `${e.deg} deg / ${e.mm} mm`);
  assert.match(await page.locator('#results').textContent(), /mesh|across/);
  assert.deepEqual(problems, []);
});

test('a bad model file is named and the target stays as it was', async () => {
  const { page, problems } = await session.open();
  await page.locator('#mesh-input').setInputFiles({ name: 'broken.stl', mimeType: 'model/stl', buffer: Buffer.from('solid broken\nfacet normal 0 0 1\n') });
  await page.getByTestId('error').waitFor();
  assert.match(await page.getByTestId('error').textContent(), /broken\.stl/);
  assert.equal(await page.locator('#target-kind').inputValue(), 'cube');
  assert.deepEqual(problems, []);
});

test('the chairs demo calibrates with its CAD model as the target', async () => {
  const { page, problems } = await session.open();
  await page.locator('#demo-preset').selectOption('paper-chair');
  await page.locator('#demo-frames').fill('2');
  await page.locator('#demo-frames').dispatchEvent('change');
  await page.getByTestId('demo').click();
  await waitForStatus(page, /^Demo: paper-chair/);
  assert.equal(await page.locator('#target-kind').inputValue(), 'mesh');
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.equal(result.reconstruction.placements.length, 3);
  await page.screenshot({ path: 'e2e/artifacts/chairs.png' });
  assert.deepEqual(problems, []);
});
