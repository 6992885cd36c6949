//! The E-step's hot loop: one point against a contiguous block of components.
//!
//! Plain loops with no reduction inside, over structure-of-arrays columns, which LLVM turns
//! into SIMD (SSE2 natively, simd128 under wasm32 with `+simd128`); a polynomial exp instead of
//! libm's; no fused multiply-add and lane sums reduced in a fixed order, so results do not
//! depend on how the loops were vectorised.
//!
//! Exponents are f64, the exps f32 (four lanes where f64 has two, and a degree-6 polynomial
//! where f64 needs 10), the sums f64. The f32 exp's relative error of about 1e-7 per term moves
//! the calibrations of tests/jrmpc/registration.rs by at most 8e-6 rad against the exact dense
//! path (the bound is 1e-4). Distances in f32 as well would be faster still, but moved them by
//! up to 5e-4 rad: an f32 coordinate's rounding, a few sigma from the cell centre, shifts a narrow
//! component's exponent systematically for every point of the cell. With the sums in f32 too
//! (1.45x in wasm), plain `jrmpc`'s twin studies moved 0.15 deg and more
//! (docs/lab/benchmarks-log.md).

/// Elements per chunk of the lane sums; blocks are padded to a multiple of it.
pub const LANES: usize = 4;

/// Largest exponent evaluated in f32 (`exp(-87)` is still a normal f32); terms beyond it are 0,
/// as they are beyond the grid's cutoff. That cutoff is about 20-45 in practice; where it is
/// higher the terms dropped here are below `1.7e-38 p_k Q_k^1.5` each.
const MAX_EXPONENT_F32: f32 = 87.0;

/// The exponent written for a term past the cutoff, which [`exps`] turns into 0. Not
/// infinity: its exp would be clamped to `exp(-87)`, which times `p_k Q_k^1.5` is subnormal,
/// and x86 takes a microcode assist of about a hundred cycles for each subnormal product
/// (natively and under wasm, which keeps subnormals): half of the sample job's native time.
const OUTSIDE: f32 = -1.0;

/// Posteriors below this are dropped: products with them could be subnormal, which costs x86
/// a hundred cycles each.
const TINY: f64 = 1e-280;

/// `exp(-x)` in f32 for `0 <= x <= 87`, to about 1 ulp: `2^n e^r`, `n` rounded by the
/// 1.5 * 2^23 trick, `r` split off in two parts (Cephes' expf), `e^r = 1 + r + r^2 P(r)` with
/// `P` of degree 4, minimax for relative error on `|r| <= 1.01 ln2 / 2` (the margin covers the
/// range reduction's rounding): 3e-9 before rounding, far below f32's 6e-8, so in f32 it is as
/// accurate as Cephes' degree-5 `P` (both at most 8e-8, mean error below 2e-9). The step saved
/// made the sample job 9 % faster in wasm and 3 % natively (docs/lab/benchmarks-log.md).
#[inline(always)]
pub fn exp_neg_f32(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const P: [f32; 5] =
        [1.381_314_6e-3, 8.369_419e-3, 4.166_845_6e-2, 1.666_651_5e-1, 0.499_999_94];
    let y = -(if x < MAX_EXPONENT_F32 { x } else { MAX_EXPONENT_F32 });
    let t = y * std::f32::consts::LOG2_E + MAGIC;
    let n = t - MAGIC;
    let r = y - n * LN2_HI - n * LN2_LO;
    let mut p = P[0];
    for c in &P[1..] {
        p = p * r + c;
    }
    let e_r = p * (r * r) + r + 1.0;
    let n = t.to_bits() as i32 - 0x4B40_0000;
    e_r * f32::from_bits(((n + 127) << 23) as u32)
}

/// Components of one block, structure of arrays, padded to a multiple of [`LANES`]; means
/// relative to `origin`. The columns keep their length (the capacity) across blocks; entries
/// `..padded` are the block's.
#[derive(Default)]
pub struct Block {
    pub origin: nalgebra::Vector3<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    /// `Q_k / 2`.
    pub half_q: Vec<f64>,
    /// `p_k Q_k^1.5`; 0 in padding.
    pub scale: Vec<f32>,
    /// Entries.
    pub len: usize,
    /// Entries with the padding.
    pub padded: usize,
}

impl Block {
    fn columns(&mut self) -> [&mut Vec<f64>; 4] {
        [&mut self.x, &mut self.y, &mut self.z, &mut self.half_q]
    }

    /// Empties the block, with room for `capacity` entries.
    pub fn start(&mut self, capacity: usize) {
        let room = capacity.div_ceil(LANES) * LANES;
        for v in self.columns() {
            if v.len() < room {
                v.resize(room, 0.0);
            }
        }
        if self.scale.len() < room {
            self.scale.resize(room, 0.0);
        }
        self.len = 0;
        self.padded = 0;
    }

    /// Pads to a multiple of [`LANES`] with entries that contribute exactly 0.
    pub fn pad(&mut self) {
        let (len, padded) = (self.len, self.len.div_ceil(LANES) * LANES);
        for v in self.columns() {
            v[len..padded].fill(0.0);
        }
        self.scale[len..padded].fill(0.0);
        self.padded = padded;
    }
}

/// Writes `a_k = p_k Q_k^1.5 exp(-Q_k |p - x_k|^2 / 2)` for every entry of `block` into `a`,
/// for each of `N` points `p` at once (each component's columns are loaded once for all of
/// them), and returns each point's sum. Terms whose exponent exceeds `cutoff` are 0 (see
/// [`Grid`]).
///
/// [`Grid`]: super::grid::Grid
pub fn terms<const N: usize>(
    block: &Block,
    p: [[f64; 3]; N],
    cutoff: f64,
    a: &mut [Vec<f32>; N],
) -> [f64; N] {
    let n = block.padded;
    let (x, y, z) = (&block.x[..n], &block.y[..n], &block.z[..n]);
    let (hq, s) = (&block.half_q[..n], &block.scale[..n]);
    let mut a = a.each_mut().map(|a| &mut a[..n]);
    // Exponents in f64 (written to `a`), then the exps in f32 lanes, twice as many.
    let cutoff = cutoff.min(f64::from(MAX_EXPONENT_F32));
    for i in 0..n {
        for (a, p) in a.iter_mut().zip(&p) {
            let (dx, dy, dz) = (x[i] - p[0], y[i] - p[1], z[i] - p[2]);
            let e = hq[i] * (dx * dx + dy * dy + dz * dz);
            a[i] = if e <= cutoff { e as f32 } else { OUTSIDE };
        }
    }
    let mut totals = [0.0; N];
    for (total, a) in totals.iter_mut().zip(a) {
        *total = exps(s, a);
    }
    totals
}

/// Turns the exponents `a` into terms `s_k exp(-a_k)` (0 past the cutoff) and returns their
/// sum.
#[inline(always)]
fn exps(s: &[f32], a: &mut [f32]) -> f64 {
    let a = &mut a[..s.len()];
    for i in 0..s.len() {
        let e = a[i];
        let v = s[i] * exp_neg_f32(e);
        a[i] = if e >= 0.0 { v } else { 0.0 };
    }
    let mut partial = [0.0f64; LANES];
    for chunk in a.chunks_exact(LANES) {
        for l in 0..LANES {
            partial[l] += f64::from(chunk[l]);
        }
    }
    partial.iter().sum()
}

/// Posteriors `alpha_k = a_k * norm` of the points of a run, summed per block entry:
/// `lambda += alpha`, `p_sum += alpha p`, `p2 += alpha |p|^2`, with `p` in block coordinates
/// (about the cell's centre, within a few reaches of the means). [`Accumulators::about_mean`]
/// turns them into sums of `u = x_k - p` and `|u|^2`: the variance needs sums about the
/// component's mean, and in block coordinates the expansion loses no more than about 1e-14
/// of them, while each term costs five multiply-adds instead of eleven operations.
#[derive(Default)]
pub struct Accumulators {
    pub lambda: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub p2: Vec<f64>,
}

impl Accumulators {
    pub fn reset(&mut self, len: usize) {
        for v in [&mut self.lambda, &mut self.x, &mut self.y, &mut self.z, &mut self.p2] {
            v.clear();
            v.resize(len, 0.0);
        }
    }

    /// Adds `N` points at `p` (block coordinates) whose terms are `a`, with their posterior
    /// normalisers `norm`; each accumulator is loaded and stored once for all of them. A
    /// point that stands for a cell of points (multi-resolution) is their mean, with their
    /// count folded into `norm` and their mean squared distance from it in `spread` (0 for a
    /// point).
    pub fn add<const N: usize>(
        &mut self,
        block: &Block,
        p: [[f64; 3]; N],
        spread: [f64; N],
        a: &[Vec<f32>; N],
        norm: [f64; N],
    ) {
        let n = block.padded;
        let (l, x, y, z) =
            (&mut self.lambda[..n], &mut self.x[..n], &mut self.y[..n], &mut self.z[..n]);
        let p2 = &mut self.p2[..n];
        let a = a.each_ref().map(|a| &a[..n]);
        let squares: [f64; N] = std::array::from_fn(|j| {
            p[j][0] * p[j][0] + p[j][1] * p[j][1] + p[j][2] * p[j][2] + spread[j]
        });
        for i in 0..n {
            let (mut sl, mut sx, mut sy, mut sz, mut sp2) = (l[i], x[i], y[i], z[i], p2[i]);
            for j in 0..N {
                let alpha = f64::from(a[j][i]) * norm[j];
                let alpha = if alpha >= TINY { alpha } else { 0.0 };
                sl += alpha;
                sx += alpha * p[j][0];
                sy += alpha * p[j][1];
                sz += alpha * p[j][2];
                sp2 += alpha * squares[j];
            }
            (l[i], x[i], y[i], z[i], p2[i]) = (sl, sx, sy, sz, sp2);
        }
    }

    /// Entry `e`'s sums about its mean `x_k` (block coordinates): `[lambda, sum alpha u,
    /// sum alpha |u|^2]` with `u = x_k - p`.
    pub fn about_mean(&self, block: &Block, e: usize) -> [f64; 5] {
        let (l, s) = (self.lambda[e], [self.x[e], self.y[e], self.z[e]]);
        let m = [block.x[e], block.y[e], block.z[e]];
        let u = [0, 1, 2].map(|i| m[i] * l - s[i]);
        let m2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
        let cross = m[0] * s[0] + m[1] * s[1] + m[2] * s[2];
        [l, u[0], u[1], u[2], m2 * l - 2.0 * cross + self.p2[e]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_f32_is_accurate_to_f32() {
        let mut worst = 0.0f64;
        for i in 0..=870_000 {
            let x = i as f32 * 1e-4;
            let exact = (-f64::from(x)).exp();
            worst = worst.max((f64::from(exp_neg_f32(x)) - exact).abs() / exact);
        }
        assert!(worst < 2.5e-7, "relative error {worst}");
        assert_eq!(exp_neg_f32(0.0), 1.0);
        assert!(exp_neg_f32(1e6) > 0.0 && exp_neg_f32(1e6) < 1e-37);
    }
}
