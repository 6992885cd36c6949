// JRMPC's E-step on the GPU (WebGPU): one more kind of shard for shard-pool.js, holding every
// view's centred points (f32) on the GPU and answering each iteration's E-step input with the
// same output a JrmpcShard gives (`jrmpc::wire`: per view, per component lambda, s1, s2), which
// the session's M-step takes as it is. Dense and in f32, under the fidelity rule
// (docs/method.md); the shader is gpu-estep.wgsl.
import shaderSource from './gpu-estep.wgsl?raw';

const WORKGROUP = 64; // gpu-estep.wgsl's
const MAX_GROUPS = 65535; // WebGPU's default maxComputeWorkgroupsPerDimension
// Points per chunk of the `sums` pass: each invocation sums at most 32 points in f32 before
// the tree reduction; the chunks are added in f64 here.
const CHUNK = 2048;

// The adapter for `mode` ('auto' | 'gpu'), or null where the E-step should stay on the CPU.
// 'auto' takes a hardware adapter only: a software one (SwiftShader, `isFallbackAdapter`) is
// slower than the wasm workers. 'gpu' takes any, and throws where there is none.
export async function gpuAdapter(mode) {
  if (mode !== 'auto' && mode !== 'gpu') return null;
  let adapter = null;
  let why = 'this browser has no WebGPU (navigator.gpu)';
  if (globalThis.navigator?.gpu) {
    try {
      adapter = await navigator.gpu.requestAdapter({ powerPreference: 'high-performance' });
      why = 'WebGPU offers no adapter here';
    } catch (error) {
      why = `WebGPU's adapter request failed: ${error?.message ?? error}`;
    }
  }
  if (adapter && mode === 'auto' && adapter.info?.isFallbackAdapter) adapter = null;
  if (!adapter && mode === 'gpu') throw new Error(`the E-step was set to run on the GPU, but ${why}; set it to auto or cpu`);
  return adapter;
}

// The adapter's name for the page: vendor and architecture or description.
export function adapterName(adapter) {
  const info = adapter.info ?? {};
  return [info.vendor, info.architecture || info.description].filter(Boolean).join(' ') || 'unknown adapter';
}

// A GPU device and the E-step's two pipelines, for any number of shards in turn.
export class GpuEStep {
  static async create(adapter) {
    const limits = adapter.limits;
    const device = await adapter.requestDevice({
      // Room for large clouds: the points and their transformed copies, 16 bytes each.
      requiredLimits: { maxStorageBufferBindingSize: limits.maxStorageBufferBindingSize, maxBufferSize: limits.maxBufferSize },
    });
    device.pushErrorScope('validation');
    const module = device.createShaderModule({ code: shaderSource });
    const pipeline = (entryPoint) => device.createComputePipeline({ layout: 'auto', compute: { module, entryPoint } });
    const pipelines = { normalise: pipeline('normalise'), sums: pipeline('sums') };
    const error = await device.popErrorScope();
    if (error) {
      device.destroy();
      throw new Error(`the GPU E-step's shader failed: ${error.message}`);
    }
    return new GpuEStep(device, pipelines, adapterName(adapter));
  }

  constructor(device, pipelines, name) {
    this.device = device;
    this.pipelines = pipelines;
    this.name = name;
  }

  // A shard of views: `points` and `sizes` as for `new JrmpcShard`.
  shard(points, sizes) {
    return new GpuShard(this, points, sizes);
  }

  destroy() {
    this.device.destroy();
  }
}

// Some views' points on the GPU, and their E-step. `eStep` resolves where a JrmpcShard's
// returns; `seconds` sums the time from upload to read-back.
class GpuShard {
  constructor(gpu, points, sizes) {
    const { device } = gpu;
    this.gpu = gpu;
    this.sizes = Array.from(sizes);
    this.count = this.sizes.reduce((a, b) => a + b, 0);
    if (points.length !== 3 * this.count) throw new Error(`GPU shard: ${points.length} coordinates for ${this.count} points`);
    this.seconds = 0;
    this.iterations = 0;
    // Points as f32 pairs (gpu-estep.wgsl), vec4 each: the high part with the view's index
    // (exact in f32 below 2^24 views), the low part.
    const [his, los] = [new Float32Array(4 * Math.max(this.count, 1)), new Float32Array(4 * Math.max(this.count, 1))];
    const chunks = []; // [first point, count, view, 0] per chunk; a chunk is within one view
    this.viewChunks = []; // per view, its chunks' indices
    let at = 0;
    this.sizes.forEach((size, view) => {
      for (let i = at; i < at + size; i++) {
        for (let c = 0; c < 3; c++) {
          his[4 * i + c] = points[3 * i + c];
          los[4 * i + c] = points[3 * i + c] - his[4 * i + c];
        }
        his[4 * i + 3] = view;
      }
      const mine = [];
      for (let start = 0; start < size; start += CHUNK) {
        mine.push(chunks.length / 4);
        chunks.push(at + start, Math.min(CHUNK, size - start), view, 0);
      }
      this.viewChunks.push(mine);
      at += size;
    });
    this.chunks = chunks.length / 4;
    if (this.chunks > MAX_GROUPS) throw new Error(`GPU shard: ${this.count} points is more than one dispatch holds`);
    const storage = GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST;
    const make = (size, usage) => device.createBuffer({ size: Math.max(16, size), usage });
    this.buffers = {
      params: make(16, GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST),
      points: make(his.byteLength, storage),
      lows: make(los.byteLength, storage),
      norms: make(4 * this.count, GPUBufferUsage.STORAGE),
      chunks: make(16 * this.chunks, storage),
    };
    device.queue.writeBuffer(this.buffers.points, 0, his);
    device.queue.writeBuffer(this.buffers.lows, 0, los);
    device.queue.writeBuffer(this.buffers.chunks, 0, Uint32Array.from(chunks));
    this.k = 0; // the buffers that depend on K are made for the first input's K
  }

  // Buffers and bind groups that depend on K.
  #sizeFor(k) {
    const { device, pipelines } = this.gpu;
    for (const name of ['means', 'partials', 'readBack']) this.buffers[name]?.destroy();
    const partialBytes = 20 * this.chunks * k;
    Object.assign(this.buffers, {
      means: device.createBuffer({ size: 32 * this.sizes.length * k, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST }),
      partials: device.createBuffer({ size: partialBytes, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC }),
      readBack: device.createBuffer({ size: partialBytes, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST }),
    });
    const b = this.buffers;
    const group = (pipeline, bindings) => device.createBindGroup({
      layout: pipeline.getBindGroupLayout(0),
      entries: bindings.map(([binding, buffer]) => ({ binding, resource: { buffer } })),
    });
    this.groups = {
      normalise: group(pipelines.normalise, [[0, b.params], [1, b.points], [2, b.lows], [3, b.means], [4, b.norms]]),
      sums: group(pipelines.sums, [[0, b.params], [1, b.points], [2, b.lows], [3, b.means], [4, b.norms], [5, b.chunks], [6, b.partials]]),
    };
    this.k = k;
  }

  // The E-step of this shard's views, which are views `first..` of the session: `input` and
  // the output as in `jrmpc::wire`.
  async eStep(input, first) {
    const started = performance.now();
    const { device, pipelines } = this.gpu;
    // input[2], multi-resolution EM's cube edge, is the CPU's saving: the GPU evaluates every
    // point, the statistics the cubes stand for. input[3] asks for the exact E-step (f64),
    // which only the CPU computes: the pool never sends it here.
    const [beta, k, , exact] = input;
    const views = this.sizes.length;
    const head = 4;
    const transforms = head + 5 * k + 12 * first;
    if (!(Number.isInteger(k) && k > 0 && beta > 0) || input.length < transforms + 12 * views) {
      throw new Error('GPU shard: malformed E-step input');
    }
    if (exact !== 0) throw new Error('GPU shard: the exact E-step runs on the CPU only');
    if (k !== this.k) this.#sizeFor(k);
    const means = input.subarray(head, head + 3 * k);
    const variances = input.subarray(head + 3 * k, head + 4 * k);
    const priors = input.subarray(head + 4 * k, head + 5 * k);
    const rt = input.subarray(transforms, transforms + 12 * views);
    // Per view, per component: its mean in the view's frame, c = R^T (x_k - t), as an f32
    // pair, with h_k = Q_k / 2 and s_k = p_k Q_k^1.5 (in f64, as Mixture::peak_scales, then
    // rounded).
    const centres = new Float64Array(3 * k * views);
    const packed = new Float32Array(8 * k * views);
    for (let v = 0; v < views; v++) {
      const r = rt.subarray(12 * v, 12 * v + 9); // row-major
      const t = rt.subarray(12 * v + 9, 12 * v + 12);
      for (let c = 0; c < k; c++) {
        const d = [means[3 * c] - t[0], means[3 * c + 1] - t[1], means[3 * c + 2] - t[2]];
        const q = 1 / variances[c];
        const at = v * k + c;
        for (let i = 0; i < 3; i++) {
          const x = r[i] * d[0] + r[3 + i] * d[1] + r[6 + i] * d[2];
          centres[3 * at + i] = x;
          packed[8 * at + i] = x;
          packed[8 * at + 4 + i] = x - packed[8 * at + i];
        }
        packed[8 * at + 3] = q / 2;
        packed[8 * at + 7] = priors[c] * q * Math.sqrt(q);
      }
    }
    const groups = Math.ceil(this.count / WORKGROUP);
    const rows = Math.ceil(groups / MAX_GROUPS);
    const perRow = Math.ceil(groups / rows);
    const params = new ArrayBuffer(16);
    new Uint32Array(params).set([this.count, k, 0, perRow * WORKGROUP]);
    new Float32Array(params)[2] = beta;
    const b = this.buffers;
    device.queue.writeBuffer(b.params, 0, params);
    device.queue.writeBuffer(b.means, 0, packed);

    const encoder = device.createCommandEncoder();
    const pass = encoder.beginComputePass();
    if (this.count) {
      pass.setPipeline(pipelines.normalise);
      pass.setBindGroup(0, this.groups.normalise);
      pass.dispatchWorkgroups(perRow, rows);
      pass.setPipeline(pipelines.sums);
      pass.setBindGroup(0, this.groups.sums);
      pass.dispatchWorkgroups(k, this.chunks);
    }
    pass.end();
    encoder.copyBufferToBuffer(b.partials, 0, b.readBack, 0, b.partials.size);
    device.queue.submit([encoder.finish()]);
    await b.readBack.mapAsync(GPUMapMode.READ);
    const partials = new Float32Array(b.readBack.getMappedRange()).slice();
    b.readBack.unmap();

    const output = new Float64Array(1 + 5 * k * views);
    output[0] = this.count * k; // dense: every term
    for (let v = 0; v < views; v++) {
      const base = 1 + 5 * k * v;
      for (let c = 0; c < k; c++) {
        // The chunks' sums about c, in f64 and chunk order.
        let [l, ux, uy, uz, u2] = [0, 0, 0, 0, 0];
        for (const chunk of this.viewChunks[v]) {
          const at = 5 * (chunk * k + c);
          l += partials[at];
          ux += partials[at + 1];
          uy += partials[at + 2];
          uz += partials[at + 3];
          u2 += partials[at + 4];
        }
        // Sums of u = c - v, back to sums of v = c - u (as estep::accumulate does).
        const m = centres.subarray(3 * (v * k + c), 3 * (v * k + c) + 3);
        const mu = m[0] * ux + m[1] * uy + m[2] * uz;
        output[base + c] = l;
        output[base + k + 3 * c] = l * m[0] - ux;
        output[base + k + 3 * c + 1] = l * m[1] - uy;
        output[base + k + 3 * c + 2] = l * m[2] - uz;
        output[base + 4 * k + c] = l * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]) - 2 * mu + u2;
      }
    }
    this.seconds += (performance.now() - started) / 1000;
    this.iterations += 1;
    return output;
  }

  free() {
    for (const buffer of Object.values(this.buffers)) buffer.destroy();
  }
}
