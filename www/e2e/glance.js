// "Results at a glance", checked the same way on every real rig after its run: at
// 1280x720 and 1400x900 the verdict and every sensor's extrinsic are in view with nothing
// scrolled; each reason of the verdict is said as often as the result has it (once per sensor
// that has it), not again in a banner and a card; a sensor-to-sensor transform equal to the
// extrinsic is not printed again; one frame shows no spread; the selection's table is the
// result's. Screenshots of both sizes go to
// SHOTS. And before a run: the file table fits the side panel, no name cut off.
import assert from 'node:assert/strict';
import { SHOTS } from './harness.js';

const inViewport = (locator) => locator.evaluate((el) => {
  const r = el.getBoundingClientRect();
  return r.top >= 0 && r.left >= 0 && r.bottom <= innerHeight && r.right <= innerWidth && r.height > 0;
});

const count = (text, part) => text.split(part).length - 1;
const same = (a, b) => a.every((v, i) => Math.abs(v - b[i]) < 1e-8);

// Waits until the view has drawn no new frame for 700 ms (its last frame the full clouds).
export async function still(page) {
  let frames = -1;
  for (;;) {
    await page.waitForTimeout(700);
    const now = await page.locator('#view').evaluate((v) => Number(v.dataset.frames ?? 0));
    if (now === frames) return;
    frames = now;
  }
}

export async function fileTableFits(page) {
  const table = await page.locator('#files').evaluate((el) => ({ overflow: el.scrollWidth - el.clientWidth, cut: [...el.querySelectorAll('input')].filter((i) => i.scrollWidth > i.clientWidth).map((i) => i.value) }));
  assert.ok(table.overflow <= 0, `the file table overflows by ${table.overflow} px`);
  assert.deepEqual(table.cut, [], 'names cut off in the file table');
}

async function inView(page, size) {
  assert.equal(await page.locator('#side').evaluate((el) => el.scrollTop), 0, `${size}: nothing scrolled`);
  assert.ok(await inViewport(page.getByTestId('verdict')), `${size}: the verdict is in view`);
  const rows = page.getByTestId('extrinsic');
  for (let i = 0; i < (await rows.count()); i++) assert.ok(await inViewport(rows.nth(i)), `${size}: ${await rows.nth(i).getAttribute('data-sensor')}'s extrinsic is in view`);
  assert.ok(await inViewport(page.getByTestId('reference-line')), `${size}: the reference's row is in view`);
}

// The selection's table says what the result's selection holds: per sensor a row per
// hypothesis in its order, named (a levelling by what it levelled), the chosen one marked, and
// where a hypothesis's ground was compared with the others', how far apart (mm / deg).
async function selectionShown(page, r) {
  for (const s of r.selection) {
    const rows = page.locator(`[data-testid=hypothesis][data-sensor="${s.sensor}"]`);
    assert.equal(await rows.count(), s.hypotheses.length, `${s.sensor}: a row per hypothesis`);
    assert.deepEqual(await rows.evaluateAll((all) => all.map((row) => row.dataset.stage)), s.hypotheses.map((h) => h.stage));
    const chosen = page.locator(`[data-testid=hypothesis][data-sensor="${s.sensor}"][data-chosen]`);
    assert.equal(await chosen.getAttribute('data-stage'), s.hypotheses[s.chosen].stage, `${s.sensor}: the chosen row`);
    // A levelling is named by what it levelled: the best-scored global candidates are levelled.
    const named = await rows.evaluateAll((all) => all.map((row) => row.children[1].textContent.replace(/^▶ /, '')));
    s.hypotheses.forEach((h, i) => {
      if (h.stage === 'levelled' && h.parent != null) assert.equal(named[i], `levelled ${named[h.parent]}`, `${s.sensor}: hypothesis ${i}'s name`);
    });
    const grounds = await rows.evaluateAll((all) => all.map((row) => row.lastElementChild.textContent));
    s.hypotheses.forEach((h, i) => {
      const said = h.ground ? `${(1000 * h.ground.height).toFixed(1)} mm / ${(h.ground.tilt * 180 / Math.PI).toFixed(3)} deg` : '';
      assert.equal(grounds[i], said, `${s.sensor}: hypothesis ${i}'s grounds`);
    });
  }
}

// After a run: the checks above, and `${SHOTS}/${name}-1280x720.png`, `-1400x900.png`.
export async function glance(page, name) {
  await page.setViewportSize({ width: 1280, height: 720 });
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  const r = Array.isArray(result) ? result[0] : result;
  await inView(page, '1280x720');
  const text = await page.locator('#results').textContent();
  const reasons = [...Object.values(r.verdict.sensors).flatMap((s) => s.reasons), ...r.verdict.reasons].map((x) => x.text);
  for (const reason of new Set(reasons)) {
    assert.equal(count(text, reason), count(reasons.join('\n'), reason), `"${reason}" is said as often as the result has it`);
  }
  for (const s of r.sensors.filter((s) => s.name !== r.reference)) {
    const relative = page.locator(`[data-testid=relative][data-sensor="${s.name}"]`);
    assert.equal(await relative.locator('pre').count(), same(s.relative, s.extrinsic) ? 0 : 1, `${s.name}: T_ref_s printed only when it differs`);
    if (s.spread.frames < 2) assert.equal(await page.locator(`.answer-sensor[data-sensor="${s.name}"] .spread`).count(), 0, `${s.name}: no spread for one frame`);
  }
  await selectionShown(page, r);
  await still(page);
  await page.screenshot({ path: `${SHOTS}/${name}-1280x720.png` });
  await page.setViewportSize({ width: 1400, height: 900 });
  await still(page);
  await inView(page, '1400x900');
  await page.screenshot({ path: `${SHOTS}/${name}-1400x900.png` });
  await page.setViewportSize({ width: 1280, height: 720 });
  return r;
}
