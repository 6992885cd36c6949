// A pool worker (see shard-pool.js): holds a shard of JRMPC's E-step, some views' points in its
// own wasm instance, and answers each {type: 'eStep', input, first} with its views'
// statistics; and registers frame pairs, {type: 'align', ...}, for the calibration worker.
import init, { JrmpcShard, alignPairs } from '../pkg/gmmcalib.js';
import wasmUrl from '../pkg/gmmcalib_bg.wasm?url';

const ready = init({ module_or_path: wasmUrl });
let shard = null;

self.onmessage = async ({ data }) => {
  try {
    await ready;
    if (data.type === 'init') {
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
    } else {
      throw new Error(`unknown request type '${data.type}'`);
    }
  } catch (error) {
    self.postMessage({ type: 'error', message: error?.message ?? String(error) });
  }
};
