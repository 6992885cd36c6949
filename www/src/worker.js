// All heavy work happens here, off the main thread: the wasm module is loaded once and each
// request {type, id, ...} is answered with {type: 'result' | 'error', id, ...}. Typed arrays in
// results are transferred, not copied.
import init, { calibrate, parseCloud, simulateRig } from '../pkg/gmmcalib.js';
import wasmUrl from '../pkg/gmmcalib_bg.wasm?url';

const ready = init({ module_or_path: wasmUrl });

function buffersOf(value, found = []) {
  if (ArrayBuffer.isView(value)) found.push(value.buffer);
  else if (value && typeof value === 'object') for (const v of Object.values(value)) buffersOf(v, found);
  return found;
}

const handlers = {
  parse: ({ bytes, name }) => parseCloud(new Uint8Array(bytes), name),
  simulate: ({ options }) => simulateRig(options),
  calibrate: ({ input }, id) =>
    calibrate(input, (progress) => {
      self.postMessage({ type: 'progress', id, progress });
      return true;
    }),
};

self.onmessage = async ({ data }) => {
  const { type, id } = data;
  try {
    await ready;
    const handler = handlers[type];
    if (!handler) throw new Error(`unknown request type '${type}'`);
    const result = handler(data, id);
    self.postMessage({ type: 'result', id, result }, [...new Set(buffersOf(result))]);
  } catch (error) {
    // A trap inside wasm (a panic, out of memory) leaves the instance unusable: ask for a new
    // worker. Ordinary errors (bad input) are values and keep this one.
    const fatal = error instanceof WebAssembly.RuntimeError;
    const message = error?.message ?? String(error);
    self.postMessage({ type: 'error', id, fatal, message: fatal ? `the calculation crashed (${message}); restarted` : message });
  }
};
