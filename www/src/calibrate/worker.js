// All heavy work happens here, off the main thread: the wasm module is loaded once and each
// request {type, id, ...} is answered with {type: 'result' | 'error', id, ...}. Typed arrays in
// results are transferred, not copied.
import init, * as wasm from '../../pkg/gmmcalib.js';
import wasmUrl from '../../pkg/gmmcalib_bg.wasm?url';
import { RemoteWorker, calibrateSharded } from './shard-pool.js';

const { calibrate, compareCalibrations, methods, parseCloud, parseConfig, parseMesh, parseOpenCalib, placeScans, exportsOf, simulateRig, RecordingFile } = wasm;

// Open recordings by id. A recording is read where it lies: FileReaderSync on slices of the
// File, so a multi-gigabyte file is never in memory; only its index and the chosen chunks are.
const recordings = new Map();
let nextRecording = 1;

// Compiled here once and handed to the pool workers (shard-pool.js): a posted module shares
// its compiled code, so a pool worker does not compile it again (one answers 10-20 ms after
// it is started).
const compiled = WebAssembly.compileStreaming(fetch(wasmUrl));
const ready = compiled.then((module) => init({ module_or_path: module }));

function buffersOf(value, found = []) {
  if (ArrayBuffer.isView(value)) found.push(value.buffer);
  else if (value && typeof value === 'object') for (const v of Object.values(value)) buffersOf(v, found);
  return found;
}

const handlers = {
  parse: ({ bytes, name }) => parseCloud(new Uint8Array(bytes), name),
  config: ({ text, name }) => parseConfig(text, name),
  mesh: ({ bytes, name }) => parseMesh(new Uint8Array(bytes), name),
  exports: (input) => exportsOf(input),
  compare: ({ stored, storedName, current, currentName, tolerance }) => compareCalibrations(stored, storedName, current, currentName, tolerance),
  opencalib: ({ paths, pathsName, guess, guessName }) => parseOpenCalib(paths, pathsName, guess ?? null, guessName ?? null),
  layout: ({ paths }) => placeScans(paths),
  methods: () => methods(),
  openRecording: ({ file }, id) => {
    const reader = new FileReaderSync();
    const readAt = (offset, length) => new Uint8Array(reader.readAsArrayBuffer(file.slice(offset, offset + length)));
    const onProgress = (done, total) => self.postMessage({ type: 'progress', id, progress: { done, total } });
    const recording = new RecordingFile(file.size, readAt, file.name, onProgress);
    const handle = nextRecording++;
    recordings.set(handle, recording);
    return { handle, topics: recording.topics(), problems: recording.problems() };
  },
  recordingRig: ({ handle, options }) => {
    const recording = recordings.get(handle);
    if (!recording) throw new Error('the recording is no longer open; drop it again');
    return recording.rig(options);
  },
  closeRecording: ({ handle }) => {
    recordings.get(handle)?.free();
    recordings.delete(handle);
  },
  simulate: ({ options }) => simulateRig(options),
  // `workers` > 1 shares the global stage, JRMPC's E-step and the frame pairs' ICP with that
  // many workers in all (this one included), where a worker can start workers of its own;
  // `eStepDevice` 'auto' or 'gpu' puts the E-step on the GPU where WebGPU allows (shard-pool.js,
  // gpu-estep.js).
  calibrate: async ({ input, workers = 1, eStepDevice = 'cpu' }, id) => {
    // At most 10 progress messages a second, and always each stage's first and last: the page
    // redraws on each, and that work competes with the calculation (docs/lab/benchmarks-log.md). A
    // stage that stops before its maximum (EM converged) has its last message posted when the
    // next stage begins.
    let postedAt = -Infinity;
    let postedStage = null;
    let held = null;
    const stageOf = (progress) => `${progress.method}/${progress.stage}`;
    const post = (progress) => {
      postedAt = performance.now();
      postedStage = stageOf(progress);
      held = null;
      self.postMessage({ type: 'progress', id, progress });
    };
    const onProgress = (progress) => {
      const begun = stageOf(progress) !== postedStage;
      if (held !== null && stageOf(held) !== stageOf(progress)) post(held);
      if (begun || performance.now() - postedAt >= 100 || progress.iteration === progress.maxIterations) post(progress);
      else held = progress;
      return true;
    };
    const shared = workers > 1 && typeof Worker === 'function';
    if (shared || eStepDevice !== 'cpu') {
      const module = await compiled;
      return calibrateSharded(wasm, input, shared ? workers : 1, onProgress, () => new RemoteWorker(module), eStepDevice);
    }
    const result = calibrate(input, onProgress);
    for (const r of Array.isArray(result) ? result : [result]) if (!r.error) r.workers = 1;
    return result;
  },
};

self.onmessage = async ({ data }) => {
  const { type, id } = data;
  try {
    await ready;
    const handler = handlers[type];
    if (!handler) throw new Error(`unknown request type '${type}'`);
    const result = await handler(data, id);
    self.postMessage({ type: 'result', id, result }, [...new Set(buffersOf(result))]);
  } catch (error) {
    // A trap inside wasm (a panic, out of memory) leaves the instance unusable: ask for a new
    // worker. Ordinary errors (bad input) are values and keep this one.
    const fatal = error instanceof WebAssembly.RuntimeError;
    const message = error?.message ?? String(error);
    self.postMessage({ type: 'error', id, fatal, message: fatal ? `the calculation crashed (${message}); restarted` : message });
  }
};
