// Work that survives, on OpenCalib's Hesai rig (five LiDARs, ../shared/data): after a
// run the page is reloaded and the scans, the rig panel, the settings and the result come back
// from the browser's storage (nothing leaves the machine); Clear forgets them; Copy link copies
// the settings; the result's JSON, saved as a file, opens in a fresh page with the same verdict
// and the scans placed by it; Save PNG carries the verdict line, the legend or the colour bar.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync, writeFileSync } from 'node:fs';
import { SHOTS, browserSession, waitForStatus } from './harness.js';
import { haveData, hesaiFolder } from './realrigs.js';
import { fileTableFits, glance } from './glance.js';

const session = browserSession();
mkdirSync(SHOTS, { recursive: true });

const rows = (page) => page.locator('#files tr:not(.bad)').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));

// Pixels of a PNG (bytes) in a region (shares of its width and height) for which `test(r, g, b)`
// holds: decoded in the page (no PNG decoder here), counted in Node.
async function countPixels(page, png, region, test) {
  const data = await page.evaluate(async ([data, region]) => {
    const bitmap = await createImageBitmap(new Blob([Uint8Array.from(atob(data), (c) => c.charCodeAt(0))]));
    const ctx = new OffscreenCanvas(bitmap.width, bitmap.height).getContext('2d');
    ctx.drawImage(bitmap, 0, 0);
    const [x0, y0, x1, y1] = region.map((v, i) => Math.round(v * (i % 2 ? bitmap.height : bitmap.width)));
    const px = ctx.getImageData(x0, y0, x1 - x0, y1 - y0).data;
    let text = '';
    for (let i = 0; i < px.length; i += 8192) text += String.fromCharCode(...px.subarray(i, i + 8192));
    return btoa(text);
  }, [png.toString('base64'), region]);
  const px = Buffer.from(data, 'base64');
  let n = 0;
  for (let i = 0; i < px.length; i += 4) if (test(px[i], px[i + 1], px[i + 2])) n++;
  return n;
}

async function savePng(page) {
  const [download] = await Promise.all([page.waitForEvent('download'), page.getByRole('button', { name: 'Save PNG' }).click()]);
  return readFileSync(await download.path());
}

test('the Hesai rig: reloaded, its work comes back; Clear forgets; the link; the result file opened again; the PNG', { skip: !haveData && 'no ../shared/data' }, async () => {
  const { page, problems } = await session.open();
  await page.locator('#view').drop({ files: hesaiFolder() });
  await waitForStatus(page, /^5 scans of 5 sensors loaded\.$/);
  await fileTableFits(page);
  assert.equal(await page.getByRole('radio', { name: 'reference p64', exact: true }).isChecked(), true, 'OpenCalib\'s device 0');
  await page.locator('#target-kind').selectOption('none');
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const result = await glance(page, 'hesai');
  const level = result.verdict.level;
  const json = await page.getByTestId('result-json').textContent();
  const table = await rows(page);

  // Save PNG: the verdict line across the top in its level's colours, the five sensors' legend.
  const png = await savePng(page);
  writeFileSync(`${SHOTS}/hesai-saved-view.png`, png);
  const fill = { good: [0x12, 0x28, 0x1a], check: [0x2b, 0x24, 0x10], failed: [0x2c, 0x12, 0x15] }[level];
  const near = ([r, g, b]) => (x, y, z) => Math.abs(x - r) + Math.abs(y - g) + Math.abs(z - b) < 12;
  assert.ok(await countPixels(page, png, [0.1, 0, 0.9, 0.06], near(fill)) > 2000, 'the verdict line');
  for (const colour of [[0xff, 0x6b, 0x6b], [0x4d, 0xab, 0xf7], [0x69, 0xdb, 0x7c], [0xff, 0xd4, 0x3b], [0xda, 0x77, 0xf2]]) {
    assert.ok(await countPixels(page, png, [0, 0.05, 0.12, 0.4], near(colour)) > 20, `the legend's dot ${colour}`);
  }
  // Coloured by height: the colour bar instead, at the bottom right.
  await page.locator('#colour').selectOption('height');
  await page.getByTestId('scale').waitFor();
  const byHeight = await savePng(page);
  writeFileSync(`${SHOTS}/hesai-saved-view-by-height.png`, byHeight);
  const ramp = (r, g, b) => Math.max(r, g, b) > 180 && Math.max(r, g, b) - Math.min(r, g, b) > 120;
  assert.ok(await countPixels(page, byHeight, [0.75, 0.88, 1, 1], ramp) > 500, 'the colour bar');
  await page.locator('#colour').selectOption('sensor');

  // Copy link: the settings, the reference; the scans stay here.
  await page.evaluate(() => (navigator.clipboard.writeText = async (text) => (window.copied = text)));
  await page.getByRole('button', { name: 'Copy link' }).click();
  const link = await page.evaluate(() => window.copied);
  assert.match(link, /#target=none&reference=p64$/);
  await waitForStatus(page, /^Link copied: .*\(it holds the settings; the scans stay in this browser\)$/);

  // The result as a file, from the exports.
  await page.locator('#export-box > summary').click();
  await page.locator('[data-export=json] > summary').click();
  const [download] = await Promise.all([page.waitForEvent('download'), page.locator('[data-export=json] button', { hasText: 'Download' }).click()]);
  const saved = readFileSync(await download.path());
  assert.equal(download.suggestedFilename(), 'gmmcalib-result.json');

  // Reloaded: everything back, the result as it was.
  await page.reload();
  await waitForStatus(page, /^Restored from this browser: 5 scans of 5 sensors, the rig and the settings, the last result\. Clear forgets them\.$/);
  assert.equal(await page.getByTestId('verdict').getAttribute('data-level'), level);
  assert.equal(await page.getByTestId('result-json').textContent(), json);
  assert.deepEqual(await rows(page), table);
  assert.equal(await page.locator('#target-kind').inputValue(), 'none');
  assert.equal(await page.locator('input[name=show][value=after]').isChecked(), true);
  await page.screenshot({ path: `${SHOTS}/hesai-restored-1280x720.png` });

  // Clear forgets, also for the next visit.
  await page.locator('#load-panel summary').click();
  await page.locator('#clear').click();
  await waitForStatus(page, /^Cleared/);
  await page.reload();
  await waitForStatus(page, /^Load scans or run the demo\.$/);
  assert.deepEqual(await rows(page), []);
  assert.equal(await page.getByTestId('verdict').count(), 0);

  // A fresh page: the scans and the result file dropped together show the same verdict, the
  // scans placed by it. A file that is no result is named, and changes nothing.
  const fresh = await session.open();
  await fresh.page.locator('#view').drop({ files: [{ name: 'notes.json', mimeType: 'application/json', buffer: Buffer.from('{"sensors": [1, 2]}') }] });
  await fresh.page.waitForFunction(() => !document.querySelector('[data-testid=error]').hidden);
  assert.match(await fresh.page.getByTestId('error').textContent(), /^notes\.json: not a gmmcalib result/);
  await fresh.page.locator('#view').drop({ files: [...hesaiFolder(), { name: 'gmmcalib-result.json', mimeType: 'application/json', buffer: saved }] });
  await waitForStatus(fresh.page, /^Opened gmmcalib-result\.json: gmm's result for p64, qt_201, qt_202, qt_203, qt_204\.$/);
  assert.equal(await fresh.page.getByTestId('verdict').getAttribute('data-level'), level);
  // The same values (the file is the library's JSON, whose -0 the page's view writes as 0).
  const values = (text) => JSON.parse(JSON.stringify(JSON.parse(text)));
  assert.deepEqual(values(await fresh.page.getByTestId('result-json').textContent()), values(saved.toString()));
  assert.equal(await fresh.page.locator('input[name=show][value=after]').isChecked(), true);
  await fresh.page.screenshot({ path: `${SHOTS}/hesai-opened-from-file-1280x720.png` });
  assert.deepEqual(fresh.problems, []);
  assert.deepEqual(problems, []);
});
