// The worker client's recovery, with a stand-in Worker: a crash or a wasm trap rejects what was
// pending and the next request gets a fresh worker; cancel does the same.
import { test } from 'node:test';
import assert from 'node:assert/strict';

const workers = [];
class FakeWorker {
  constructor() {
    this.sent = [];
    this.terminated = false;
    workers.push(this);
  }
  postMessage(message) {
    this.sent.push(message);
  }
  terminate() {
    this.terminated = true;
  }
  reply(message) {
    this.onmessage({ data: message });
  }
}
globalThis.Worker = FakeWorker;
const { WorkerClient } = await import('../src/calibrate/rpc.js');

test('results, progress and errors reach the request they answer', async () => {
  const client = new WorkerClient();
  const progress = [];
  const a = client.request('calibrate', { input: 1 }, { onProgress: (p) => progress.push(p) });
  const b = client.request('parse', { name: 'x.pcd' });
  const [w] = workers.slice(-1);
  const [ida, idb] = w.sent.map((m) => m.id);
  w.reply({ type: 'progress', id: ida, progress: { iteration: 1 } });
  w.reply({ type: 'error', id: idb, message: 'x.pcd: bad header' });
  w.reply({ type: 'result', id: ida, result: 42 });
  assert.equal(await a, 42);
  await assert.rejects(b, /x\.pcd: bad header/);
  assert.deepEqual(progress, [{ iteration: 1 }]);
  assert.equal(w.terminated, false, 'an ordinary error keeps the worker');
});

test('a crash, a wasm trap or a cancel replaces the worker', async () => {
  const client = new WorkerClient();
  const first = client.request('calibrate', {});
  const w1 = workers.at(-1);
  w1.onerror({ message: 'out of memory', preventDefault() {} });
  await assert.rejects(first, /worker crashed: out of memory/);
  assert.equal(w1.terminated, true);

  const second = client.request('calibrate', {});
  const w2 = workers.at(-1);
  assert.notEqual(w2, w1);
  w2.reply({ type: 'error', id: w2.sent[0].id, fatal: true, message: 'the calculation crashed' });
  await assert.rejects(second, /the calculation crashed/);
  assert.equal(w2.terminated, true);

  const third = client.request('calibrate', {});
  const w3 = workers.at(-1);
  assert.notEqual(w3, w2);
  client.cancel();
  await assert.rejects(third, (e) => e.cancelled === true);
  assert.equal(w3.terminated, true);
});
