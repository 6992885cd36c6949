// JRMPC's E-step over a pool of workers (issue 8): the calibration worker drives a wasm
// CalibrationSession, keeps the first slice of the views itself and hands the others to shard
// workers (shard-worker.js). Each iteration every shard returns its views' statistics (O(views
// x K) numbers, transferred, not copied) and the session's M-step takes them in view order, so
// the result is `calibrate`'s, bit for bit, for any number of workers.

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

// A shard worker as promises: init(points, sizes), then eStep(input, first) -> Float64Array.
class RemoteShard {
  #worker;
  #pending = null; // {resolve, reject} of the one request in flight

  constructor() {
    this.#worker = new Worker(new URL('./shard-worker.js', import.meta.url), { type: 'module' });
    this.#worker.onmessage = ({ data }) => {
      const request = this.#pending;
      this.#pending = null;
      if (data.type === 'error') request?.reject(new Error(`a calculation worker failed: ${data.message}`));
      else request?.resolve(data.output);
    };
    this.#worker.onerror = (event) => {
      event.preventDefault();
      const request = this.#pending;
      this.#pending = null;
      request?.reject(new Error(`a calculation worker crashed: ${event.message || 'unknown error'}`));
    };
  }

  #request(message, transfer) {
    return new Promise((resolve, reject) => {
      this.#pending = { resolve, reject };
      this.#worker.postMessage(message, transfer);
    });
  }

  init(points, sizes) {
    return this.#request({ type: 'init', points, sizes }, [points.buffer, sizes.buffer]);
  }

  eStep(input, first) {
    return this.#request({ type: 'eStep', input, first }, []);
  }

  terminate() {
    this.#worker.terminate();
  }
}

// `calibrate(input, onProgress)` with the E-step shared by `workers` workers (this one
// included). `wasm` is the initialised module (CalibrationSession, JrmpcShard).
export async function calibrateSharded(wasm, input, workers, onProgress) {
  const session = new wasm.CalibrationSession(input);
  const remotes = [];
  let local = null;
  try {
    const sizes = session.viewSizes();
    const slices = splitViews(Array.from(sizes), workers);
    const shardOf = ({ first, count }) => [session.shardPoints(first, count), sizes.slice(first, first + count)];
    if (slices.length > 0) local = new wasm.JrmpcShard(...shardOf(slices[0]));
    await Promise.all(slices.slice(1).map((slice) => {
      const remote = new RemoteShard();
      remotes.push(remote);
      return remote.init(...shardOf(slice));
    }));
    while (!session.finished()) {
      const estep = session.eStepInput();
      const pending = remotes.map((remote, i) => remote.eStep(estep, slices[i + 1].first));
      const outputs = [local.eStep(estep, slices[0].first), ...(await Promise.all(pending))];
      if (onProgress(session.mStep(outputs)) === false) session.cancel();
    }
    const result = session.finish(onProgress);
    result.workers = Math.max(1, slices.length); // the ICP methods: no views to split
    return result;
  } finally {
    for (const remote of remotes) remote.terminate();
    local?.free();
    session.free();
  }
}
