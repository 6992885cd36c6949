// The Livox Mid-100 (../shared/data, read at test time, never copied: GPL) from its middle unit
// L1, the reference the verdict advises when L0 is one (L2 overlaps only L1). The driver gives
// the three units in one frame, so each unit's right start is its identity nominal: every unit
// stays there (a refinement that slid L2 0.78 m along the strip it shares with L1 was once
// taken), and the reference, at one place with the others, is not "the same sensor twice".
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync } from 'node:fs';
import { SHOTS, browserSession, waitForStatus } from './harness.js';
import { haveData, livoxFiles } from './realrigs.js';
import { glance } from './glance.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

test('the Livox rig from the middle unit: every unit stays at its right start', { skip: !haveData && 'no ../shared/data' }, async () => {
  const { page, problems } = await session.open();
  await page.locator('#view').drop({ files: livoxFiles() });
  await waitForStatus(page, /^3 scans of 3 sensors loaded/);
  await page.locator('#target-kind').selectOption('none');
  await page.getByRole('radio', { name: 'reference L1', exact: true }).check();
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 300_000);
  const r = await glance(page, 'livox-middle-reference');
  assert.equal(r.reference, 'L1');
  assert.equal(r.verdict.sensors.L1.level, 'good', JSON.stringify(r.verdict.sensors.L1.reasons));
  for (const s of r.sensors.filter((x) => x.name !== 'L1')) {
    const moved = Math.hypot(s.correction[3], s.correction[7], s.correction[11]);
    assert.ok(moved < 0.05, `${s.name} moved ${moved.toFixed(3)} m from its start`);
  }
  assert.deepEqual(problems, []);
});
