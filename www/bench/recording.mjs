// The recording bench in the page (issue 21; prints, asserts nothing): a 5 GB MCAP (sparse,
// written by e2e/mcapfile.js into a temporary folder) holding two LiDAR topics of 50 scans of
// 131,072 points each (x y z f32, CDR, one stored chunk per instant) and a camera topic of 2 MiB
// zero images that pad the file. Times, in headless Chromium through the page as a user runs it:
// the file set on the file input to the topic list shown, then Load scans (50 instants of both
// topics: 100 scans) to the status saying they are loaded (decoding in the worker, the points
// copied to the page and its tables and view updated). Run `make build` first; then
// `cd www && node bench/recording.mjs` (BENCH_GB sets the size).
import { mkdtempSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { serveDist, launch, openPage, waitForStatus } from '../e2e/harness.js';
import { McapFile, pointCloud2 } from '../e2e/mcapfile.js';

const SIZE = Number(process.env.BENCH_GB ?? 5) * 1e9;
const POINTS = 131_072;
const INSTANTS = 50;
const IMAGE = 2 * 1024 * 1024;
const T0 = 1_700_000_000_000_000_000n;

// A scan on a slowly turning spiral, as benches/recording.rs writes natively.
function spiral(k) {
  const p = new Float32Array(3 * POINTS);
  for (let i = 0; i < POINTS; i++) {
    const a = i * 0.001 + k * 0.01;
    const r = 2 + (i % 1000) * 0.03;
    p.set([r * Math.cos(a), r * Math.sin(a), (i % 64) * 0.05 - 1], 3 * i);
  }
  return p;
}

function write(path) {
  const file = new McapFile(path);
  const lidars = ['/left/points', '/right/points'].map((t) => file.channel(t, 'sensor_msgs/msg/PointCloud2'));
  const camera = file.channel('/camera/image', 'sensor_msgs/msg/Image');
  const scans = [spiral(0), spiral(1)];
  const images = Math.ceil(SIZE / IMAGE);
  for (let k = 0; k < images; k++) {
    const t = T0 + BigInt(k) * 100_000_000n;
    if (k < INSTANTS) file.chunk(lidars.map((channel, i) => ({ channel, timeNs: t, data: pointCloud2(scans[i], t, `lidar${i}`) })));
    file.chunk([{ channel: camera, timeNs: t + 10_000_000n, zeros: IMAGE }]);
  }
  return file.close();
}

const dir = mkdtempSync(join(tmpdir(), 'gmmcalib-bench-recording-'));
const server = await serveDist();
const browser = await launch();
try {
  const path = join(dir, 'bench.mcap');
  let t = performance.now();
  const size = write(path);
  console.log(`gmmcalib recording bench in the page (${browser.version()}, headless; the machine may be shared)`);
  console.log(`bench.mcap: ${(size / 1e9).toFixed(2)} GB (${(statSync(path).blocks * 512 / 1e6).toFixed(0)} MB on disk), ` +
    `2 topics x ${INSTANTS} scans x ${POINTS} points and ${Math.ceil(SIZE / IMAGE)} camera images, written in ${((performance.now() - t) / 1e3).toFixed(1)} s`);
  for (let run = 1; run <= 2; run++) {
    const { page, problems } = await openPage(browser, server.url);
    await page.waitForFunction(() => document.querySelector('[data-testid=status]').textContent !== '');
    t = performance.now();
    await page.getByTestId('file-input').setInputFiles(path);
    await waitForStatus(page, /bench\.mcap: pick the topics, then Load scans\.$/);
    const list = (performance.now() - t) / 1e3;
    await page.getByLabel('instants').fill(String(INSTANTS));
    t = performance.now();
    await page.getByTestId('recording-load').click();
    await waitForStatus(page, /^100 scans of 2 sensors loaded from bench\.mcap/, 600_000);
    const load = (performance.now() - t) / 1e3;
    if (problems.length) throw new Error(problems.join('\n'));
    console.log(`  run ${run}: topics listed in ${list.toFixed(2)} s; 100 scans loaded in ${load.toFixed(2)} s (${(load * 1e3 / 100).toFixed(1)} ms/scan)`);
    await page.close();
  }
} finally {
  await browser.close();
  server.close();
  rmSync(dir, { recursive: true, force: true });
}
