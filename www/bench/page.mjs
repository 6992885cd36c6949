// The page's own two timings, so a change to the page can show it costs neither (issue 39):
// first paint (the browser's first-contentful-paint of a fresh page, no cache) and the demo's
// time to result (Demo clicked, then Calibrate, until the status line says Done; the paper rig,
// 4 frames, seed 1, as a new user gets it). Each is measured RUNS times in fresh pages of one
// Chromium, and the median printed with the spread. `node bench/page.mjs [--runs N]` after
// `make build`; the machine may be shared, so compare medians taken side by side.
import { serveDist, launch, openPage, waitForStatus } from '../e2e/harness.js';

const at = process.argv.indexOf('--runs');
const RUNS = at > 0 ? Number(process.argv[at + 1]) : 5;
const median = (v) => [...v].sort((a, b) => a - b)[v.length >> 1];
const line = (name, v, unit) => console.log(`${name.padEnd(26)} median ${median(v).toFixed(unit === 'ms' ? 0 : 2).padStart(7)} ${unit}  (${v.map((x) => x.toFixed(unit === 'ms' ? 0 : 2)).join(', ')})`);

const server = await serveDist();
const browser = await launch();
console.log(`gmmcalib page bench (${browser.version()}, headless, ${RUNS} runs each; the machine may be shared)`);
try {
  const paint = [];
  const readyAt = [];
  const toResult = [];
  const reported = [];
  for (let i = 0; i < RUNS; i++) {
    const { page, problems } = await openPage(browser, server.url);
    // The page is ready for a user once the library has listed its methods.
    await page.waitForFunction(() => document.querySelector('#method').options.length > 1);
    const ready = await page.evaluate(() => performance.now());
    // The paint entry may come after the methods are listed: waited for, from the buffer.
    const t = { ready, paint: await page.evaluate(() => new Promise((resolve) => new PerformanceObserver((list, observer) => {
      const entry = list.getEntriesByName('first-contentful-paint')[0];
      if (entry) {
        observer.disconnect();
        resolve(entry.startTime);
      }
    }).observe({ type: 'paint', buffered: true }))) };
    paint.push(t.paint);
    readyAt.push(t.ready);
    const started = Date.now();
    await page.getByTestId('demo').click();
    await waitForStatus(page, /Calibrate next/, 120_000);
    await page.getByTestId('calibrate').click();
    await waitForStatus(page, /^Done/, 300_000);
    toResult.push((Date.now() - started) / 1000);
    reported.push(Number((await page.getByTestId('status').textContent()).match(/in ([\d.]+) s/)[1]));
    if (problems.length) throw new Error(problems.join('\n'));
    await page.close();
  }
  line('first contentful paint', paint, 'ms');
  line('methods listed (ready)', readyAt, 'ms');
  line('demo: click to result', toResult, 's');
  line('demo: calibration (status)', reported, 's');
} finally {
  await browser.close();
  server.close();
}
