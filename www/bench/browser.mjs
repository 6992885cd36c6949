// The browser bench (issue 8): times a calibration in headless Chromium, through the page as a
// user runs it (a GMMCalib folder through the file input, Calibrate), on 1 and on 2 workers, at
// the sample and the paper scale of bench.mjs: `jrmpc` (EM alone), then `gmm` (the default:
// EM, then the frame pairs' GICP and the plane adjustment). Prints the page's own wall time
// (click to result, views copied to the worker included), the Gaussian terms evaluated and
// dense-equivalent terms per second. Run `make bench-browser` (builds www/dist first).
// Pass --quick for the sample scale only. `--estep gpu` times the E-step on WebGPU instead (one
// CPU worker beside it; Chromium started with WebGPU on, a hardware adapter where the machine has
// one: add `--swiftshader` to force the software adapter, whose speed says nothing about a GPU)
// and prints the GPU's own E-step seconds. Last, a real targetless scene (issue 22: at most
// 2 s in the browser): OpenCalib's road scene 0001 dropped as its folder, target none, on 1
// and 2 workers; `--real` runs that alone.
import { serveDist, launch, openPage, waitForStatus } from '../e2e/harness.js';
import { gmmcalibFolder, opencalibFolder, sampledRig } from '../e2e/rigfiles.js';

const quick = process.argv.includes('--quick');
const realOnly = process.argv.includes('--real');
const arg = (name) => process.argv[process.argv.indexOf(name) + 1];
const gpu = process.argv.includes('--estep') && arg('--estep') === 'gpu';
const swiftshader = process.argv.includes('--swiftshader');
const webgpu = ['--enable-unsafe-webgpu', '--enable-features=Vulkan', '--ignore-gpu-blocklist',
  ...(swiftshader ? ['--use-webgpu-adapter=swiftshader'] : [])];
const jobs = [
  { name: 'sample scale: 10 views x 1300 points, K=444', frames: 5, pointsPerView: 1300, components: 444 },
  { name: 'paper scale: 212 views x 1850 points, K=400', frames: 106, pointsPerView: 1850, components: 400 },
];

const server = await serveDist();
const browser = await launch(gpu ? webgpu : [], { hardwareGpu: gpu && !swiftshader });
console.log(`gmmcalib browser bench (${browser.version()}, headless; the machine may be shared)`);
try {
  for (const [job, method] of (realOnly ? [] : quick ? jobs.slice(0, 1) : jobs).flatMap((j) => [[j, 'jrmpc'], [j, 'gmm']])) {
    const rig = sampledRig({ frames: job.frames, pointsPerView: job.pointsPerView, partial: true, seed: 1 });
    const files = gmmcalibFolder(rig, 'rig', `method: ${method}\ncomponents: ${job.components}\niterations: 100\n`);
    const points = rig.scans.reduce((n, v) => n + v.points.length / 3, 0);
    console.log(`${method} ${job.name} (${points} points)`);
    const seconds = {};
    for (const workers of gpu ? [1] : [1, 2]) {
      const estep = gpu ? '&estep=gpu' : '&estep=cpu';
      const { page, problems } = await openPage(browser, `${server.url}#workers=${workers}${estep}`);
      await page.getByTestId('file-input').setInputFiles(files);
      await waitForStatus(page, /scans of 2 sensors loaded/, 120_000);
      await page.getByTestId('calibrate').click();
      await waitForStatus(page, /^Done/, 900_000);
      const status = await page.getByTestId('status').textContent();
      const result = JSON.parse(await page.getByTestId('result-json').textContent());
      if (problems.length) throw new Error(problems.join('\n'));
      if (result.workers !== workers) throw new Error(`ran on ${result.workers} workers, asked for ${workers}`);
      seconds[workers] = Number(status.match(/in ([\d.]+) s/)[1]);
      const terms = result.history.terms.reduce((a, b) => a + b, 0);
      const dense = points * job.components * result.iterations;
      console.log(`  ${workers} worker${workers > 1 ? 's' : ' '} ${seconds[workers].toFixed(1).padStart(7)} s  ` +
        `${(terms / 1e6).toFixed(1).padStart(7)} M terms evaluated (${(100 * terms / dense).toFixed(1)} % of dense, ` +
        `${result.iterations} iterations)  ${(dense / seconds[workers] / 1e6).toFixed(0).padStart(5)} M dense-equivalent terms/s`);
      if (gpu) {
        if (result.estep !== 'gpu') throw new Error(`the E-step ran on ${result.estep}, asked for the GPU`);
        console.log(`  E-step on ${result.gpu}: ${result.gpuEStepSeconds.toFixed(2)} s over ${result.gpuIterations} iterations ` +
          `(${(1000 * result.gpuEStepSeconds / result.gpuIterations).toFixed(1)} ms each)`);
      }
      await page.close();
    }
    if (!gpu) console.log(`  2 workers over 1: ${(seconds[1] / seconds[2]).toFixed(2)}x`);
  }
  if (!gpu) await realScene();
} finally {
  await browser.close();
  server.close();
}

// OpenCalib 0001 (three LiDARs, 90k + 2 x 9k points) dropped as its folder, from its own far-off
// guess, target none: the global stage, the overlap region, levelling, the frame pairs' GICP,
// the plane adjustment and the verdict, click to result.
async function realScene() {
  const files = opencalibFolder('0001');
  console.log('gmm OpenCalib 0001, target none (real scans: 3 sensors, global alignment from its guess)');
  for (const workers of [1, 2]) {
    const { page, problems } = await openPage(browser, `${server.url}#workers=${workers}&estep=cpu`);
    await page.locator('#view').drop({ files });
    await waitForStatus(page, /^3 scans of 3 sensors loaded\.$/, 120_000);
    await page.locator('#target-kind').selectOption('none');
    // The status line gives tenths; the page's own clock, from the click to the status saying
    // Done, gives the figure to the millisecond.
    await page.evaluate(() => {
      const status = document.querySelector('[data-testid=status]');
      window.benchDone = null;
      const done = () => { if (window.benchDone === null && /^Done/.test(status.textContent)) window.benchDone = performance.now(); };
      new MutationObserver(done).observe(status, { childList: true, characterData: true, subtree: true });
      window.benchStart = performance.now();
    });
    await page.getByTestId('calibrate').click();
    await waitForStatus(page, /^Done/, 300_000);
    const seconds = await page.evaluate(() => (window.benchDone - window.benchStart) / 1000);
    const level = await page.getByTestId('verdict').getAttribute('data-level');
    if (problems.length) throw new Error(problems.join('\n'));
    console.log(`  ${workers} worker${workers > 1 ? 's' : ' '} ${seconds.toFixed(3).padStart(7)} s  verdict ${level}`);
    await page.close();
  }
}
