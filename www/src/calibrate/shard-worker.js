// A pool worker (see shard-pool.js): holds a shard of JRMPC's E-step, some views' points in its
// own wasm instance, and answers each {type: 'eStep', input, first} with its views'
// statistics; registers frame pairs, {type: 'align', ...}, and aligns a sensor globally,
// {type: 'alignGlobal', job}, for the calibration worker.
import init, { JrmpcShard, alignGlobal, alignPairs } from '../../pkg/gmmcalib.js';
import wasmUrl from '../../pkg/gmmcalib_bg.wasm?url';

// The first message is {type: 'module', module}: the calibration worker's compiled module,
// whose code this worker shares, or undefined to fetch and compile its own.
let loaded;
const ready = new Promise((resolve) => { loaded = resolve; })
  .then((module) => init({ module_or_path: module ?? wasmUrl }));
let shard = null;

self.onmessage = async ({ data }) => {
  if (data.type === 'module') {
    loaded(data.module);
    return;
  }
  try {
    await ready;
    if (data.type === 'ready') {
      self.postMessage({ type: 'output', output: null });
    } else if (data.type === 'init') {
      shard?.free();
      shard = new JrmpcShard(data.points, data.sizes);
      self.postMessage({ type: 'ready' });
    } else if (data.type === 'eStep') {
      if (!shard) throw new Error('eStep before init');
      const output = shard.eStep(data.input, data.first);
      self.postMessage({ type: 'output', output }, [output.buffer]);
    } else if (data.type === 'align') {
      const output = alignPairs(data.icp, data.target, data.sources, data.starts);
      self.postMessage({ type: 'output', output }, output.filter((o) => o instanceof Float64Array).map((o) => o.buffer));
    } else if (data.type === 'alignGlobal') {
      self.postMessage({ type: 'output', output: alignGlobal(data.job) });
    } else {
      throw new Error(`unknown request type '${data.type}'`);
    }
  } catch (error) {
    self.postMessage({ type: 'error', message: error?.message ?? String(error) });
  }
};
