//! The E-step's hot loop: one point against a contiguous block of components.
//!
//! Plain loops with no reduction inside, over structure-of-arrays columns, which LLVM turns
//! into SIMD (SSE2 natively, simd128 under wasm32 with `+simd128`); a polynomial exp instead of
//! libm's; no fused multiply-add and lane sums reduced in a fixed order, so results do not
//! depend on how the loops were vectorised. f64 throughout: the reference's calibrations move by 1e-5 rad
//! when every term carries a relative error of 1e-7 (f32), so f32 cannot meet the 1e-4 rad
//! bound after 100 iterations on rigs that have not converged.

/// Elements per chunk of the lane sums; blocks are padded to a multiple of it.
pub const LANES: usize = 4;

/// Largest exponent evaluated (`exp(-700)` is still a normal f64).
const MAX_EXPONENT: f64 = 700.0;

/// Posteriors below this are dropped: products with them could be subnormal, which costs x86
/// a hundred cycles each.
const TINY: f64 = 1e-280;

/// Coefficients of `e^r` on `|r| <= ln 2 / 2`, degree 10 down to 0: a minimax fit of the
/// relative error (Remez, in 50-digit arithmetic), 3e-16 with the coefficients in f64, as
/// close as the degree-12 Taylor series it replaced, for two multiply-adds less.
const EXP_POLY: [f64; 11] = [
    2.748_844_619_412_401_3e-7,
    2.763_976_818_338_151_3e-6,
    2.480_191_768_015_792e-5,
    1.984_117_138_442_271e-4,
    1.388_888_849_914_629_6e-3,
    8.333_333_384_665_614e-3,
    4.166_666_666_842_598e-2,
    1.666_666_666_655_774_2e-1,
    4.999_999_999_999_728_6e-1,
    1.000_000_000_000_006_4,
    1.0,
];

/// `exp(-x)` for `x >= 0`, to about 2 ulp: `2^n e^r` with `n` rounded by the 1.5 * 2^52 trick
/// (no SSE4.1 `round` needed), `r` split off in two parts (Cody-Waite) and `e^r` by
/// [`EXP_POLY`].
#[inline(always)]
pub fn exp_neg(x: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 * 2^52: adding it rounds to an integer
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let y = -(if x < MAX_EXPONENT { x } else { MAX_EXPONENT });
    let t = y * std::f64::consts::LOG2_E + MAGIC;
    let n = t - MAGIC;
    let r = y - n * LN2_HI - n * LN2_LO;
    let mut e_r = EXP_POLY[0];
    for c in &EXP_POLY[1..] {
        e_r = e_r * r + c;
    }
    // t's bit pattern is 0x4338_0000_0000_0000 + n; 2^n is (n + 1023) in the exponent field.
    let n = t.to_bits() as i64 - 0x4338_0000_0000_0000;
    e_r * f64::from_bits(((n + 1023) << 52) as u64)
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
    pub scale: Vec<f64>,
    /// Entries.
    pub len: usize,
    /// Entries with the padding.
    pub padded: usize,
}

impl Block {
    fn columns(&mut self) -> [&mut Vec<f64>; 5] {
        [&mut self.x, &mut self.y, &mut self.z, &mut self.half_q, &mut self.scale]
    }

    /// Empties the block, with room for `capacity` entries.
    pub fn start(&mut self, capacity: usize) {
        let room = capacity.div_ceil(LANES) * LANES;
        for v in self.columns() {
            if v.len() < room {
                v.resize(room, 0.0);
            }
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
        self.padded = padded;
    }
}

/// Writes `a_k = p_k Q_k^1.5 exp(-Q_k |p - x_k|^2 / 2)` for every entry of `block` into `a`
/// and returns their sum. Terms whose exponent exceeds `cutoff` are 0 (see [`Grid`]).
///
/// [`Grid`]: super::grid::Grid
pub fn terms(block: &Block, p: [f64; 3], cutoff: f64, a: &mut [f64]) -> f64 {
    let n = block.padded;
    let (x, y, z) = (&block.x[..n], &block.y[..n], &block.z[..n]);
    let (hq, s, a) = (&block.half_q[..n], &block.scale[..n], &mut a[..n]);
    for i in 0..n {
        let (dx, dy, dz) = (x[i] - p[0], y[i] - p[1], z[i] - p[2]);
        let e = hq[i] * (dx * dx + dy * dy + dz * dz);
        let v = s[i] * exp_neg(e);
        a[i] = if e <= cutoff { v } else { 0.0 };
    }
    let mut partial = [0.0f64; LANES];
    for chunk in a.chunks_exact(LANES) {
        for l in 0..LANES {
            partial[l] += chunk[l];
        }
    }
    partial.iter().sum()
}

/// Posteriors `alpha_k = a_k * norm` of the points of a run, summed per block entry with
/// `u = x_k - p` (block coordinates): `lambda += alpha`, `u_sum += alpha u`,
/// `u2 += alpha |u|^2`. Sums about the component's mean rather than the raw
/// `sum alpha |v|^2`, which the variance formula would subtract from squared positions.
#[derive(Default)]
pub struct Accumulators {
    pub lambda: Vec<f64>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub u2: Vec<f64>,
}

impl Accumulators {
    pub fn reset(&mut self, len: usize) {
        for v in [&mut self.lambda, &mut self.x, &mut self.y, &mut self.z, &mut self.u2] {
            v.clear();
            v.resize(len, 0.0);
        }
    }

    /// Adds the point at `p` (block coordinates) whose terms are `a`.
    pub fn add(&mut self, block: &Block, p: [f64; 3], a: &[f64], norm: f64) {
        let n = a.len();
        let (bx, by, bz) = (&block.x[..n], &block.y[..n], &block.z[..n]);
        let (l, x, y, z) =
            (&mut self.lambda[..n], &mut self.x[..n], &mut self.y[..n], &mut self.z[..n]);
        let u2 = &mut self.u2[..n];
        for i in 0..n {
            let alpha = a[i] * norm;
            let alpha = if alpha >= TINY { alpha } else { 0.0 };
            let (ux, uy, uz) = (bx[i] - p[0], by[i] - p[1], bz[i] - p[2]);
            l[i] += alpha;
            x[i] += alpha * ux;
            y[i] += alpha * uy;
            z[i] += alpha * uz;
            u2[i] += alpha * (ux * ux + uy * uy + uz * uz);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_neg_is_accurate_over_the_whole_range() {
        let mut worst = 0.0f64;
        for i in 0..=700_000 {
            let x = i as f64 * 1e-3 + 1e-7 * (i % 7) as f64;
            let exact = (-x).exp();
            worst = worst.max((exp_neg(x) - exact).abs() / exact);
        }
        assert!(worst < 1e-15, "relative error {worst}");
        assert!(exp_neg(1e6) > 0.0 && exp_neg(1e6) < 1e-300);
        assert_eq!(exp_neg(0.0), 1.0);
    }
}
