// The drift check in the page, the way a user meets it: calibrate the demo, download
// the result JSON, then compare stored calibrations with the result: the same one (within),
// its tf YAML export dropped on the control (within), one with a sensor turned by 0.5 deg
// (moved, named), other limits, malformed files (the library's error, the result kept), and a
// rerun marking the comparison out of date.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import { browserSession, waitForStatus } from './harness.js';

const session = browserSession();

// `m` (row-major 4x4) turned by `deg` about the vehicle's z axis, in place: Rz * R, t kept.
function turned(m, deg) {
  const [c, s] = [Math.cos((deg * Math.PI) / 180), Math.sin((deg * Math.PI) / 180)];
  const rz = [[c, -s, 0], [s, c, 0], [0, 0, 1]];
  const out = [...m];
  for (let r = 0; r < 3; r++) for (let k = 0; k < 3; k++) out[r * 4 + k] = rz[r].reduce((sum, x, j) => sum + x * m[j * 4 + k], 0);
  return out;
}

const file = (name, text) => ({ name, mimeType: 'application/octet-stream', buffer: Buffer.from(text) });

test('drift check: a stored calibration compared with the result, within, moved, malformed, out of date', async () => {
  const { page, problems } = await session.open();
  await page.setViewportSize({ width: 1280, height: 900 });
  await page.getByTestId('demo').click();
  await waitForStatus(page, /Calibrate next/);
  // No result, no drift check.
  assert.equal(await page.locator('#drift').isHidden(), true);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const drift = page.locator('#drift');
  assert.equal(await drift.isVisible(), true);
  assert.equal(await page.getByRole('button', { name: 'Compare again' }).isDisabled(), true);

  // The stored calibration: the result JSON as the page downloads it.
  await page.locator('#export-box > summary').click();
  await page.locator('[data-export=json] > summary').click();
  const [download] = await Promise.all([
    page.waitForEvent('download'),
    page.locator('[data-export=json]').getByRole('button', { name: 'Download' }).click(),
  ]);
  assert.equal(download.suggestedFilename(), 'gmmcalib-result.json');
  const json = readFileSync(await download.path(), 'utf8');
  const result = JSON.parse(json);
  assert.deepEqual(result.sensors.map((s) => s.name), ['front_left', 'front_right']);

  const input = page.getByTestId('drift-input');
  const outcome = page.getByTestId('drift-outcome');
  const row = page.locator('[data-testid=drift-sensor][data-sensor=front_right]');
  const cells = () => row.locator('td').allTextContents();

  // The same calibration: nothing moved.
  await input.setInputFiles(file('gmmcalib-result.json', json));
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-outcome]'));
  assert.equal(await outcome.getAttribute('data-passed'), 'true');
  assert.equal(await outcome.textContent().then((t) => t.trim()), 'No sensor moved since gmmcalib-result.json: 1 sensor within the limits relative to front_left.');
  assert.equal(await row.getAttribute('data-moved'), 'false');
  // gmm claims a precision; the limits are the library's defaults (0.1 deg, 1 cm), which the
  // empty fields now show.
  const [name, deg, mm, precision, limit, moved] = await cells();
  assert.deepEqual([name, deg, mm, limit, moved], ['front_right', '0.000', '0.0', '0.100 / 10.0', 'within']);
  assert.match(precision, /^0\.\d{4} \/ \d+\.\d$/);
  assert.equal(await page.locator('#drift [name=rotationDeg]').getAttribute('placeholder'), '0.1');
  assert.equal(await page.locator('#drift [name=translationCm]').getAttribute('placeholder'), '1');

  // Its tf YAML export, dropped on the control: compared, not loaded as scans.
  await page.locator('[data-export=tfYaml] > summary').click();
  const tfYaml = await page.locator('[data-export=tfYaml] pre').textContent();
  const status = await page.getByTestId('status').textContent();
  const dataTransfer = await page.evaluateHandle((text) => {
    const dt = new DataTransfer();
    dt.items.add(new File([text], 'tf_static.yaml'));
    return dt;
  }, tfYaml);
  await page.getByTestId('drift-drop').dispatchEvent('drop', { dataTransfer });
  await page.waitForFunction(() => /tf_static\.yaml/.test(document.querySelector('[data-testid=drift-outcome]')?.textContent));
  assert.equal(await outcome.getAttribute('data-passed'), 'true');
  assert.equal(await page.getByTestId('drift-file').textContent(), 'tf_static.yaml');
  assert.equal(await page.getByTestId('status').textContent(), status);
  assert.equal(await page.getByTestId('verdict').isVisible(), true);

  // Its URDF export, picked as it is: a whole <robot>, read by the same check.
  await page.locator('[data-export=urdf] > summary').click();
  const urdf = await page.locator('[data-export=urdf] pre').textContent();
  await input.setInputFiles(file('extrinsics.urdf', urdf));
  await page.waitForFunction(() => /extrinsics\.urdf/.test(document.querySelector('[data-testid=drift-outcome]')?.textContent));
  assert.equal(await outcome.getAttribute('data-passed'), 'true');
  assert.equal(await page.getByTestId('drift-error').isHidden(), true);

  // front_right turned by 0.5 deg in the stored one: it has moved, and the outcome names it.
  const stored = structuredClone(result);
  stored.sensors[1].extrinsic = turned(stored.sensors[1].extrinsic, 0.5);
  await input.setInputFiles(file('stored-turned.json', JSON.stringify(stored)));
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-outcome]')?.dataset.passed === 'false');
  assert.match(await outcome.textContent(), /front_right moved 0\.500 deg and 0\.0 mm relative to front_left \(limit 0\.100 deg, 10\.0 mm\)/);
  assert.equal(await row.getAttribute('data-moved'), 'true');
  assert.deepEqual((await cells()).filter((_, i) => i !== 3), ['front_right', '0.500', '0.0', '0.100 / 10.0', 'moved']);
  // The exports folded again, so the screenshot shows the comparison under the answer.
  await page.locator('#export-box > summary').click();
  await page.locator('details.more').evaluate((d) => (d.open = false));
  await drift.scrollIntoViewIfNeeded();
  // The table fits the side panel at 1280 px: nothing scrolled sideways out of sight.
  const overflow = await page.locator('#drift .table-wrap').evaluate((el) => el.scrollWidth - el.clientWidth);
  assert.equal(overflow, 0);
  mkdirSync('e2e/artifacts', { recursive: true });
  await page.screenshot({ path: 'e2e/artifacts/drift.png' });

  // Other limits compare again at once: 1 deg lets the turn pass; 3 sigma of gmm's precision
  // (hundredths of a degree) does not.
  await page.locator('#drift [name=rotationDeg]').fill('1');
  await page.locator('#drift [name=rotationDeg]').dispatchEvent('change');
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-outcome]')?.dataset.passed === 'true');
  assert.equal((await cells())[4], '1.000 / 10.0');
  await page.getByLabel('or K sigma').check();
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-outcome]')?.dataset.passed === 'false');
  assert.match((await cells())[4], /^3σ: 0\.\d{3} \/ \d+\.\d$/);
  assert.match(await outcome.textContent(), /front_right moved 0\.500 deg .*\(limit 3 sigma, up to 0\.\d{3} deg/);

  // Malformed files: the library's words (file, place, problem); the result stays.
  const json0 = await page.getByTestId('result-json').textContent();
  const error = page.getByTestId('drift-error');
  await input.setInputFiles(file('broken.json', json.slice(0, 200)));
  await page.waitForFunction(() => !document.querySelector('[data-testid=drift-error]').hidden);
  assert.match(await error.textContent(), /^broken\.json: line \d+ column \d+: EOF while parsing/);
  assert.equal(await outcome.count(), 0);
  await input.setInputFiles(file('bad.yaml', 'transforms:\n  - header: {frame_id: vehicle}\n'));
  await page.waitForFunction(() => /^bad\.yaml/.test(document.querySelector('[data-testid=drift-error]').textContent));
  assert.equal(await error.textContent(), 'bad.yaml: transforms[0].child_frame_id: missing or not text');
  assert.equal(await page.getByTestId('verdict').isVisible(), true);
  assert.equal(await page.getByTestId('result-json').textContent(), json0);
  assert.equal(await page.getByTestId('error').isHidden(), true);

  // A good file again, then a rerun (fewer iterations): the comparison is marked out of date,
  // first by the setting, then by the new result; Compare again brings it up to date.
  await input.setInputFiles(file('gmmcalib-result.json', json));
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-outcome]'));
  assert.equal(await error.isHidden(), true);
  const staleLine = page.getByTestId('drift-stale');
  assert.equal(await staleLine.isHidden(), true);
  await page.locator('#rig-panel > summary').click();
  await page.locator('#iterations').fill('30');
  await page.locator('#iterations').dispatchEvent('change');
  assert.equal(await staleLine.textContent(), 'Out of date: the settings changed after the run it compared. Compare again for the current result.');
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  assert.equal(await staleLine.textContent(), 'Out of date: it compared an earlier result. Compare again for the current result.');
  assert.equal(await outcome.count(), 1);
  await page.getByRole('button', { name: 'Compare again' }).click();
  await page.waitForFunction(() => document.querySelector('[data-testid=drift-stale]').hidden);
  // The new result against the stored one, still at 3 sigma of the combined precision.
  assert.match((await cells())[4], /^3σ: /);
  assert.match(await outcome.textContent(), /gmmcalib-result\.json|front_right moved/);
  assert.deepEqual(problems, []);
});
