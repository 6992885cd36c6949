// The wasm twin of `cargo run --release --bin bench`: the same jobs under Node, one thread.
// Run `make wasm` first (or `make bench`). Pass --quick for the small jobs, --targets for the
// global stage and the targets (cube, CAD model, none) alone.
//
// JRMPC is timed twice: through the JS API (`calibrate`, what the page calls), and through
// `benches/bench.rs` built for wasm32 (`bench_jrmpc`, built here with cargo), which also
// reports the Gaussian terms evaluated and runs the exact dense E-step the JS API does not
// expose. That module's wasm-bindgen imports are never called; they are stubbed.
import { execFileSync } from 'node:child_process';
import { readFile } from 'node:fs/promises';
import { performance } from 'node:perf_hooks';
import init, { calibrate, parseCloud, parseOpenCalib, simulateRig } from '../pkg/gmmcalib.js';

const sampledRig = (options) => simulateRig({ preset: 'sampled', ...options });

const pkg = await init({ module_or_path: await readFile(new URL('../pkg/gmmcalib_bg.wasm', import.meta.url)) });
const quick = process.argv.includes('--quick');
const targetsOnly = process.argv.includes('--targets');
console.log(`gmmcalib wasm bench (Node ${process.version}, one thread)`);

const root = new URL('../../', import.meta.url);
execFileSync('cargo', ['build', '--quiet', '--release', '--target', 'wasm32-unknown-unknown', '--bin', 'bench'],
  { cwd: root, stdio: 'inherit' });
const stub = new Proxy({}, { get: () => () => { throw new Error('bench module called a JS import'); } });
const { instance } = await WebAssembly.instantiate(
  await readFile(new URL('target/wasm32-unknown-unknown/release/bench.wasm', root)),
  new Proxy({}, { get: () => stub }));
const benchJrmpc = instance.exports.bench_jrmpc;
const benchGlobal = instance.exports.bench_global;

const rigInput = (rig, extra) => ({ scans: rig.scans, nominal: rig.nominal, roi: rig.roi, ...extra });
const pad = (s, n) => String(s).padStart(n);
const mib = (bytes) => `${(bytes / 2 ** 20).toFixed(0)} MiB`;

// JRMPC, 100 iterations, as the reference runs it. Same order as JOBS in benches/jrmpc.rs.
const jobs = [
  { name: 'sample scale: 10 views x 1300 points, K=444', frames: 5, pointsPerView: 1300, components: 444, denseIterations: 10 },
  { name: 'paper scale: 212 views x 1850 points, K=400', frames: 106, pointsPerView: 1850, components: 400, denseIterations: 2 },
];
for (const [index, job] of (targetsOnly ? [] : quick ? jobs.slice(0, 1) : jobs).entries()) {
  const rig = sampledRig({ frames: job.frames, pointsPerView: job.pointsPerView, partial: true, seed: 1 });
  const points = rig.scans.reduce((n, v) => n + v.points.length / 3, 0);
  let started = performance.now();
  const result = calibrate(rigInput(rig, { method: 'jrmpc', components: job.components, tolerance: 0 }));
  const seconds = (performance.now() - started) / 1000;
  started = performance.now();
  const terms = benchJrmpc(index, 0, 100);
  const moduleSeconds = (performance.now() - started) / 1000;
  started = performance.now();
  benchJrmpc(index, 1, job.denseIterations);
  const denseSeconds = (performance.now() - started) / 1000 * 100 / job.denseIterations;
  const dense = points * job.components * result.iterations;
  console.log(`jrmpc ${job.name} (${points} points, ${result.iterations} iterations)`);
  console.log(`  fast   ${pad(seconds.toFixed(2), 8)} s  ${pad((terms / 1e6).toFixed(1), 7)} M terms evaluated ` +
    `(${(100 * terms / dense).toFixed(1)} % of dense)  ${pad((dense / seconds / 1e6).toFixed(1), 7)} M dense-equivalent terms/s` +
    `  (JS API; ${moduleSeconds.toFixed(2)} s in the bench module)`);
  console.log(`  dense  ${pad(denseSeconds.toFixed(2), 8)} s  (exact E-step, ${job.denseIterations} iterations timed, ` +
    `scaled to 100)  speed-up ${(denseSeconds / moduleSeconds).toFixed(1)}x`);
  console.log(`  peak wasm memory: ${mib(pkg.memory.buffer.byteLength)} (JS API), ` +
    `${mib(instance.exports.memory.buffer.byteLength)} (bench module)`);
}

// `gmm`, the default, end to end through the JS API as the page runs it: JRMPC (100 iterations
// here: this rig never meets the convergence test), then the frame pairs' GICP, the plane
// adjustment and the target fit (their share is the time after EM's last progress).
for (const job of targetsOnly ? [] : quick ? jobs.slice(0, 1) : jobs) {
  const rig = sampledRig({ frames: job.frames, pointsPerView: job.pointsPerView, partial: true, seed: 1 });
  // Every point every iteration (the default) and multi-resolution EM, side by side.
  for (const multiresolution of [false, true]) {
    let emEnded = 0;
    const started = performance.now();
    const result = calibrate(rigInput(rig, { method: 'gmm', components: job.components, multiresolution }), (p) => {
      if (p.meanSigma > 0) emEnded = performance.now();
      return true;
    });
    const ended = performance.now();
    const terms = result.history.terms.reduce((a, b) => a + b, 0);
    console.log(`gmm ${job.name}${multiresolution ? ', multi-resolution' : ''}: ${((ended - started) / 1000).toFixed(2)} s; ` +
      `JRMPC ${((emEnded - started) / 1000).toFixed(2)} s (${result.iterations} iterations, ${(terms / 1e6).toFixed(0)} M terms), ` +
      `then ${((ended - emEnded) / 1000).toFixed(2)} s (frame pairs, plane adjustment, target fit)`);
  }
}

// ICP baselines: per frame pair, on partial views of the synthetic rig.
for (const pointsPerView of targetsOnly ? [] : quick ? [2000] : [2000, 65000]) {
  const frames = pointsPerView > 10000 ? 1 : 5;
  const rig = sampledRig({ frames, pointsPerView, partial: true, seed: 2 });
  for (const method of ['p2p', 'p2l', 'gicp']) {
    const started = performance.now();
    calibrate(rigInput(rig, { method }));
    const ms = (performance.now() - started) / frames;
    console.log(`${method.padEnd(5)} per pair, ${pad(pointsPerView, 5)}-point views ${pad(ms.toFixed(1), 9)} ms`);
  }
}

// The global stage on OpenCalib's road scene (issue 19: at most 1 s per sensor): in the bench
// module (a second call: the first also parses), then `gmm` end to end with and without it
// through the JS API, as the page runs a dropped OpenCalib folder.
{
  benchGlobal();
  let started = performance.now();
  const aligned = benchGlobal();
  const seconds = (performance.now() - started) / 1000;
  console.log(`global stage, OpenCalib 0001 (${aligned} sensors aligned onto top): ${seconds.toFixed(2)} s, ${(seconds / aligned).toFixed(2)} s per sensor (bench module)`);
  const dir = new URL('../../tests/fixtures/opencalib/0001/', import.meta.url);
  const text = async (name) => (await readFile(new URL(name, dir))).toString();
  const rig = parseOpenCalib(await text('lidar_cloud_path.txt'), 'lidar_cloud_path.txt', await text('initial_extrinsic.txt'), 'initial_extrinsic.txt');
  const scans = [];
  for (const d of rig.devices) scans.push({ sensor: d.name, frame: '1', points: parseCloud(await readFile(new URL(d.file, dir)), d.file).points });
  for (const alignGlobally of [true, false]) {
    started = performance.now();
    const result = calibrate({ scans, nominal: rig.nominal, reference: rig.reference, target: { kind: 'none' }, alignGlobally });
    console.log(`gmm OpenCalib 0001, target none, global ${alignGlobally ? 'on ' : 'off'}: ${((performance.now() - started) / 1000).toFixed(2)} s, verdict ${result.verdict.level}`);
  }
}

// Targets of any shape (issue 20): `gmm` and `cad` at the sample scale (the sampled cube twin
// of the first job) and on the chair twin with its CAD model, through the JS API.
{
  const sample = sampledRig({ frames: 5, pointsPerView: 1300, partial: true, seed: 1 });
  const chairs = simulateRig({ preset: 'paper-chair', frames: 3, seed: 1 });
  // `cad` needs a target: `none` is `gmm`'s alone.
  const cases = [
    ['sample scale (cube)', sample, {}, ['gmm', 'cad']],
    ['sample scale (target none)', sample, { target: { kind: 'none' } }, ['gmm']],
    ['chair twin, 3 frames (CAD model)', chairs, { target: { kind: 'mesh' }, targetMesh: { name: 'target.obj', bytes: new TextEncoder().encode(chairs.targetObj) } }, ['gmm', 'cad']],
  ];
  for (const [name, rig, extra, methods] of cases) {
    for (const method of methods) {
      const started = performance.now();
      const result = calibrate(rigInput(rig, { method, ...extra }));
      console.log(`${method} ${name}: ${((performance.now() - started) / 1000).toFixed(2)} s, ${result.iterations} iterations, verdict ${result.verdict.level}`);
    }
  }
}

if (!targetsOnly) {
  // Parsing: a 1M-point binary PCD (x y z intensity, float32).
  const n = 1_000_000;
  const header = `# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH ${n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ${n}\nDATA binary\n`;
  const head = new TextEncoder().encode(header);
  const data = new Float32Array(n * 4);
  for (let i = 0; i < n * 4; i++) data[i] = 1 + (i % 9973) * 0.001;
  const bytes = new Uint8Array(head.length + n * 16);
  bytes.set(head);
  bytes.set(new Uint8Array(data.buffer), head.length);
  let best = Infinity;
  for (let run = 0; run < 5; run++) {
    const started = performance.now();
    const parsed = parseCloud(bytes, 'bench.pcd');
    best = Math.min(best, performance.now() - started);
    if (parsed.count !== n) throw new Error(`parsed ${parsed.count} points`);
  }
  console.log(`parseCloud 1M-point binary PCD (${(bytes.length / 1e6).toFixed(0)} MB)  ${best.toFixed(1)} ms best of 5`);
}
