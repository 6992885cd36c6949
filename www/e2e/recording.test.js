// A recording dropped on the page: an MCAP written by the `mcap` Python package
// (tests/fixtures/recording/make.py: two LiDARs of the twin and five layout topics, a tf tree of
// depth 3). The page opens it in the worker (read in slices, never whole), offers its
// point-cloud topics, loads the chosen ones at their instants with nominals from /tf_static,
// calibrates, and exports URDF joints from base_link to each topic's frame id.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { browserSession, waitForStatus } from './harness.js';

const FIXTURE = new URL('../../tests/fixtures/recording/calib_zstd.mcap', import.meta.url).pathname;

const session = browserSession();

test('an MCAP dropped on the page: pick topics, calibrate, export URDF', async () => {
  const { page, problems } = await session.open();
  const file = { name: 'calib_zstd.mcap', mimeType: 'application/octet-stream', buffer: readFileSync(FIXTURE) };
  await page.locator('#view').drop({ files: [file] });
  await waitForStatus(page, /calib_zstd\.mcap: pick the topics, then Load scans\.$/);
  const picker = page.getByTestId('recording');
  assert.match(await picker.textContent(), /8 topics, 7 with point clouds/);
  for (const layout of ['f32_intensity', 'f64', 'padded22', 'big_endian', 'organised']) {
    await page.getByLabel(`use /layout/${layout}`).uncheck();
  }
  // The reference picked with the topics; sensors are named by their frame ids, the vehicle frame
  // by the tree's base frame.
  await page.getByLabel('recording reference /front_left/points').check();
  await page.getByTestId('recording-load').click();
  await waitForStatus(page, /^6 scans of 2 sensors loaded from calib_zstd\.mcap \(3 instants, offsets up to 5\.0 ms\)\.$/);
  assert.equal(await page.getByRole('radio', { name: 'reference front_left', exact: true }).isChecked(), true);
  assert.equal(await page.getByLabel('vehicle frame name').inputValue(), 'base_link');
  assert.match(await page.locator('#files').textContent(), /calib_zstd\.mcap \/front_right\/points #1/);
  // The nominal comes from /tf_static (base_link -> sensor_kit_base_link -> mount -> sensor).
  const z = Number(await page.getByLabel('front_right z', { exact: true }).inputValue());
  assert.ok(z > 1.4 && z < 1.8, `front_right's nominal z ${z}`);

  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 120_000);
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  assert.deepEqual(result.sensors.map((s) => s.name), ['front_left', 'front_right']);
  assert.equal(await page.locator('.answer-table > .direction').textContent(), 'T_base_link_s: maps each sensor\'s points into base_link');
  const right = result.sensors[1].extrinsic;
  // The twin's truth: front_right at (2.3, -0.6, 1.6) in base_link (the CLI: 2.2997, -0.5986, 1.5997).
  assert.ok(Math.hypot(right[3] - 2.3, right[7] + 0.6, right[11] - 1.6) < 0.005, `front_right at ${right[3]}, ${right[7]}, ${right[11]}`);
  await page.locator('#export-box > summary').click(); // the exports fold below the answer
  await page.locator('[data-export=urdf] summary').click();
  const urdf = await page.locator('[data-export=urdf] pre').textContent();
  assert.match(urdf, /<parent link="base_link"\/>\s*<child link="front_right"\/>/);
  // One name per sensor in every export.
  const yaml = await page.locator('[data-export=yaml] pre').textContent();
  assert.match(yaml, /^transform_front_right: {2}# front_right -> base_link\n/m);
  assert.match(await page.locator('[data-export=ros2] pre').textContent(), /--frame-id base_link --child-frame-id front_right$/m);
  assert.deepEqual(problems, []);
});

test('a damaged recording is named and the page keeps working', async () => {
  const { page, problems } = await session.open();
  const bytes = readFileSync(FIXTURE);
  const file = { name: 'cut.mcap', mimeType: 'application/octet-stream', buffer: bytes.subarray(0, 100) };
  await page.locator('#view').drop({ files: [file] });
  await page.waitForFunction(() => !document.querySelector('[data-testid=error]').hidden);
  assert.match(await page.getByTestId('error').textContent(), /cut\.mcap/);
  await page.getByTestId('demo').click();
  await waitForStatus(page, /^Demo:/, 60_000);
  assert.deepEqual(problems, []);
});
