// One calibration run from the page: the input from the state, the request to the calibration
// worker (which shares it over its pool), progress as bar and status, the outcome split into
// results and failures. Comparing every method is one request (`method: 'all'`): the library
// runs them in turn and keeps a failed method's error.
import { RunProgress } from './progress.js';
import { nextTask } from './tasks.js';

// The scans are copied (the originals stay loaded, whatever happens to the worker) one per task:
// copying millions of points at once would block the page for 100 ms and more.
async function calibrateInput(state) {
  const s = state.settings;
  const scans = [];
  for (const v of [...state.scans]) {
    scans.push({ sensor: v.sensor, frame: v.frame, points: v.points.slice() });
    await nextTask();
  }
  const input = {
    scans,
    nominal: Object.fromEntries(state.rig.sensors.map((n) => [n, state.rig.nominal[n]])),
    roi: state.rig.roi,
    reference: state.rig.reference,
    parent: state.rig.parent,
    method: s.method,
    target: s.target,
    targetMesh: s.target.startsWith('mesh:') ? meshInput(state.targetMesh) : undefined,
    global: { on: true, off: false }[s.global],
    refine: s.global === 'refine',
    components: s.components,
    iterations: s.iterations,
    initialSigma: s.initialSigma,
    exact: s.exact,
  };
  return { input, transfer: scans.map((v) => v.points.buffer) };
}

// The CAD model loaded ({name, bytes}) as `calibrate`'s targetMesh.
function meshInput(mesh) {
  if (!mesh) throw new Error('the target is a CAD model: load its .obj, .ply or .stl file first');
  return { name: mesh.name, bytes: new Uint8Array(mesh.bytes) };
}

// Workers sharing the registration: one per core (the page's own thread mostly waits), at
// most 4; a single core runs it in the calibration worker alone.
export function workerCount(setting) {
  const n = setting === 'auto' ? Math.min(navigator.hardwareConcurrency || 1, 4) : Number(setting);
  return Number.isInteger(n) && n >= 1 ? n : 1;
}

// Between progress messages the time line and the bar still move (a global stage on a large
// rig sends one message per sensor, 10-20 s apart): every TICK_MS.
const TICK_MS = 500;

// Runs the calibration `state` describes on `client`; `onProgress({fraction, text, elapsed,
// left, progress})` sees every message, with `progress` the message itself, and a tick every
// TICK_MS between them (`progress` null). Resolves to {results, failures, json}: the reports of
// the methods that ran, {method, error} of those that failed, and what the JSON export holds
// (the CLI's --json: one report, or every method's outcome in order when comparing). Throws when
// every method failed, or when the run was cancelled.
export async function runCalibration(client, state, onProgress) {
  const compared = state.settings.method === 'all';
  const names = compared ? state.methods.map((m) => m.name) : [state.settings.method];
  const now = () => performance.now() / 1000;
  const run = new RunProgress(names, now());
  const tick = setInterval(() => onProgress({ ...run.at(now()), progress: null }), TICK_MS);
  try {
    const { input, transfer } = await calibrateInput(state);
    // The exact E-step is the CPU's (f64).
    const eStepDevice = state.settings.exact ? 'cpu' : state.settings.eStepDevice;
    const outcome = await client.request('calibrate', { input, workers: workerCount(state.settings.workers), eStepDevice }, {
      transfer,
      onProgress: (p) => onProgress({ ...run.message(p, now()), progress: p }),
    });
    const outcomes = compared ? outcome : [outcome];
    const results = outcomes.filter((o) => !o.error);
    const failures = outcomes.filter((o) => o.error);
    if (!results.length) throw new Error(failures.map((f) => `${f.method}: ${f.error}`).join('\n'));
    return { results, failures, json: outcome };
  } finally {
    clearInterval(tick);
  }
}
