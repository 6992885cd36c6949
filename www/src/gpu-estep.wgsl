// JRMPC's E-step on the GPU, dense, in f32 (gpu-estep.js drives it; docs/method.md).
// `a_ik = s_k exp(-h_k |p_i - x_k|^2)` with `s_k = p_k Q_k^1.5`, `h_k = Q_k / 2` and
// `p_i = R v_i + t` the view's transformed centred point; `alpha_ik = a_ik / (sum_l a_il + beta)`
// (TPAMI 2018 eq. 9), as the CPU's `estep::dense` computes it.
//
// Two passes, so no f32 atomics are needed and every sum has a fixed order (the same input
// gives the same output on every run):
// - `transform`: one invocation per point; writes its transformed position and its posterior
//   normaliser `1 / (sum_l a_il + beta)` (0 where every term underflowed, as on the CPU).
// - `sums`: one workgroup per (component, chunk of one view's points); each invocation walks
//   the chunk with a stride, then a tree reduction in workgroup memory. It writes the chunk's
//   `[sum alpha, sum alpha u (3), sum alpha |u|^2]` with `u = x_k - p`: sums about the
//   component's mean, which f32 holds well (sums of `v` and `|v|^2` would lose the variance to
//   cancellation). The host adds the chunks in f64 and turns them into the wire's sums over
//   untransformed points, as `estep::accumulate` does.

struct Params {
  points: u32,     // points in all
  components: u32, // K
  beta: f32,       // the outlier term
  row: u32,        // invocations per row of a 2D `transform` dispatch
}

struct View {
  r0: vec4f, // row 0 of R, t.x
  r1: vec4f,
  r2: vec4f,
}

const WORKGROUP: u32 = 64u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> points: array<vec4f>;     // v (centred), view index in w
@group(0) @binding(2) var<storage, read> views: array<View>;
@group(0) @binding(3) var<storage, read> components: array<vec4f>; // x_k, h_k
@group(0) @binding(4) var<storage, read> scales: array<f32>;       // s_k; 0: dropped
@group(0) @binding(5) var<storage, read_write> moved: array<vec4f>; // p, normaliser
@group(0) @binding(6) var<storage, read> chunks: array<vec4u>;     // first point, count
@group(0) @binding(7) var<storage, read_write> partials: array<f32>; // 5 per (chunk, k)

fn term(k: u32, p: vec3f) -> f32 {
  let u = components[k].xyz - p;
  return scales[k] * exp(-components[k].w * dot(u, u));
}

@compute @workgroup_size(WORKGROUP)
fn transform(@builtin(global_invocation_id) id: vec3u) {
  let i = id.x + id.y * params.row;
  if (i >= params.points) {
    return;
  }
  let point = points[i];
  let view = views[u32(point.w)];
  let v = vec4f(point.xyz, 1.0);
  let p = vec3f(dot(view.r0, v), dot(view.r1, v), dot(view.r2, v));
  var total = 0.0;
  for (var k = 0u; k < params.components; k++) {
    total += term(k, p);
  }
  moved[i] = vec4f(p, select(0.0, 1.0 / (total + params.beta), total > 0.0));
}

var<workgroup> shared_sums: array<array<f32, 5>, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn sums(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
  let k = group.x;
  let chunk = chunks[group.y];
  let mean = components[k].xyz;
  var s = array<f32, 5>(0.0, 0.0, 0.0, 0.0, 0.0);
  for (var j = lane; j < chunk.y; j += WORKGROUP) {
    let m = moved[chunk.x + j];
    let u = mean - m.xyz;
    let u2 = dot(u, u);
    let alpha = scales[k] * exp(-components[k].w * u2) * m.w;
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
