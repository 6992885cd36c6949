// Promise-per-request client for the calibration worker. Messages are {type, id, ...}; the
// worker answers each request with 'result' or 'error' and may send 'progress' before that.
// cancel() terminates the worker (a running wasm call cannot be interrupted otherwise) and a
// fresh one starts on the next request; so does a crashed worker, or one whose wasm trapped.

export class WorkerClient {
  #worker = null;
  #nextId = 1;
  #pending = new Map(); // id -> {resolve, reject, onProgress}

  #ensureWorker() {
    if (this.#worker) return this.#worker;
    const worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
    worker.onmessage = (event) => this.#receive(event.data);
    worker.onerror = (event) => {
      event.preventDefault();
      this.#fail(new Error(`worker crashed: ${event.message || 'unknown error'}`));
    };
    this.#worker = worker;
    return worker;
  }

  #receive(message) {
    const request = this.#pending.get(message.id);
    if (!request) return;
    if (message.type === 'progress') {
      request.onProgress?.(message.progress);
      return;
    }
    if (message.fatal) {
      this.#fail(new Error(message.message));
      return;
    }
    this.#pending.delete(message.id);
    if (message.type === 'result') request.resolve(message.result);
    else request.reject(new Error(message.message));
  }

  // Rejects every pending request and drops the worker.
  #fail(error) {
    this.#worker?.terminate();
    this.#worker = null;
    for (const request of this.#pending.values()) request.reject(error);
    this.#pending.clear();
  }

  request(type, payload, { onProgress, transfer = [] } = {}) {
    const worker = this.#ensureWorker();
    const id = this.#nextId++;
    return new Promise((resolve, reject) => {
      this.#pending.set(id, { resolve, reject, onProgress });
      worker.postMessage({ type, id, ...payload }, transfer);
    });
  }

  cancel() {
    const error = new Error('cancelled');
    error.cancelled = true;
    this.#fail(error);
  }
}
