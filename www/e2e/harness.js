// Shared by the browser tests: serve www/dist on a free loopback port and drive Debian's
// Chromium with playwright-core. Records console errors, failed requests and requests to other
// origins per page.
import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { extname, join, normalize } from 'node:path';
import { before, after } from 'node:test';
import { chromium } from 'playwright-core';

// GMMCALIB_DIST: another build to serve (bench/page.mjs compares two side by side).
const DIST = process.env.GMMCALIB_DIST || new URL('../dist/', import.meta.url).pathname;
// Where screenshots go: e2e/artifacts/, or SHOTS.
export const SHOTS = process.env.SHOTS ?? new URL('./artifacts/', import.meta.url).pathname;
const TYPES = {
  '.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css',
  '.wasm': 'application/wasm', '.json': 'application/json', '.svg': 'image/svg+xml',
};

export async function serveDist() {
  const server = createServer(async (req, res) => {
    const path = normalize(decodeURIComponent(new URL(req.url, 'http://x').pathname)).replace(/^(\.\.[/\\])+/, '');
    const file = join(DIST, path.endsWith('/') ? `${path}index.html` : path);
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

// playwright-core gives every launch a fresh, empty profile directory of its own. `extra`:
// more switches (gpu.test.js: WebGPU on SwiftShader).
// `hardwareGpu`: leave the machine's GPU on (the GPU bench); tests run without it.
export async function launch(extra = [], { hardwareGpu = false } = {}) {
  return chromium.launch({
    executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
    args: [
      '--no-sandbox', ...(hardwareGpu ? [] : ['--disable-gpu']), '--enable-unsafe-swiftshader', '--disable-quic',
      '--no-first-run', '--disable-background-networking', '--disable-component-update',
      '--disable-sync', ...extra,
    ],
  });
}

// One server and one Chromium for a test file, started before its tests and stopped after.
// `open(hash)` opens the site (with an optional `#...` hash) in a fresh page; `extra`: more
// Chromium switches.
export function browserSession(extra = []) {
  let server;
  let browser;
  before(async () => {
    server = await serveDist();
    browser = await launch(extra);
  });
  after(async () => {
    await browser?.close();
    server?.close();
  });
  return { open: (hash = '') => openPage(browser, `${server.url}${hash}`) };
}

// A page that collects console errors, uncaught exceptions and failed requests.
export async function openPage(browser, url) {
  const page = await browser.newPage();
  const problems = [];
  page.on('console', (m) => m.type() === 'error' && problems.push(`console: ${m.text()}`));
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('requestfailed', (r) => problems.push(`request failed: ${r.url()}`));
  page.on('response', (r) => r.status() >= 400 && problems.push(`HTTP ${r.status()}: ${r.url()}`));
  // Privacy: nothing but the page's own origin (and local data: / blob: URLs) is ever asked for.
  const origin = new URL(url).origin;
  page.on('request', (r) => !/^(data|blob):/.test(r.url()) && new URL(r.url()).origin !== origin && problems.push(`request to another origin: ${r.url()}`));
  await page.goto(url);
  return { page, problems };
}

// Waits until the status line matches `pattern`; fails early, naming the error, when the page
// shows one.
export async function waitForStatus(page, pattern, timeout = 60_000) {
  await page.waitForFunction(
    ([source, flags]) => {
      const error = document.querySelector('[data-testid=error]');
      if (error && !error.hidden && error.textContent) return true;
      return new RegExp(source, flags).test(document.querySelector('[data-testid=status]').textContent);
    },
    [pattern.source, pattern.flags],
    { timeout },
  );
  const status = await page.getByTestId('status').textContent();
  if (!pattern.test(status)) {
    throw new Error(`status '${status}', error '${await page.getByTestId('error').textContent()}'`);
  }
}

// Points of the loaded scans, from the file table; `frame`: that frame's only.
export async function loadedPoints(page, frame = null) {
  const rows = await page.locator('#files tr:not(.bad)').evaluateAll((trs) => trs.slice(1).map((tr) => {
    const cells = tr.querySelectorAll('td');
    return [cells[2].firstChild.value, Number(cells[4].textContent.replaceAll(',', ''))];
  }));
  return rows.filter(([f]) => frame === null || f === frame).reduce((sum, [, n]) => sum + n, 0);
}

// Waits until the main view has drawn a frame of exactly `points` points (the viewer's
// `data-points`), so a screenshot shows what it should.
export async function waitForView(page, points, timeout = 60_000) {
  await page.waitForFunction((n) => document.querySelector('#view').dataset.points === String(n), points, { timeout });
}
