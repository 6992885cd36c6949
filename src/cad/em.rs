//! The EM engine behind [`super::register`]: a sparse E-step over a hash grid of the fixed
//! centres that reduces each point's responsibilities to a few sums, and the per-sensor
//! Gauss-Newton M-step and the variance update that need only those sums.
//!
//! All positions are taken relative to the centres' centroid (`origin`), so the expanded
//! quadratic forms below do not cancel with vehicle-frame coordinates of tens of metres.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use super::CadModel;
use crate::se3::Pose;

/// At most this many grid cells; beyond it the cells grow (the search stays exact, only
/// slower).
const MAX_CELLS: usize = 1 << 18;

/// CADCalib's guard added to the posterior denominator and the variance's (`+ 1e-12` in
/// `e_step` and `m_step`).
const TINY: f64 = 1e-12;

/// CADCalib stops a sensor's Gauss-Newton steps once a step is shorter than this
/// (`_solve_shared_extrinsics`: `if max_delta < 1e-8: break`).
const STEP_DONE: f64 = 1e-8;

/// One centre, relative to the origin, with its per-centre constants.
#[derive(Clone, Copy, Debug)]
struct Centre {
    c: [f64; 3],
    n: [f64; 3],
    a: f64,
    /// `ln(F_max / F_k)`, CADCalib's weight `F_k` of the centre's Gaussian in the posterior
    /// numerator as an offset of its exponent (infinite for a zero weight).
    log_weight: f64,
    /// What a term adds to the sums besides its responsibility: `a n n^T` (xx, xy, xz, yy,
    /// yz, zz), `Lambda c` (x, y, z) and `c^T Lambda c`, with `Lambda = I + a n n^T`.
    row: [f64; 10],
}

/// One point's responsibilities reduced to what the M-step needs: with `r_k` the
/// responsibility of centre `k` and `Lambda_k = I + a_k n_k n_k^T` (unscaled), `w = sum r_k`,
/// `m0 = sum r_k Lambda_k` (xx, xy, xz, yy, yz, zz), `m1 = sum r_k Lambda_k c_k` and
/// `m2 = sum r_k c_k^T Lambda_k c_k`, so that for the point at `x`
/// `sum r_k (x - c_k)^T Lambda_k (x - c_k) = x^T m0 x - 2 x.m1 + m2`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Summary {
    pub w: f64,
    m0: [f64; 6],
    m1: [f64; 3],
    m2: f64,
}

impl Summary {
    fn m0(&self) -> Matrix3<f64> {
        let m = &self.m0;
        Matrix3::new(m[0], m[1], m[2], m[1], m[3], m[4], m[2], m[4], m[5])
    }

    /// A point's whole weight on an unbounded plane through `c` with unit normal `n`, whose
    /// precision across it is `lambda` and along it none: `lambda (x - c)^T n n^T (x - c)`.
    pub fn plane(n: &Vector3<f64>, c: &Vector3<f64>, lambda: f64) -> Self {
        let m = n * n.transpose() * lambda;
        let m1 = m * c;
        Self {
            w: 1.0,
            m0: [m[(0, 0)], m[(0, 1)], m[(0, 2)], m[(1, 1)], m[(1, 2)], m[(2, 2)]],
            m1: m1.into(),
            m2: c.dot(&m1),
        }
    }

    /// `sum r_k (x - c_k)^T Lambda_k (x - c_k)`, not below 0 (CADCalib clamps its squared
    /// distances at 0 the same way).
    pub fn anisotropic_sq(&self, x: &Vector3<f64>) -> f64 {
        let q = x.dot(&(self.m0() * x)) - 2.0 * x.dot(&Vector3::from(self.m1)) + self.m2;
        q.max(0.0)
    }
}

/// The fixed mixture, relative to its centroid, with CADCalib's outlier constants.
pub(super) struct Mixture {
    pub origin: Vector3<f64>,
    centres: Vec<Centre>,
    /// The largest `F_k`; the kernel's terms are `F_k / F_max exp(..)`.
    weight_max: f64,
    /// CADCalib's `bounding_volume` (m^3): the box of all points and centres at the start.
    bounding_volume: f64,
}

impl Mixture {
    /// `gamma`: GMMBase's `gamma` (0.1), giving the priors `pk = 1 / (K (gamma + 1))`;
    /// `w`: the outlier ratio; `sigma2`: the initial variance the outlier weight is fixed at.
    pub fn new(model: &CadModel, gamma: f64, w: f64, sigma2: f64, bounding_volume: f64) -> Self {
        let k = model.len();
        let origin = model.centres.iter().sum::<Vector3<f64>>() / k as f64;
        // CADCalib `_compute_f_matrix_factor`: f_Y = pk sqrt(1 + a_k);
        // w0 = V w sum(f_Y sqrt(1 + a_k)) (2 pi sigma^2)^-1.5, w0 /= 1 - w + w0;
        // F_k = (1 - w0) / (w0 + 1e-12) f_Y. Fixed at the initial sigma, as there.
        let pk = 1.0 / (k as f64 * (gamma + 1.0));
        let sum_fy_vol: f64 = model.anisotropy.iter().map(|a| pk * (1.0 + a)).sum();
        let w0 =
            bounding_volume * w * sum_fy_vol * (2.0 * std::f64::consts::PI * sigma2).powf(-1.5);
        let w0 = w0 / (1.0 - w + w0);
        let f_x = (1.0 - w0) / (w0 + TINY);
        let weight = |a: f64| f_x * pk * (1.0 + a).sqrt();
        let weight_max = model.anisotropy.iter().map(|&a| weight(a)).fold(0.0, f64::max);
        let centres = (0..k)
            .map(|i| {
                let c = model.centres[i] - origin;
                let n = model.normals[i];
                let a = model.anisotropy[i];
                let lc = c + n * (a * n.dot(&c));
                let f = weight(a);
                let log_weight = if f > 0.0 && weight_max.is_finite() {
                    (weight_max / f).ln()
                } else {
                    f64::INFINITY
                };
                Centre {
                    c: c.into(),
                    n: n.into(),
                    a,
                    log_weight,
                    row: [
                        a * n.x * n.x,
                        a * n.x * n.y,
                        a * n.x * n.z,
                        a * n.y * n.y,
                        a * n.y * n.z,
                        a * n.z * n.z,
                        lc.x,
                        lc.y,
                        lc.z,
                        c.dot(&lc),
                    ],
                }
            })
            .collect();
        Self { origin, centres, weight_max, bounding_volume }
    }

    /// The centres numbered in `keep`, with this mixture's origin and constants: one copy's
    /// share of it.
    pub fn subset(&self, keep: &[usize]) -> Self {
        Self {
            origin: self.origin,
            centres: keep.iter().map(|&k| self.centres[k]).collect(),
            weight_max: self.weight_max,
            bounding_volume: self.bounding_volume,
        }
    }

    /// CADCalib's outlier term of the posterior denominator at `sigma2`,
    /// `(2 pi sigma^2)^1.5 / (V + 1e-12)` (`e_step`, `bg`), plus its `1e-12` guard, in units
    /// of the largest centre weight.
    pub fn outlier_term(&self, sigma2: f64) -> f64 {
        let bg = (2.0 * std::f64::consts::PI * sigma2).powf(1.5) / (self.bounding_volume + TINY);
        if self.weight_max > 0.0 { (bg + TINY) / self.weight_max } else { f64::INFINITY }
    }
}

/// Largest exponent evaluated (`exp(-80)` is still a normal f32, so the terms stay clear of
/// subnormal numbers, which cost x86 a hundred cycles each); terms beyond it are 0. With the
/// default radius the exponents stay below 8.
const MAX_EXPONENT: f32 = 80.0;

/// Cells per search radius: a point's block spans `2 SUBDIVIDE + 1` cells per axis, so finer
/// cells fit the block closer to the ball (`(2.5 r)^3` here against `(3 r)^3` with cells of
/// `r`) but leave fewer points per cell to share gathering it.
const SUBDIVIDE: f64 = 2.0;

/// The centres binned into cubic cells of half the search radius, in cell order (x fastest):
/// the columns the exponents need as structure of arrays, the rest as rows.
pub(super) struct Grid {
    min: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// Cells from a point's cell to the farthest one its ball can reach, per axis.
    reach: i64,
    /// Centres of cell `i` are entries `start[i]..start[i + 1]`.
    start: Vec<usize>,
    columns: Columns,
    rows: Vec<[f64; 10]>,
    radius: f64,
}

/// Position (x, y, z), normal (x, y, z), anisotropy and `ln(F_max / F_k)` of centres.
#[derive(Default)]
struct Columns([Vec<f64>; 8]);

/// The E-step's buffers, reused across points and iterations.
#[derive(Default)]
pub(super) struct Scratch {
    /// Points in cell order: (cell key, index).
    order: Vec<(u64, u32)>,
    /// The centres that may reach the points of one cell.
    block: Columns,
    block_rows: Vec<[f64; 10]>,
    /// One point's exponents, then its terms.
    terms: Vec<f32>,
}

impl Grid {
    pub fn new(mixture: &Mixture, radius: f64) -> Self {
        let centres = &mixture.centres;
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for c in centres {
            for i in 0..3 {
                min[i] = min[i].min(c.c[i]);
                max[i] = max[i].max(c.c[i]);
            }
        }
        let extent = [0, 1, 2].map(|i| max[i] - min[i]);
        let widest = extent.iter().fold(0.0f64, |m, e| m.max(*e));
        let mut cell = (radius / SUBDIVIDE).max(widest * 1e-9).max(1e-12);
        let dims = loop {
            let dims = extent.map(|e| (e / cell).floor() as usize + 1);
            match dims.iter().try_fold(1usize, |acc, d| acc.checked_mul(*d)) {
                Some(t) if t <= MAX_CELLS => break dims,
                // Grow the cells by the cube root of the excess (and a little more).
                Some(t) => cell *= (t as f64 / MAX_CELLS as f64).cbrt() * 1.01,
                None => cell *= 2.0,
            }
        };
        // A point in cell i lies in [i c, (i + 1) c), so its ball (radius r) reaches cells
        // i - ceil(r / c) ..= floor(i + 1 + r / c) <= i + ceil(r / c).
        let reach = ((radius / cell).ceil() as i64).max(1);
        let cell_of = |c: &Centre| {
            let idx =
                [0, 1, 2].map(|i| (((c.c[i] - min[i]) / cell).floor() as usize).min(dims[i] - 1));
            idx[0] + dims[0] * (idx[1] + dims[1] * idx[2])
        };
        // Counting sort by cell.
        let cells = dims[0] * dims[1] * dims[2];
        let mut start = vec![0usize; cells + 1];
        let index: Vec<usize> = centres.iter().map(cell_of).collect();
        for &i in &index {
            start[i + 1] += 1;
        }
        for i in 0..cells {
            start[i + 1] += start[i];
        }
        let mut next = start.clone();
        let mut order = vec![0usize; centres.len()];
        for (k, &i) in index.iter().enumerate() {
            order[next[i]] = k;
            next[i] += 1;
        }
        let sorted: Vec<&Centre> = order.iter().map(|&k| &centres[k]).collect();
        let column = |f: fn(&Centre) -> f64| sorted.iter().map(|c| f(c)).collect();
        let columns = Columns([
            column(|c| c.c[0]),
            column(|c| c.c[1]),
            column(|c| c.c[2]),
            column(|c| c.n[0]),
            column(|c| c.n[1]),
            column(|c| c.n[2]),
            column(|c| c.a),
            column(|c| c.log_weight),
        ]);
        let rows = sorted.iter().map(|c| c.row).collect();
        Self { min, cell, dims, reach, start, columns, rows, radius }
    }

    /// The responsibilities of every point `x` (relative to the origin) as [`Summary`]s
    /// (`w == 0`: no centre supports it); `outlier` is [`Mixture::outlier_term`]. Only centres
    /// within the grid's radius are evaluated, and of those only terms whose Mahalanobis
    /// distance is within the radius too; every other term is at most
    /// `exp(-radius^2 / (2 sigma^2))` of its centre's peak.
    ///
    /// Points are taken cell by cell: the centres that may reach a cell's points are gathered
    /// into one contiguous block, which each of them then scans in three plain loops.
    pub fn e_step(
        &self,
        x: &[Vector3<f64>],
        half_inv_sigma2: f64,
        outlier: f64,
        scratch: &mut Scratch,
        summaries: &mut [Summary],
    ) {
        // Cell coordinates, clamped a reach beyond the grid (farther out, no block), packed
        // into a sortable key.
        let coordinate = |p: &Vector3<f64>, i: usize| {
            let c = ((p[i] - self.min[i]) / self.cell).floor();
            let limit = (self.dims[i] as i64 + self.reach) as f64;
            (c.clamp(-(self.reach as f64) - 1.0, limit) as i64 + self.reach + 1) as u64
        };
        scratch.order.clear();
        scratch.order.extend(x.iter().enumerate().map(|(i, p)| {
            let key = coordinate(p, 0) | coordinate(p, 1) << 21 | coordinate(p, 2) << 42;
            (key, i as u32)
        }));
        scratch.order.sort_unstable();
        let order = std::mem::take(&mut scratch.order);
        for group in order.chunk_by(|a, b| a.0 == b.0) {
            let key = group[0].0;
            let cell = [0, 1, 2].map(|i| ((key >> (21 * i)) & 0x1f_ffff) as i64 - self.reach - 1);
            self.gather(cell, scratch);
            for &(_, i) in group {
                let i = i as usize;
                summaries[i] = self.point(&x[i], half_inv_sigma2, outlier, scratch);
            }
        }
        scratch.order = order;
    }

    /// Gathers the centres of the cells within `reach` of `cell` into the scratch block.
    fn gather(&self, cell: [i64; 3], scratch: &mut Scratch) {
        for column in &mut scratch.block.0 {
            column.clear();
        }
        scratch.block_rows.clear();
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for i in 0..3 {
            let (a, b) = (cell[i] - self.reach, cell[i] + self.reach);
            if b < 0 || a > self.dims[i] as i64 - 1 {
                return;
            }
            lo[i] = a.max(0) as usize;
            hi[i] = b.min(self.dims[i] as i64 - 1) as usize;
        }
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                let base = self.dims[0] * (iy + self.dims[1] * iz);
                let run = self.start[base + lo[0]]..self.start[base + hi[0] + 1];
                for (block, column) in scratch.block.0.iter_mut().zip(&self.columns.0) {
                    block.extend_from_slice(&column[run.clone()]);
                }
                scratch.block_rows.extend_from_slice(&self.rows[run]);
            }
        }
    }

    /// One point against the gathered block: its exponents, its terms (f32 lanes), their sums.
    fn point(
        &self,
        x: &Vector3<f64>,
        half_inv_sigma2: f64,
        outlier: f64,
        scratch: &mut Scratch,
    ) -> Summary {
        let n = scratch.block_rows.len();
        if n == 0 {
            return Summary::default();
        }
        let r2 = self.radius * self.radius;
        let [cx, cy, cz, nx, ny, nz, a, lw] = scratch.block.0.each_ref().map(|c| &c[..n]);
        scratch.terms.resize(n, 0.0);
        let terms = &mut scratch.terms[..n];
        let (px, py, pz) = (x[0], x[1], x[2]);
        // Exponents `m / (2 sigma^2) + ln(F_max / F_k)`, infinite past the radius (isotropic
        // or Mahalanobis). Plain loops over equal-length slices, which LLVM vectorises (SSE2
        // natively, simd128 in wasm32).
        for j in 0..n {
            let (dx, dy, dz) = (px - cx[j], py - cy[j], pz - cz[j]);
            let nd = nx[j] * dx + ny[j] * dy + nz[j] * dz;
            let m = dx * dx + dy * dy + dz * dz + a[j] * nd * nd;
            let e = m * half_inv_sigma2 + lw[j];
            terms[j] = (if m <= r2 { e } else { f64::INFINITY }) as f32;
        }
        for t in terms.iter_mut() {
            let e = *t;
            // The JRMPC kernel's exp (tested there), on the same range.
            let v = crate::jrmpc::exp_neg_f32(e.min(MAX_EXPONENT));
            *t = if e <= MAX_EXPONENT { v } else { 0.0 };
        }
        // The sums, zero terms included (cheaper than skipping them), in two sets of partial
        // sums combined in a fixed order, so consecutive terms do not wait on each other.
        let mut partial = [[0.0f64; 11]; 2];
        let rows = &scratch.block_rows[..n];
        let (t2, r2) = (terms.chunks_exact(2), rows.chunks_exact(2));
        for (&t, row) in t2.remainder().iter().zip(r2.remainder()) {
            add_term(&mut partial[0], t, row);
        }
        for (t, r) in t2.zip(r2) {
            add_term(&mut partial[0], t[0], &r[0]);
            add_term(&mut partial[1], t[1], &r[1]);
        }
        let sums: [f64; 11] = std::array::from_fn(|i| partial[0][i] + partial[1][i]);
        let s = sums[0];
        if s <= 0.0 {
            return Summary::default();
        }
        // CADCalib `e_step`: alpha = F_k exp(..) / (sum + bg + 1e-12), numerator and
        // denominator divided by F_max.
        let scale = 1.0 / (s + outlier);
        let w = s * scale;
        let t: [f64; 10] = std::array::from_fn(|i| sums[i + 1] * scale);
        Summary {
            w,
            m0: [w + t[0], t[1], t[2], w + t[3], t[4], w + t[5]],
            m1: [t[6], t[7], t[8]],
            m2: t[9],
        }
    }
}

/// Adds a term `t` with its centre's `row` to `sums` (the term itself, then `t row`).
#[inline(always)]
fn add_term(sums: &mut [f64; 11], t: f32, row: &[f64; 10]) {
    let t = f64::from(t);
    sums[0] += t;
    for (sum, v) in sums[1..].iter_mut().zip(row) {
        *sum += t * v;
    }
}

/// `[v]_x`, the cross-product matrix.
fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Gauss-Newton steps for one sensor's pose on `sum_ik r_ik (T y_i - c_k)^T Lambda_k (T y_i -
/// c_k)` with the responsibilities fixed: `points` are the sensor's raw points, `summaries`
/// their sums. The increment is a rotation `omega` about the origin then a shift `v`
/// (left-multiplied), damped by `damping` on the diagonal as CADCalib does
/// (`_solve_shared_extrinsics`); a step whose system cannot be solved is skipped (CADCalib:
/// zero delta).
pub(super) fn gauss_newton(
    pose: &mut Pose,
    origin: &Vector3<f64>,
    points: &[Vector3<f64>],
    summaries: &[Summary],
    steps: usize,
    damping: f64,
) {
    for _ in 0..steps {
        let mut h = Matrix6::<f64>::zeros();
        let mut g = Vector6::<f64>::zeros();
        let mut hrr = Matrix3::zeros();
        let mut hrt = Matrix3::zeros();
        let mut htt = Matrix3::zeros();
        let mut gr = Vector3::zeros();
        let mut gt = Vector3::zeros();
        for (y, summary) in points.iter().zip(summaries) {
            if summary.w <= 0.0 {
                continue;
            }
            let x = pose.transform_point(&(*y).into()).coords - origin;
            let m = summary.m0();
            // J = [-[x]_x, I]; grad = m0 x - m1; H = J^T m0 J, g = J^T grad.
            let grad = m * x - Vector3::from(summary.m1);
            let s = skew(&x);
            let sm = s * m;
            hrr -= sm * s;
            hrt += sm;
            htt += m;
            gr += x.cross(&grad);
            gt += grad;
        }
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&(0.5 * (hrr + hrr.transpose())));
        h.fixed_view_mut::<3, 3>(0, 3).copy_from(&hrt);
        h.fixed_view_mut::<3, 3>(3, 0).copy_from(&hrt.transpose());
        h.fixed_view_mut::<3, 3>(3, 3).copy_from(&htt);
        g.fixed_rows_mut::<3>(0).copy_from(&gr);
        g.fixed_rows_mut::<3>(3).copy_from(&gt);
        let system = h + Matrix6::identity() * damping;
        let Some(delta) = system.cholesky().map(|c| c.solve(&-g)) else {
            return;
        };
        if !delta.iter().all(|d| d.is_finite()) {
            return;
        }
        let omega = Vector3::new(delta[0], delta[1], delta[2]);
        let v = Vector3::new(delta[3], delta[4], delta[5]);
        let rotation = nalgebra::UnitQuaternion::from_scaled_axis(omega);
        // x' = R_omega (T y - o) + v + o.
        let step = Pose::from_parts((origin + v - rotation * origin).into(), rotation);
        *pose = step * *pose;
        if delta.norm() < STEP_DONE {
            return;
        }
    }
}

/// Bounding box volume (m^3) and squared diagonal (m^2) of the given points.
pub(super) fn bounding_box(points: impl Iterator<Item = Vector3<f64>>) -> (f64, f64) {
    let mut min = Vector3::repeat(f64::INFINITY);
    let mut max = Vector3::repeat(f64::NEG_INFINITY);
    for p in points {
        min = min.inf(&p);
        max = max.sup(&p);
    }
    let d = max - min;
    if !d.iter().all(|v| v.is_finite()) {
        return (0.0, 0.0);
    }
    (d.x * d.y * d.z, d.norm_squared())
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;

    /// The E-step of one point by brute force over every centre, in f64 with libm's exp,
    /// with the same cut (`m <= radius^2`).
    fn dense(mixture: &Mixture, x: &Vector3<f64>, sigma2: f64, radius: f64) -> Summary {
        let (mut s, mut sums) = (0.0, [0.0f64; 10]);
        for k in &mixture.centres {
            let d = x - Vector3::from(k.c);
            let nd = Vector3::from(k.n).dot(&d);
            let m = d.norm_squared() + k.a * nd * nd;
            if m <= radius * radius {
                let t = (-(m / (2.0 * sigma2) + k.log_weight)).exp();
                s += t;
                for (sum, v) in sums.iter_mut().zip(&k.row) {
                    *sum += t * v;
                }
            }
        }
        if s <= 0.0 {
            return Summary::default();
        }
        let scale = 1.0 / (s + mixture.outlier_term(sigma2));
        let (w, t) = (s * scale, sums.map(|v| v * scale));
        Summary {
            w,
            m0: [w + t[0], t[1], t[2], w + t[3], t[4], w + t[5]],
            m1: [t[6], t[7], t[8]],
            m2: t[9],
        }
    }

    /// The grid's sparse E-step equals the brute-force one over all centres, from a radius
    /// that spans a few cells to one that spans the whole model, for points on the surface,
    /// near it and far from it.
    #[test]
    fn sparse_e_step_matches_brute_force() {
        let mut rng = Pcg64::seed_from_u64(1);
        // Centres on three faces of a unit cube, with the faces' normals and mixed anisotropy.
        let mut centres = Vec::new();
        let mut normals = Vec::new();
        for i in 0..600 {
            let axis = i % 3;
            let mut p = Vector3::from_fn(|_, _| rng.random_range(0.0..1.0));
            p[axis] = 0.0;
            centres.push(p + Vector3::new(5.0, -2.0, 1.0));
            normals.push(Vector3::ith(axis, 1.0));
        }
        let anisotropy = (0..600).map(|i| [0.0, 30.0, 12.5][i % 3]).collect();
        let model = CadModel { centres, normals, anisotropy };
        let mixture = Mixture::new(&model, 0.1, 0.1, 3.0, 1.5);
        let points: Vec<Vector3<f64>> = (0..400)
            .map(|i| {
                let spread = [0.02, 0.3, 3.0][i % 3];
                model.centres[i] - mixture.origin
                    + Vector3::from_fn(|_, _| rng.random_range(-spread..spread))
            })
            .collect();
        let mut scratch = Scratch::default();
        let mut summaries = vec![Summary::default(); points.len()];
        for (sigma, radius) in [(0.02, 0.07), (0.05, 0.175), (0.3, 1.05), (2.0, 7.0)] {
            let grid = Grid::new(&mixture, radius);
            let sigma2: f64 = sigma * sigma;
            grid.e_step(
                &points,
                0.5 / sigma2,
                mixture.outlier_term(sigma2),
                &mut scratch,
                &mut summaries,
            );
            let mut supported = 0;
            for (x, got) in points.iter().zip(&summaries) {
                let want = dense(&mixture, x, sigma2, radius);
                supported += usize::from(want.w > 0.0);
                assert_eq!(got.w > 0.0, want.w > 0.0, "support at {x:?}");
                let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-5 * scale + 1e-300;
                assert!(close(got.w, want.w, want.w), "w {} against {}", got.w, want.w);
                let big = want.m0.iter().chain(&want.m1).fold(want.w, |m, v| m.max(v.abs()));
                for (g, w) in got.m0.iter().chain(&got.m1).zip(want.m0.iter().chain(&want.m1)) {
                    assert!(close(*g, *w, big), "{g} against {w}");
                }
                assert!(close(got.m2, want.m2, want.m2.abs().max(big)));
            }
            assert!(supported > 100 && supported < points.len() || radius > 5.0, "{supported}");
        }
    }
}
