// The page as a daily tool, through the paths a user takes: the answer first and in
// view at 1280x720, state that never goes stale, a layout from a laptop to a wide monitor, the
// view's tools (sensors shown, point size, colour scales, preset views, focus, picking,
// measuring, PNG), help on every control. Screenshots at 1280x720 and 1920x1080 land in
// e2e/artifacts/.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { mkdirSync, readFileSync } from 'node:fs';
import { browserSession, loadedPoints, waitForStatus, waitForView } from './harness.js';

const session = browserSession();
mkdirSync('e2e/artifacts', { recursive: true });

const inViewport = (locator) => locator.evaluate((el) => {
  const r = el.getBoundingClientRect();
  return r.top >= 0 && r.left >= 0 && r.bottom <= innerHeight && r.right <= innerWidth && r.height > 0;
});

// A demo run of the paper rig (2 frames, few iterations: the layout is under test, not the
// accuracy), at the page's 1280x720.
async function demoRun(hash = '#demo=paper&frames=2') {
  const { page, problems } = await session.open(hash);
  await waitForStatus(page, /Calibrate next/);
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  return { page, problems };
}

test('the answer first: verdict and the first extrinsic in view at 1280x720 without scrolling', async () => {
  const { page, problems } = await demoRun();
  assert.deepEqual(page.viewportSize(), { width: 1280, height: 720 });
  assert.equal(await page.locator('#side').evaluate((el) => el.scrollTop), 0, 'nothing scrolled');
  assert.ok(await inViewport(page.getByTestId('verdict')), 'the verdict is in view');
  const extrinsic = page.getByTestId('extrinsic').first();
  assert.ok(await inViewport(extrinsic), 'the first sensor\'s extrinsic is in view');
  // The table says which way its transforms map; each row holds a sensor's xyz and rpy as the
  // JSON has them; the sensor-to-sensor transform is on the sensor's card; the reference is a
  // row of its own.
  assert.equal(await page.locator('.answer-table > .direction').textContent(), 'T_vehicle_s: maps each sensor\'s points into vehicle');
  const result = JSON.parse(await page.getByTestId('result-json').textContent());
  const [xyz, rpy] = (await extrinsic.locator('td.numbers').textContent()).split('\n').map((line) => line.trim().split(/\s+/).slice(1, 4).map(Number));
  assert.deepEqual(xyz, [3, 7, 11].map((k) => +result.sensors[1].extrinsic[k].toFixed(4)));
  assert.deepEqual(rpy, result.sensors[1].rpy.map((r) => +((r * 180) / Math.PI).toFixed(3)));
  const relative = page.getByTestId('relative').first();
  assert.match(await relative.textContent(), /T_front_left_front_right: maps front_right's points into front_left/);
  const shownXyz = (await relative.locator('pre').textContent()).split('\n')[0].trim().split(/\s+/).slice(2).map(Number);
  assert.deepEqual(shownXyz, [3, 7, 11].map((k) => +result.sensors[1].relative[k].toFixed(6)));
  assert.match(await page.getByTestId('reference-line').textContent(), /front_left\s*reference/);
  // Copy gives the block as users paste it, its direction first.
  await page.evaluate(() => (navigator.clipboard.writeText = async (text) => (window.copied = text)));
  await page.getByRole('button', { name: 'Copy T_vehicle_front_right' }).click();
  const copied = await page.evaluate(() => window.copied);
  assert.match(copied, /^# T_vehicle_front_right: maps front_right's points into vehicle\nxyz \(m\) +\S+ \S+ \S+\nrpy \(deg\) +\S+ \S+ \S+\nquat \(x y z w\) +\S+ \S+ \S+ \S+$/);
  // EM's convergence, as the JSON has it.
  const run = page.getByTestId('run-summary');
  assert.equal(await run.getAttribute('data-converged'), String(result.converged));
  assert.match(await run.textContent(), result.converged ? /converged/ : /not converged/);
  // The rest folds below; the setup panels fold to one line each and say what they hold.
  assert.equal(await page.locator('details.more').evaluate((d) => d.open), false);
  assert.match(await page.locator('#load-panel summary').textContent(), /4 scans of 2 sensors, 2 frames/);
  assert.match(await page.locator('#rig-panel summary').textContent(), /reference front_left, gmm, target cube:0\.5/);
  // The inset is labelled and shown now that there is a target.
  assert.equal(await page.getByTestId('inset').isVisible(), true);
  assert.match(await page.getByTestId('inset').textContent(), /Reconstructed target/);
  await waitForView(page, await loadedPoints(page, '1'));
  await page.screenshot({ path: 'e2e/artifacts/page-1280x720.png' });
  const drawn = await page.locator('#view').evaluate((v) => Number(v.dataset.frames));
  await page.setViewportSize({ width: 1920, height: 1080 });
  assert.ok(await inViewport(page.getByTestId('extrinsic').first()));
  await page.waitForFunction((k) => Number(document.querySelector('#view').dataset.frames) > k, drawn);
  await waitForView(page, await loadedPoints(page, '1'));
  await page.screenshot({ path: 'e2e/artifacts/page-1920x1080.png' });
  assert.deepEqual(problems, []);
});

test('state never goes stale: edits mark the result out of date, Clear resets, Calibrate says why it waits', async () => {
  // 8 frames and 2000 components: JRMPC runs long enough (1.5 s on the 2-vCPU VM) for the
  // worker's progress, posted at most every 100 ms, to reach the page about ten times.
  const { page, problems } = await session.open('#demo=paper&frames=8&components=2000&iterations=100');
  await waitForStatus(page, /Calibrate next/);
  // The time left comes from measured iterations: none for the first few. The status line says
  // what runs, the time line under the bar how long it has and will take.
  await page.evaluate(() => {
    window.statuses = [];
    window.times = [];
    const status = document.querySelector('[data-testid=status]');
    const time = document.querySelector('[data-testid=progress-time]');
    new MutationObserver(() => window.statuses.push(status.textContent)).observe(status, { childList: true, characterData: true, subtree: true });
    new MutationObserver(() => window.times.push([status.textContent, time.textContent])).observe(time, { childList: true, characterData: true, subtree: true });
  });
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  const statuses = await page.evaluate(() => window.statuses);
  const times = await page.evaluate(() => window.times);
  const early = times.filter(([t]) => /^JRMPC iteration [123]\//.test(t));
  assert.ok(early.length && early.every(([, time]) => /^\d+\.\d s elapsed$/.test(time)), JSON.stringify(early));
  assert.ok(times.some(([t, time]) => /^JRMPC iteration \d+\/100/.test(t) && /^\d+\.\d s elapsed, about \d+ s left in this stage$/.test(time)), JSON.stringify(times));
  // EM's last iteration is shown, also when it converged before the maximum.
  const iterations = statuses.at(-1).match(/^Done: (\d+) iterations/)[1];
  assert.ok(statuses.filter((t) => t.startsWith('JRMPC')).at(-1).startsWith(`JRMPC iteration ${iterations}/100,`), JSON.stringify(statuses));
  assert.equal(await page.getByTestId('progress-time').textContent(), '', 'no time line once done');
  assert.equal(await page.getByTestId('stale').isHidden(), true);

  // A sensor renamed in the file table (panel 1 folded after the run: opened as a user would).
  await page.locator('#load-panel summary').click();
  await page.getByLabel('sensor of front_right_2', { exact: true }).fill('rear');
  await page.getByLabel('sensor of front_right_2', { exact: true }).press('Enter');
  await page.getByLabel('sensor of front_right_2', { exact: true }).blur();
  await waitForStatus(page, /The sensors changed: the result below is out of date\. Calibrate again\./);
  assert.equal(await page.getByTestId('stale').isVisible(), true);
  assert.equal(await page.getByTestId('calibrate').isEnabled(), true);
  assert.ok(await page.getByTestId('verdict').count(), 'the old result stays readable');
  await page.getByLabel('sensor of front_right_2', { exact: true }).fill('front_right');
  await page.getByLabel('sensor of front_right_2', { exact: true }).blur();

  // A setting changed: out of date too; a new run is current again.
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 180_000);
  assert.equal(await page.getByTestId('stale').isHidden(), true);
  await page.locator('#rig-panel summary').click();
  await page.locator('#iterations').fill('20');
  await page.locator('#iterations').blur();
  await waitForStatus(page, /The settings changed: the result below is out of date/);
  assert.match(await page.getByTestId('stale').textContent(), /Out of date: the settings changed after this run/);
  await page.getByLabel('front_right yaw', { exact: true }).fill('1');
  await page.getByLabel('front_right yaw', { exact: true }).blur();
  await waitForStatus(page, /The nominal extrinsics changed/);

  // Clear: no progress left over, and Calibrate says why it waits.
  assert.equal(await page.getByTestId('progress').evaluate((p) => p.value), 1);
  await page.locator('#load-panel summary').click();
  await page.locator('#clear').click();
  assert.equal(await page.getByTestId('progress').evaluate((p) => p.value), 0);
  assert.equal(await page.getByTestId('calibrate').isDisabled(), true);
  assert.match(await page.getByTestId('calibrate-why').textContent(), /Load scans/);
  // One sensor only: why it cannot run, named.
  const { pcdAscii } = await import('./rigfiles.js');
  const cube = new Float32Array(300).map((_, i) => (i % 3 === 0 ? 10 : 0) + Math.sin(i));
  await page.getByTestId('file-input').setInputFiles(['left_1.pcd', 'left_2.pcd'].map((name) => ({ name, mimeType: 'application/octet-stream', buffer: pcdAscii(cube) })));
  await waitForStatus(page, /2 scans of 1 sensor loaded/);
  assert.equal(await page.getByTestId('calibrate').isDisabled(), true);
  assert.match(await page.getByTestId('calibrate-why').textContent(), /Needs scans of two sensors or more; all 2 scans belong to left/);
  assert.equal(await page.getByTestId('calibrate').getAttribute('aria-describedby'), 'calibrate-why');
  assert.deepEqual(problems, []);
});

test('layout: from 1024 px to a wide screen, a resizable and collapsible side panel, nothing cut off', async () => {
  const { page, problems } = await session.open('#demo=paper&frames=2');
  await waitForStatus(page, /Calibrate next/);
  // Before a run: no empty inset, no empty convergence plot.
  assert.equal(await page.getByTestId('inset').isHidden(), true);
  assert.equal(await page.locator('#convergence-box').isHidden(), true);
  for (const width of [1024, 1280, 1920]) {
    await page.setViewportSize({ width, height: 768 });
    const side = await page.locator('#side').evaluate((el) => ({ width: el.clientWidth, overflow: el.scrollWidth - el.clientWidth }));
    const view = await page.locator('#view').boundingBox();
    assert.ok(side.overflow <= 0, `${width}: the side panel overflows by ${side.overflow} px`);
    assert.ok(view.width >= width * 0.55, `${width}: the view is ${view.width} px wide`);
    // Every nominal shows in full in its input.
    const cut = await page.locator('#rig input[type=number]').evaluateAll((inputs) => inputs.filter((i) => i.scrollWidth > i.clientWidth).map((i) => i.value));
    assert.deepEqual(cut, [], `${width}: values cut off`);
  }
  // The separator: arrow keys make the panel narrower, the Panel button hides it.
  await page.setViewportSize({ width: 1280, height: 720 });
  const before = (await page.locator('#side').boundingBox()).width;
  await page.locator('#resizer').focus();
  for (let i = 0; i < 3; i++) await page.keyboard.press('ArrowLeft');
  const after = (await page.locator('#side').boundingBox()).width;
  assert.ok(Math.abs(before - after - 72) < 2, `${before} -> ${after}`);
  // Dragged by mouse too.
  const bar = await page.locator('#resizer').boundingBox();
  await page.mouse.move(bar.x + 3, bar.y + 200);
  await page.mouse.down();
  await page.mouse.move(bar.x + 103, bar.y + 200, { steps: 4 });
  await page.mouse.up();
  assert.ok(Math.abs((await page.locator('#side').boundingBox()).width - after - 100) < 3);
  await page.getByRole('button', { name: 'Panel' }).click();
  assert.equal(await page.locator('#side').isHidden(), true);
  assert.ok((await page.locator('#view').boundingBox()).width >= 1270);
  await page.getByRole('button', { name: 'Panel' }).click();
  assert.equal(await page.locator('#side').isVisible(), true);
  assert.deepEqual(problems, []);
});

// Pixels of the view (page coordinates) showing a point of the sensor coloured `rgb`, found in
// a screenshot of the view: [[x, y], ...], spread over the view.
async function pixelsOf(page, rgb) {
  const box = await page.locator('#view').boundingBox();
  const png = await page.screenshot({ clip: box });
  const found = await page.evaluate(async ([data, [r, g, b]]) => {
    const bitmap = await createImageBitmap(new Blob([Uint8Array.from(atob(data), (c) => c.charCodeAt(0))], { type: 'image/png' }));
    const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
    const ctx = canvas.getContext('2d');
    ctx.drawImage(bitmap, 0, 0);
    const { data: px, width, height } = ctx.getImageData(0, 0, bitmap.width, bitmap.height);
    const out = [];
    // An isolated point's pixel with its three neighbours to the right and below of its colour.
    const is = (x, y) => { const i = 4 * (y * width + x); return Math.abs(px[i] - r) + Math.abs(px[i + 1] - g) + Math.abs(px[i + 2] - b) < 40; };
    for (let y = 10; y < height - 10; y += 3) for (let x = 10; x < width - 10; x += 3) if (is(x, y) && is(x + 1, y) && is(x, y + 1) && is(x + 1, y + 1)) out.push([x, y]);
    return out;
  }, [png.toString('base64'), rgb]);
  return found.map(([x, y]) => [box.x + x + 0.5, box.y + y + 0.5]);
}

const frames = (page) => page.locator('#view').evaluate((v) => Number(v.dataset.frames));

test('the view: sensors shown, point size, colour scales, preset views, focus, PNG', async () => {
  const { page, problems } = await demoRun();
  const first = await loadedPoints(page, '1');
  await waitForView(page, first);
  // The inset: resized by its corner, hidden by its close button.
  const inset = await page.getByTestId('inset').boundingBox();
  await page.mouse.move(inset.x + inset.width - 3, inset.y + inset.height - 3);
  await page.mouse.down();
  await page.mouse.move(inset.x + inset.width + 97, inset.y + inset.height + 57, { steps: 5 });
  await page.mouse.up();
  const grown = await page.getByTestId('inset').boundingBox();
  assert.ok(grown.width > inset.width + 80 && grown.height > inset.height + 40, JSON.stringify([inset, grown]));
  await page.getByRole('button', { name: 'Hide the target view' }).click();
  assert.equal(await page.getByTestId('inset').isHidden(), true);
  // Hide front_right: only front_left's first frame is drawn.
  const left = await page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => tr.querySelectorAll('td')).filter((c) => c[1].firstChild.value === 'front_left' && c[2].firstChild.value === '1').map((c) => Number(c[4].textContent.replaceAll(',', ''))));
  await page.getByLabel('show front_right').uncheck();
  await waitForView(page, left[0]);
  await page.getByLabel('show front_right').check();
  await waitForView(page, first);
  // Colour by height: a scale with its range, the sensor dots muted.
  assert.equal(await page.getByTestId('scale').isHidden(), true);
  await page.locator('#colour').selectOption('height');
  await page.getByTestId('scale').waitFor();
  assert.match(await page.getByTestId('scale').textContent(), /height \(vehicle z, m\), 2nd–98th percentile.*-?\d+\.\d\d.*\d+\.\d\d/);
  assert.equal(await page.locator('#legend').evaluate((l) => l.classList.contains('muted')), true);
  // The demo's scans carry no intensity: the scale says so.
  await page.locator('#colour').selectOption('intensity');
  await page.waitForFunction(() => document.querySelector('[data-testid=scale]').dataset.mode === 'intensity');
  assert.match(await page.getByTestId('scale').textContent(), /these scans carry none/);
  // Distance to the reference's points, after calibration: most of front_right's points on
  // the reference's surfaces.
  await page.locator('#colour').selectOption('distance');
  await page.waitForFunction(() => document.querySelector('[data-testid=scale]').dataset.mode === 'distance');
  assert.match(await page.getByTestId('scale').textContent(), /distance to the reference's surface \(m\).*0\.00.*0\.05 and beyond/);
  await page.waitForTimeout(300);
  await page.screenshot({ path: 'e2e/artifacts/page-distance.png' });
  // Before calibration (the nominal, off by degrees) the points lie further from the
  // reference's surfaces than after.
  const median = () => page.getByTestId('scale').evaluate((s) => Number(s.dataset.median));
  const after = await median();
  await page.locator('input[name=show][value=before]').check();
  await page.waitForFunction((m) => Number(document.querySelector('[data-testid=scale]').dataset.median) !== m, after);
  const before = await median();
  console.log(`median distance to the reference's surface: ${(before * 100).toFixed(1)} cm before, ${(after * 100).toFixed(1)} cm after`);
  assert.ok(after < 0.01 && before > 2 * after, `${before} m before, ${after} m after`);
  await page.locator('input[name=show][value=after]').check();
  await page.locator('#colour').selectOption('sensor');
  await page.waitForFunction(() => document.querySelector('[data-testid=scale]').hidden);
  // Point size, preset views and focus each draw a new frame.
  for (const act of [
    () => page.locator('#point-size').fill('5'),
    () => page.getByRole('button', { name: 'Top', exact: true }).click(),
    () => page.getByRole('button', { name: 'Side', exact: true }).click(),
    () => page.getByRole('button', { name: 'Front', exact: true }).click(),
    () => page.locator('#focus').selectOption('target:0'),
    () => page.locator('#focus').selectOption('roi'),
    () => page.locator('#focus').selectOption('all'),
  ]) {
    const n = await frames(page);
    await act();
    await page.waitForFunction((k) => Number(document.querySelector('#view').dataset.frames) > k, n);
  }
  assert.deepEqual(await page.locator('#focus option').allTextContents(), ['…', 'everything', 'the ROI', 'sensor front_left', 'sensor front_right', 'target 1', 'target 2', 'target 3']);
  // Save PNG: a download of the whole view, with points in it.
  await page.getByRole('button', { name: 'Top', exact: true }).click();
  const [download] = await Promise.all([page.waitForEvent('download'), page.getByRole('button', { name: 'Save PNG' }).click()]);
  assert.equal(download.suggestedFilename(), 'gmmcalib-view.png');
  const png = readFileSync(await download.path());
  assert.equal(png.subarray(1, 4).toString(), 'PNG');
  const colours = await page.evaluate(async (data) => {
    const bitmap = await createImageBitmap(new Blob([Uint8Array.from(atob(data), (c) => c.charCodeAt(0))]));
    const ctx = new OffscreenCanvas(bitmap.width, bitmap.height).getContext('2d');
    ctx.drawImage(bitmap, 0, 0);
    const px = ctx.getImageData(0, 0, bitmap.width, bitmap.height).data;
    let red = 0;
    for (let i = 0; i < px.length; i += 4) if (px[i] > 200 && px[i + 1] < 140 && px[i + 2] < 140) red++;
    return { width: bitmap.width, red };
  }, png.toString('base64'));
  const view = await page.locator('#view').boundingBox();
  assert.equal(colours.width, Math.round(view.width));
  assert.ok(colours.red > 100, `${colours.red} pixels of front_left's red in the PNG`);
  const drawn = await frames(page);
  await page.setViewportSize({ width: 1920, height: 1080 });
  await page.waitForFunction((k) => Number(document.querySelector('#view').dataset.frames) > k, drawn);
  await waitForView(page, first);
  await page.screenshot({ path: 'e2e/artifacts/page-top-1920x1080.png' });
  assert.deepEqual(problems, []);
});

test('picking a point and measuring between two', async () => {
  const { page, problems } = await demoRun();
  await waitForView(page, await loadedPoints(page, '1'));
  await page.getByRole('button', { name: 'Panel' }).click(); // the whole width for the view
  await page.getByRole('button', { name: 'Top', exact: true }).click();
  await page.locator('#point-size').fill('4');
  await page.waitForTimeout(500);
  const reds = await pixelsOf(page, [0xff, 0x6b, 0x6b]);
  assert.ok(reds.length > 10, `${reds.length} red pixels`);
  // A click on a red point: front_left, its coordinates in the vehicle frame.
  await page.mouse.click(...reds[0]);
  await page.getByTestId('readout').waitFor();
  const one = await page.getByTestId('readout').textContent();
  assert.match(one, /^front_left \(frame 1\): -?\d+\.\d{3}, -?\d+\.\d{3}, -?\d+\.\d{3} m$/);
  // Measure: two picks far apart, their distance as the two coordinates give it.
  await page.getByRole('button', { name: 'Measure' }).click();
  assert.equal(await page.getByRole('button', { name: 'Measure' }).getAttribute('aria-pressed'), 'true');
  const [a, b] = [reds[0], reds.reduce((far, p) => (Math.hypot(p[0] - reds[0][0], p[1] - reds[0][1]) > Math.hypot(far[0] - reds[0][0], far[1] - reds[0][1]) ? p : far))];
  await page.mouse.click(...a);
  await page.waitForFunction(() => /click the second point/.test(document.querySelector('[data-testid=readout]').textContent));
  await page.mouse.click(...b);
  await page.waitForFunction(() => /distance A–B/.test(document.querySelector('[data-testid=readout]').textContent));
  const text = await page.getByTestId('readout').textContent();
  const [pa, pb] = [...text.matchAll(/: (-?\d+\.\d+), (-?\d+\.\d+), (-?\d+\.\d+) m/g)].map((m) => m.slice(1).map(Number));
  const d = Number(text.match(/distance A–B: (\d+\.\d+) m/)[1]);
  assert.ok(Math.abs(d - Math.hypot(pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2])) < 0.003, text);
  assert.ok(d > 0.5, text);
  await page.screenshot({ path: 'e2e/artifacts/page-measure.png' });
  // Escape ends measuring and clears the marks.
  await page.keyboard.press('Escape');
  assert.equal(await page.getByTestId('readout').isHidden(), true);
  assert.deepEqual(problems, []);
});

test('help and accessibility: every control labelled, tooltips on parameters and columns, visible focus, contrast, How it works', async () => {
  const { page, problems } = await demoRun();
  await page.locator('#load-panel summary').click();
  await page.locator('#rig-panel summary').click();
  await page.locator('details.more summary').click();
  // Every control has a name a screen reader reads.
  const unnamed = await page.evaluate(() => [...document.querySelectorAll('input, select, button, [role=separator], canvas')]
    .filter((el) => el.type !== 'hidden' && !(el.hidden && el.type === 'file'))
    .filter((el) => !(el.getAttribute('aria-label') || el.labels?.length || el.textContent.trim() || el.closest('label')))
    .map((el) => el.outerHTML.slice(0, 80)));
  assert.deepEqual(unnamed, []);
  // Every parameter and every column says what it is.
  const untitled = await page.evaluate(() => [
    ...[...document.querySelectorAll('.settings label, .toolbar label')].filter((l) => !l.title && !l.closest('#legend')).map((l) => l.textContent.trim()),
    ...[...document.querySelectorAll('table.files tr:first-child th')].filter((th) => !th.title).map((th) => th.textContent),
  ]);
  assert.deepEqual(untitled, []);
  // Keyboard focus is visible.
  await page.locator('#demo').focus();
  await page.keyboard.press('Tab');
  const outline = await page.evaluate(() => getComputedStyle(document.activeElement).outlineStyle);
  assert.notEqual(outline, 'none');
  // Text contrast (WCAG AA, 4.5:1) of the page's kinds of text against what lies behind them.
  const low = await page.evaluate(() => {
    const rgb = (s) => s.match(/[\d.]+/g).map(Number);
    const lum = ([r, g, b]) => [r, g, b].map((c) => { c /= 255; return c <= 0.03928 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; }).reduce((s, c, i) => s + c * [0.2126, 0.7152, 0.0722][i], 0);
    const background = (el) => {
      for (let e = el; e; e = e.parentElement) {
        const c = rgb(getComputedStyle(e).backgroundColor);
        if (c.length < 4 || c[3] > 0.5) return c;
      }
      return [15, 17, 21];
    };
    const out = [];
    for (const el of document.querySelectorAll('.hint, .summary, .run, .direction, .reference, .precision, .spread, .stale, .error, button, label, th, td, summary, #status, .truth b, .sensor-verdict, .not-converged')) {
      if (!el.getClientRects().length || !el.textContent.trim()) continue;
      const style = getComputedStyle(el);
      const [a, b] = [lum(rgb(style.color)), lum(background(el))];
      const ratio = (Math.max(a, b) + 0.05) / (Math.min(a, b) + 0.05) * (style.opacity < 1 && !el.disabled ? 0 : 1);
      if (ratio < 4.5 && !el.disabled && !el.closest('button:disabled')) out.push(`${el.tagName}.${el.className} ${ratio.toFixed(2)}: ${el.textContent.trim().slice(0, 30)}`);
    }
    return out;
  });
  assert.deepEqual(low, []);
  // How it works: linked from the header, the stages in plain words.
  const [how] = await Promise.all([page.waitForEvent('popup'), page.getByRole('link', { name: 'How it works' }).click()]);
  await how.waitForLoadState();
  const headings = await how.locator('h2').allTextContents();
  assert.deepEqual(headings, ['Which way a transform maps', 'The stages of a calibration (method gmm)', 'The parameters', 'Files and columns', 'The view']);
  assert.equal(await how.locator('#stages + ol > li').count(), 9);
  assert.match(await how.locator('body').textContent(), /moved by 4\.110 deg in all" is the whole rotation/);
  assert.deepEqual(problems, []);
});

test('loose files without a sensor in their names: one sensor assumed, said, and asked', async () => {
  const { page, problems } = await session.open();
  const { pcdAscii } = await import('./rigfiles.js');
  const cloud = new Float32Array(300).map((_, i) => 5 + Math.sin(i));
  await page.getByTestId('file-input').setInputFiles(['1.pcd', '2.pcd', '3.pcd'].map((name) => ({ name, mimeType: 'application/octet-stream', buffer: pcdAscii(cloud) })));
  await waitForStatus(page, /3 scans of 1 sensor loaded; 3 files without a sensor in their names taken as frames of sensor_1/);
  const question = page.getByTestId('loose-question');
  assert.match(await question.textContent(), /3 files carry no sensor in their names \(1\.pcd, 2\.pcd, 3\.pcd\)\. Taken as one sensor, sensor_1, with 3 frames/);
  const rows = () => page.locator('#files tr').evaluateAll((trs) => trs.slice(1).map((tr) => [...tr.querySelectorAll('input')].map((i) => i.value).join('/')));
  assert.deepEqual(await rows(), ['sensor_1/1', 'sensor_1/2', 'sensor_1/3']);
  assert.match(await page.getByTestId('calibrate-why').textContent(), /Needs scans of two sensors or more/);
  await page.screenshot({ path: 'e2e/artifacts/page-loose.png' });
  await page.getByRole('button', { name: 'Each file is a sensor' }).click();
  assert.deepEqual(await rows(), ['1/1', '2/1', '3/1']);
  await waitForStatus(page, /Each of the 3 files is a sensor of its own: 3 sensors\./);
  assert.equal(await question.count(), 0);
  assert.equal(await page.getByTestId('calibrate').isEnabled(), true);
  assert.deepEqual(problems, []);
});

test('intensity spans its 2nd-98th percentile: a few bright returns do not paint the rest blue', async () => {
  const { page, problems } = await session.open();
  // GMMCalib-like intensities: mostly 30-60, 1 % at 5615.
  const pcd = (shift) => {
    const lines = Array.from({ length: 2000 }, (_, i) => `${8 + (i % 40) * 0.05} ${shift + Math.floor(i / 40) * 0.05} ${0.1 * Math.sin(i)} ${i % 100 === 0 ? 5615 : 30 + (i % 31)}`);
    return Buffer.from(['VERSION 0.7', 'FIELDS x y z intensity', 'SIZE 4 4 4 4', 'TYPE F F F F', 'COUNT 1 1 1 1', 'WIDTH 2000', 'HEIGHT 1',
      'VIEWPOINT 0 0 0 1 0 0 0', 'POINTS 2000', 'DATA ascii', ...lines, ''].join('\n'));
  };
  await page.getByTestId('file-input').setInputFiles([['a_1.pcd', 0], ['b_1.pcd', 0.02]].map(([name, shift]) => ({ name, mimeType: 'application/octet-stream', buffer: pcd(shift) })));
  await waitForStatus(page, /2 scans of 2 sensors loaded/);
  await page.locator('#colour').selectOption('intensity');
  await page.waitForFunction(() => document.querySelector('[data-testid=scale]').dataset.mode === 'intensity');
  const scale = await page.getByTestId('scale').textContent();
  assert.match(scale, /intensity, 2nd–98th percentile/);
  const [lo, hi] = [await page.locator('#scale-lo').textContent(), await page.locator('#scale-hi').textContent()].map(Number);
  assert.ok(lo >= 30 && lo <= 32 && hi >= 58 && hi <= 60, `${lo}..${hi}`);
  await page.screenshot({ path: 'e2e/artifacts/page-intensity.png' });
  assert.deepEqual(problems, []);
});
