// The wasm twin of `cargo run --release --bin bench`: the same JRMPC jobs through the JS API,
// under Node, one thread. Run `make wasm` first (or `make bench`). Pass --quick for the small job.
import { readFile } from 'node:fs/promises';
import { performance } from 'node:perf_hooks';
import init, { calibrate, syntheticRig } from '../pkg/gmmcalib.js';

await init({ module_or_path: await readFile(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });

const jobs = [
  { name: 'sample scale: 10 views x 1300 points, K=444', frames: 5, pointsPerView: 1300, components: 444 },
  { name: 'paper scale: 212 views x 1850 points, K=400', frames: 106, pointsPerView: 1850, components: 400 },
];

console.log(`gmmcalib wasm bench (Node ${process.version})`);
for (const job of process.argv.includes('--quick') ? jobs.slice(0, 1) : jobs) {
  const rig = syntheticRig({ frames: job.frames, pointsPerView: job.pointsPerView, partial: true, seed: 1 });
  const points = rig.views.reduce((n, v) => n + v.points.length / 3, 0);
  const started = performance.now();
  const result = calibrate({
    views: rig.views, nominal: rig.nominal, roi: rig.roi,
    method: 'jrmpc', components: job.components, tolerance: 0,
  });
  const seconds = (performance.now() - started) / 1000;
  const terms = points * job.components * result.iterations;
  console.log(
    `jrmpc ${job.name.padEnd(46)} ${seconds.toFixed(2).padStart(8)} s  ${String(result.iterations).padStart(3)} iterations  ` +
      `${(terms / seconds / 1e6).toFixed(1).padStart(7)} M terms/s  (${points} points)`,
  );
}
