// Issue 39, GMMCalib's own samples as a new user drops them (../shared/data): the cube (two roof
// LiDARs, a 0.5 m cube, config.yaml) and the chair (its CAD model chair.obj beside the scans).
// Each loads with its config, the file table fitting the panel, calibrates, and reads at a
// glance at 1280x720 and 1400x900 (e2e/glance.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { SHOTS, browserSession, waitForStatus } from './harness.js';
import { chairFolder, cubeFolder, haveData } from './realrigs.js';
import { fileTableFits, glance } from './glance.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

for (const [name, files, target] of [['cube', cubeFolder, /^cube:0\.5$/], ['chair', chairFolder, /^mesh:chair\/chair\.obj$/]]) {
  test(`GMMCalib's ${name} sample: loaded with its config, calibrated, read at a glance`, { skip: !haveData && 'no ../shared/data' }, async () => {
    const { page, problems } = await session.open();
    await page.locator('#view').drop({ files: files() });
    await waitForStatus(page, /^6 scans of 2 sensors loaded\.$/);
    await fileTableFits(page);
    assert.match(await page.locator('#rig-summary').textContent(), /ROI set/, 'the config\'s ROI');
    assert.match(page.url(), /roi=/);
    assert.match(decodeURIComponent(page.url()), new RegExp(`target=${target.source.slice(1, -1)}|^[^#]*#(?!.*target=)`));
    await page.getByTestId('calibrate').click();
    await waitForStatus(page, /^Done/, 180_000);
    const r = await glance(page, name);
    console.log(`${name}: ${r.verdict.level}, ${await page.getByTestId('status').textContent()}`);
    assert.deepEqual(problems, []);
  });
}
