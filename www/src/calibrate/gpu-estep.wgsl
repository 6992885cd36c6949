// JRMPC's E-step on the GPU, dense, in f32 (gpu-estep.js drives it; docs/method.md).
// `a_ik = s_k exp(-h_k |c_k - v_i|^2)` with `s_k = p_k Q_k^1.5`, `h_k = Q_k / 2`, `v_i` the
// view's centred point and `c_k = R^T (x_k - t)` the component's mean in the view's frame (the
// distance is the one after transforming, `|R v + t - x_k|`); `alpha_ik = a_ik / (sum_l a_il +
// beta)` (TPAMI 2018 eq. 9), as the CPU's `estep::dense` computes it.
//
// Points and means come as f32 pairs `hi + lo` (the f64 value rounded, then the rest rounded):
// for a point near a mean, `hi - hi` is exact, so `u = c - v` keeps about f64's accuracy where
// it matters. A plain f32 difference carries the rounding of coordinates metres from the
// centre, micrometres, into the exponent of components a centimetre wide.
//
// Two passes, so no f32 atomics are needed and every sum has a fixed order (the same input
// gives the same output on every run):
// - `normalise`: one invocation per point; writes its posterior normaliser
//   `1 / (sum_l a_il + beta)` (0 where every term underflowed, as on the CPU).
// - `sums`: one workgroup per (component, chunk of one view's points); each invocation walks
//   the chunk with a stride, then a tree reduction in workgroup memory. It writes the chunk's
//   `[sum alpha, sum alpha u (3), sum alpha |u|^2]`: sums about the component's mean, which f32
//   holds well (sums of `v` and `|v|^2` would lose the variance to cancellation). The host adds
//   the chunks in f64 and turns them into the wire's sums of `v` and `|v|^2`.

struct Params {
  points: u32,     // points in all
  components: u32, // K
  beta: f32,       // the outlier term
  row: u32,        // invocations per row of a 2D `normalise` dispatch
}

struct Mean {
  hi: vec4f, // c_k's hi, h_k
  lo: vec4f, // c_k's lo, s_k (0: a dropped component)
}

const WORKGROUP: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> points: array<vec4f>;  // v's hi, view index in w
@group(0) @binding(2) var<storage, read> lows: array<vec4f>;    // v's lo
@group(0) @binding(3) var<storage, read> means: array<Mean>;    // per view, per component
@group(0) @binding(4) var<storage, read_write> norms: array<f32>; // per point
@group(0) @binding(5) var<storage, read> chunks: array<vec4u>;  // first point, count, view
@group(0) @binding(6) var<storage, read_write> partials: array<f32>; // 5 per (chunk, k)

// `exp(-x)` for `x >= 0` to about 1 ulp, 0 past 87: the CPU kernel's `exp_neg_f32` (Cephes'
// range reduction, a degree-4 minimax polynomial, 2^n from its bits). WGSL's `exp` may be off
// by 3 + 2|x| ulp, an error that grows with the distance and so bends every component's shape.
fn exp_neg(x: f32) -> f32 {
  if (x >= 87.0) {
    return 0.0;
  }
  let y = -x;
  let n = round(y * 1.442695);
  let r = y - n * 0.6933594 - n * -2.1219444e-4;
  var p = 1.3813146e-3;
  p = p * r + 8.369419e-3;
  p = p * r + 4.1668456e-2;
  p = p * r + 1.6666515e-1;
  p = p * r + 0.49999994;
  let e_r = p * (r * r) + r + 1.0;
  return e_r * bitcast<f32>(u32(i32(n) + 127) << 23u);
}

// `u = c - v` from the pairs: the high parts' difference first (exact when they are close).
fn offset(mean: Mean, i: u32) -> vec3f {
  return (mean.hi.xyz - points[i].xyz) + (mean.lo.xyz - lows[i].xyz);
}

@compute @workgroup_size(WORKGROUP)
fn normalise(@builtin(global_invocation_id) id: vec3u) {
  let i = id.x + id.y * params.row;
  if (i >= params.points) {
    return;
  }
  let first = u32(points[i].w) * params.components;
  // Kahan's compensated sum: a plain f32 sum of K terms carries about sqrt(K) roundings,
  // 1e-6 of the total at K = 400, into every posterior of the point, which moved JRMPC alone
  // on the demo by 0.005 deg / 1 mm (0.0004 deg / 0.09 mm compensated). The chunk sums below
  // gained nothing from it.
  var total = 0.0;
  var lost = 0.0;
  for (var k = 0u; k < params.components; k++) {
    let mean = means[first + k];
    let u = offset(mean, i);
    let y = mean.lo.w * exp_neg(mean.hi.w * dot(u, u)) - lost;
    let t = total + y;
    lost = (t - total) - y;
    total = t;
  }
  norms[i] = select(0.0, 1.0 / (total + params.beta), total > 0.0);
}

var<workgroup> shared_sums: array<array<f32, 5>, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn sums(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
  let k = group.x;
  let chunk = chunks[group.y];
  let mean = means[chunk.z * params.components + k];
  var s = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
  for (var j = lane; j < chunk.y; j += WORKGROUP) {
    let i = chunk.x + j;
    let u = offset(mean, i);
    let u2 = dot(u, u);
    let alpha = mean.lo.w * exp_neg(mean.hi.w * u2) * norms[i];
    s[0] += alpha;
    s[1] += alpha * u.x;
    s[2] += alpha * u.y;
    s[3] += alpha * u.z;
    s[4] += alpha * u2;
  }
  shared_sums[lane] = s;
  workgroupBarrier();
  for (var half = WORKGROUP / 2u; half > 0u; half /= 2u) {
    if (lane < half) {
      for (var c = 0u; c < 5u; c++) {
        shared_sums[lane][c] += shared_sums[lane + half][c];
      }
    }
    workgroupBarrier();
  }
  if (lane == 0u) {
    let at = 5u * (group.y * params.components + k);
    for (var c = 0u; c < 5u; c++) {
      partials[at + c] = shared_sums[0][c];
    }
  }
}
