// The page's own two timings, so a change to the page can show it costs neither (issue 39):
// first paint (the browser's first-contentful-paint of a fresh page, no cache) and the demo's
// time to result (Demo clicked, then Calibrate, until the status line says Done; the paper rig,
// 4 frames, seed 1, as a new user gets it). Each is measured RUNS times in fresh pages of one
// Chromium and the median printed with the spread. `node bench/page.mjs [--runs N] [--against
// DIR]` after `make build`; with --against, another build (a www/dist kept from before a change)
// is measured too, alternating page by page, so a shared machine's load falls on both alike.
import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { extname, join, normalize } from 'node:path';
import { launch, openPage, waitForStatus } from '../e2e/harness.js';

const arg = (name, fallback) => (process.argv.includes(name) ? process.argv[process.argv.indexOf(name) + 1] : fallback);
const RUNS = Number(arg('--runs', 5));
// A user reads the page before clicking: --settle MS waits that long after it is ready.
const SETTLE_MS = Number(arg('--settle', 0));
const builds = [['this build', process.env.GMMCALIB_DIST || new URL('../dist/', import.meta.url).pathname], ...(arg('--against') ? [['--against', arg('--against')]] : [])];
const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css', '.wasm': 'application/wasm' };
const median = (v) => [...v].sort((a, b) => a - b)[v.length >> 1];
const line = (name, v, unit) => console.log(`  ${name.padEnd(26)} median ${median(v).toFixed(unit === 'ms' ? 0 : 2).padStart(7)} ${unit}  (${v.map((x) => x.toFixed(unit === 'ms' ? 0 : 2)).join(', ')})`);

// A static server of `dir` on a free loopback port.
async function serve(dir) {
  const server = createServer(async (req, res) => {
    const path = normalize(decodeURIComponent(new URL(req.url, 'http://x').pathname)).replace(/^(\.\.[/\\])+/, '');
    const file = join(dir, path.endsWith('/') ? `${path}index.html` : path);
    try {
      const body = await readFile(file);
      res.writeHead(200, { 'content-type': TYPES[extname(file)] ?? 'application/octet-stream' });
      res.end(body);
    } catch {
      res.writeHead(404).end('not found');
    }
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  return { url: `http://127.0.0.1:${server.address().port}/`, close: () => server.close() };
}

// One fresh page of `url`: {paint, ready} (ms from navigation), {toResult, reported} (s).
async function measure(browser, url) {
  const { page, problems } = await openPage(browser, url);
  // The page is ready for a user once the library has listed its methods.
  await page.waitForFunction(() => document.querySelector('#method').options.length > 1);
  const ready = await page.evaluate(() => performance.now());
  // The paint entry may come after the methods are listed: waited for, from the buffer.
  const paint = await page.evaluate(() => new Promise((resolve) => new PerformanceObserver((list, observer) => {
    const entry = list.getEntriesByName('first-contentful-paint')[0];
    if (entry) {
      observer.disconnect();
      resolve(entry.startTime);
    }
  }).observe({ type: 'paint', buffered: true })));
  await page.waitForTimeout(SETTLE_MS);
  const started = Date.now();
  await page.getByTestId('demo').click();
  await waitForStatus(page, /Calibrate next/, 120_000);
  const loaded = (Date.now() - started) / 1000;
  await page.getByTestId('calibrate').click();
  await waitForStatus(page, /^Done/, 300_000);
  const toResult = (Date.now() - started) / 1000;
  const reported = Number((await page.getByTestId('status').textContent()).match(/in ([\d.]+) s/)[1]);
  if (problems.length) throw new Error(problems.join('\n'));
  await page.close();
  return { paint, ready, loaded, toResult, reported };
}

const servers = await Promise.all(builds.map(([, dir]) => serve(dir)));
const browser = await launch();
console.log(`gmmcalib page bench (${browser.version()}, headless, ${RUNS} runs each; the machine may be shared)`);
try {
  const samples = builds.map(() => []);
  // Alternating, each build first in every other round: a page's work after its result (what
  // it keeps in the browser, its workers ending) must not fall on one build only.
  for (let i = 0; i < RUNS; i++) {
    const order = [...servers.keys()];
    if (i % 2) order.reverse();
    for (const k of order) samples[k].push(await measure(browser, servers[k].url));
  }
  builds.forEach(([name, dir], k) => {
    console.log(`${name} (${dir})`);
    const of = (key) => samples[k].map((s) => s[key]);
    line('first contentful paint', of('paint'), 'ms');
    line('methods listed (ready)', of('ready'), 'ms');
    line('demo: click to rig loaded', of('loaded'), 's');
    line('demo: click to result', of('toResult'), 's');
    line('demo: calibration (status)', of('reported'), 's');
  });
} finally {
  await browser.close();
  servers.forEach((s) => s.close());
}
