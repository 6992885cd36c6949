// A calibration over a pool of workers: the calibration worker drives a wasm
// CalibrationSession (the library's state machine over methods and their stages) and shares
// each stage's work with pool workers (shard-worker.js). The global stage: a sensor at a
// time, each aligned onto the reference on its own. JRMPC's E-step: it keeps the first
// slice of the views and each pool worker holds another; every iteration each returns its
// views' statistics (O(views x K) numbers, transferred, not copied) and the session's M-step
// takes them in view order. The frame pairs' ICP: a reference view's pairs at a time. Which
// stage comes next, and the loop over methods when comparing, are the session's. The result is
// `calibrate`'s, bit for bit, for any number of workers. JRMPC's E-step may run on the GPU
// instead (gpu-estep.js): within the fidelity rule of the CPU's result, not bit for bit.
import { nextTask } from './tasks.js';

// Contiguous slices of views with about equal points: [{first, count}], at most `parts`, none
// empty. The E-step costs about the same per point, so equal points balance the workers.
export function splitViews(sizes, parts) {
  const total = sizes.reduce((a, b) => a + b, 0);
  const slices = [];
  let first = 0;
  let done = 0;
  for (let part = 1; part <= parts && first < sizes.length; part++) {
    const goal = (total * part) / parts;
    let end = first + 1; // at least one view each
    let sum = done + sizes[first];
    // Take views while that brings the sum closer to this part's share of the total, leaving
    // at least one view for each part still to come.
    while (end < sizes.length - (parts - part) && Math.abs(sum + sizes[end] - goal) <= Math.abs(sum - goal)) {
      sum += sizes[end];
      end += 1;
    }
    if (part === parts) end = sizes.length;
    slices.push({ first, count: end - first });
    for (let v = first; v < end; v++) done += sizes[v];
    first = end;
  }
  return slices;
}

// A pool worker (shard-worker.js) as promises, given the wasm module first: ready();
// init(points, sizes), then eStep(input, first) -> Float64Array; align(icp, target, sources,
// starts) -> an outcome per source; alignGlobal(job) -> a sensor's global alignment.
export class RemoteWorker {
  #worker;
  #pending = []; // {resolve, reject} of the requests in flight: the worker answers in order

  // `module`: this worker's compiled WebAssembly.Module, shared with the new one (else it
  // fetches and compiles its own).
  constructor(module = undefined) {
    this.#worker = new Worker(new URL('./shard-worker.js', import.meta.url), { type: 'module' });
    this.#worker.postMessage({ type: 'module', module });
    this.#worker.onmessage = ({ data }) => {
      const request = this.#pending.shift();
      if (data.type === 'error') request?.reject(new Error(`a calculation worker failed: ${data.message}`));
      else request?.resolve(data.output);
    };
    this.#worker.onerror = (event) => {
      event.preventDefault();
      const message = `a calculation worker crashed: ${event.message || 'unknown error'}`;
      for (const request of this.#pending.splice(0)) request.reject(new Error(message));
    };
  }

  #request(message, transfer) {
    return new Promise((resolve, reject) => {
      this.#pending.push({ resolve, reject });
      this.#worker.postMessage(message, transfer);
    });
  }

  init(points, sizes) {
    return this.#request({ type: 'init', points, sizes }, [points.buffer, sizes.buffer]);
  }

  eStep(input, first) {
    return this.#request({ type: 'eStep', input, first }, []);
  }

  align(icp, target, sources, starts) {
    return this.#request({ type: 'align', icp, target, sources, starts }, [target.buffer, ...sources.map((s) => s.buffer)]);
  }

  // Resolves once the worker runs, its wasm loaded.
  ready() {
    return this.#request({ type: 'ready' }, []);
  }

  alignGlobal(job) {
    return this.#request({ type: 'alignGlobal', job }, [job.scan.buffer, job.reference.buffer]);
  }

  terminate() {
    this.#worker.terminate();
  }
}

// Runs `loops` (async functions) to their ends; the first failure stops the others (`stop()`
// makes their queues look empty) and is thrown once all have ended, so none touches the
// session after it is freed.
async function untilAllEnd(loops, stop) {
  const settled = await Promise.allSettled(loops.map((loop) => loop.catch((error) => {
    stop();
    throw error;
  })));
  const failure = settled.find(({ status }) => status === 'rejected');
  if (failure) throw failure.reason;
}

// The global stage shared: each sensor is aligned onto the reference on its own, so a remote
// worker takes a sensor (its job carries all it needs) while this worker aligns another. The
// session keeps the alignments by sensor, so who aligned what does not change the result.
// `onProgress` sees the stage begin and each sensor aligned; `false` from it stops handing out
// sensors (the session aligns the rest as the stage ends, then stops).
async function shareGlobal(session, pool, onProgress) {
  const queue = Array.from(session.globalJobs());
  let stopped = false;
  const heed = (progress) => {
    if (!onProgress(progress) && !stopped) {
      stopped = true;
      session.cancel();
    }
  };
  heed(session.globalProgress());
  // One sensor (a rig of two) is this worker's alone: no remote is started for it.
  const remotes = queue.length > 1 && !stopped ? await pool() : [];
  const next = () => (stopped ? undefined : queue.shift());
  const remote = async (worker) => {
    for (let sensor = next(); sensor !== undefined; sensor = next()) {
      heed(session.recordGlobal(sensor, await worker.alignGlobal(session.globalJob(sensor))));
    }
  };
  const local = async () => {
    for (let sensor = next(); sensor !== undefined; sensor = next()) {
      heed(session.alignGlobally(Uint32Array.of(sensor)));
      await nextTask();
    }
  };
  // The remotes take their first sensors before this worker starts on one, which holds the
  // thread until it is done.
  await untilAllEnd([...remotes.map(remote), local()], () => { stopped = true; });
}

// JRMPC's EM with the E-step shared: this worker keeps the first slice of the views, each remote
// one more (remotes beyond the slices idle). With `gpu` (a GpuEStep) one GPU shard holds every
// view instead. Returns the GPU shard's {seconds, iterations} of E-step, or null.
async function shareEm(wasm, session, remotes, onProgress, gpu = null) {
  const sizes = session.viewSizes();
  const slices = gpu ? [{ first: 0, count: sizes.length }] : splitViews(Array.from(sizes), remotes.length + 1);
  const shardOf = ({ first, count }) => [session.shardPoints(first, count), sizes.slice(first, first + count)];
  const local = gpu ? gpu.shard(...shardOf(slices[0])) : new wasm.JrmpcShard(...shardOf(slices[0]));
  try {
    await Promise.all(slices.slice(1).map((slice, i) => remotes[i].init(...shardOf(slice))));
    while (!session.finished()) {
      const estep = session.eStepInput();
      const pending = slices.slice(1).map((slice, i) => remotes[i].eStep(estep, slice.first));
      const outputs = [await local.eStep(estep, slices[0].first), ...(await Promise.all(pending))];
      if (onProgress(session.mStep(outputs)) === false) session.cancel();
    }
    return gpu ? { seconds: local.seconds, iterations: local.iterations } : null;
  } finally {
    local.free();
  }
}

// The frame pairs (`pairs`: referenceView, view per pair) as groups of pair indices that share
// a reference view, [[referenceView, [pair, ...]], ...]: each group builds that view's ICP
// target once. With fewer groups than `parts` (the workers), the largest are halved until
// there are `parts` or none has two pairs: a worker that would idle builds the target again
// and registers half of them (a targetless scene of one frame has one reference view).
export function pairGroups(pairs, parts) {
  const byReference = new Map();
  for (let job = 0; job < pairs.length / 2; job++) {
    const reference = pairs[2 * job];
    if (!byReference.has(reference)) byReference.set(reference, []);
    byReference.get(reference).push(job);
  }
  const groups = [...byReference];
  while (groups.length > 0 && groups.length < parts) {
    const largest = groups.reduce((best, g, i) => (g[1].length > groups[best][1].length ? i : best), 0);
    const [reference, jobs] = groups[largest];
    if (jobs.length < 2) break;
    const half = Math.ceil(jobs.length / 2);
    groups.splice(largest, 1, [reference, jobs.slice(0, half)], [reference, jobs.slice(half)]);
  }
  return groups;
}

// The frame pairs' ICP (`gmm`'s refinement, the ICP methods) shared: in groups of one
// reference view (`pairGroups`), handed out a group at a time to whichever worker is free,
// this one included. The session keeps the outcomes in pair order, so who registered what
// does not change the result.
async function shareFramePairs(session, pool, onProgress, workers) {
  const work = session.framePairs();
  const queue = pairGroups(work.pairs, workers);
  // The stage begun, none done: the first pair's time is the estimate of the rest (a pair
  // takes seconds on a large scene).
  onProgress(session.progress());
  // One group (one pair) is this worker's alone: no remote is started for it.
  const remotes = queue.length > 1 ? await pool() : [];
  let stopped = false;
  const heed = (progress) => {
    if (onProgress(progress) === false) stopped = true;
    return !stopped;
  };
  const next = () => (stopped ? undefined : queue.shift());
  const local = async () => {
    for (let group = next(); group; group = next()) {
      session.registerPairs(Uint32Array.from(group[1]), heed);
      await nextTask();
    }
  };
  const remote = async (worker) => {
    for (let group = next(); group; group = next()) {
      const [reference, jobs] = group;
      const sources = jobs.map((job) => session.viewPoints(work.pairs[2 * job + 1]));
      const starts = new Float64Array(jobs.length * 7);
      jobs.forEach((job, i) => starts.set(work.starts.subarray(7 * job, 7 * job + 7), 7 * i));
      const outcomes = await worker.align(work.icp, session.viewPoints(reference), sources, starts);
      jobs.forEach((job, i) => heed(session.recordPair(job, outcomes[i])));
    }
  };
  // Each remote takes a group before this worker starts on one, which holds the thread until
  // it is done; then a second request in flight per remote, so it starts its next group while
  // its last reply waits for this worker (one in flight left it idle about half the time).
  const loops = [...remotes.map(remote), local(), ...remotes.map(remote)];
  await untilAllEnd(loops, () => { stopped = true; });
  if (stopped) session.cancel(); // stopped by the user: no later method starts
}

// `calibrate(input, onProgress)` with the work shared by `workers` workers (this one included,
// the others started when a stage first has work for them: each loads its own wasm, which on a
// targetless scene of one frame would only take cores from the work):
// each method's stages as the session asks for them; with `method: 'all'`, a method whose
// workers fail is noted as failed and the next one runs. `wasm` is the initialised module;
// `spawn()` makes a remote worker (tests pass an in-process one). `eStepDevice` ('cpu' | 'auto' |
// 'gpu', gpu-estep.js) says where JRMPC's E-step runs; each EM result tells where it ran.
export async function calibrateSharded(wasm, input, workers, onProgress, spawn = () => new RemoteWorker(), eStepDevice = 'cpu') {
  const session = new wasm.CalibrationSession(input);
  const remotes = [];
  let cancelled = false;
  const heed = (progress) => {
    if (onProgress(progress) === false) cancelled = true;
    return !cancelled;
  };
  let gpu = null;
  const emRan = new Map(); // method -> its E-step's path
  try {
    // The exact E-step is f64 on the CPU: the GPU's f32 one is not it.
    if (eStepDevice !== 'cpu' && !input.exact) {
      // Loaded only when asked for: its shader comes through Vite (`?raw`), which Node's tests
      // of this module do without.
      const { GpuEStep, gpuAdapter } = await import('./gpu-estep.js');
      const adapter = await gpuAdapter(eStepDevice);
      if (adapter) gpu = await GpuEStep.create(adapter);
    }
    // A new worker starts only while this one yields to its event loop (Chromium), so each is
    // waited for before this worker goes back to work: otherwise a remote's share began only
    // after this worker's own (the global stage's two sensors took as long as one after the
    // other).
    const pool = async () => {
      const started = [];
      while (remotes.length < workers - 1) {
        remotes.push(spawn());
        started.push(remotes.at(-1).ready());
      }
      await Promise.all(started);
      return remotes;
    };
    for (let stage = session.stage(); stage !== 'done'; stage = session.stage()) {
      try {
        if (stage === 'global') await shareGlobal(session, pool, heed);
        else if (stage === 'jrmpc') {
          const method = session.method();
          const timing = await shareEm(wasm, session, gpu ? [] : await pool(), heed, gpu);
          emRan.set(method, timing ? { eStepDevice: 'gpu', gpu: gpu.name, gpuEStepSeconds: timing.seconds, gpuIterations: timing.iterations } : { eStepDevice: 'cpu' });
        } else if (stage === 'cad') session.registerCad(heed); // one call: fast, not shared
        else if (stage === 'framePairs') await shareFramePairs(session, pool, heed, workers);
        // The run's own steps ('views', 'finish'), taken at advance: said as they begin.
        else if (!heed(session.progress())) session.cancel();
        session.advance();
      } catch (error) {
        if (input.method !== 'all') throw error;
        session.fail(error.message ?? String(error));
      }
    }
    const result = session.result();
    // The workers that took part: a remote never started did none of the work.
    const took = remotes.length + 1;
    for (const r of Array.isArray(result) ? result : [result]) if (!r.error) Object.assign(r, { workers: took }, emRan.get(r.method));
    return result;
  } finally {
    for (const remote of remotes) remote.terminate();
    session.free();
    gpu?.destroy();
  }
}
