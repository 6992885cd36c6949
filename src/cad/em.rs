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
    /// CADCalib's `F_k`: the weight of the centre's Gaussian in the posterior numerator.
    f: f64,
    /// `Lambda_k c_k` with `Lambda_k = I + a_k n_k n_k^T`.
    lc: [f64; 3],
    /// `c_k^T Lambda_k c_k`.
    clc: f64,
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
        let centres = (0..k)
            .map(|i| {
                let c = model.centres[i] - origin;
                let n = model.normals[i];
                let a = model.anisotropy[i];
                let nc = n.dot(&c);
                let lc = c + n * (a * nc);
                Centre {
                    c: c.into(),
                    n: n.into(),
                    a,
                    f: f_x * pk * (1.0 + a).sqrt(),
                    lc: lc.into(),
                    clc: c.dot(&lc),
                }
            })
            .collect();
        Self { origin, centres, bounding_volume }
    }

    /// CADCalib's outlier term of the posterior denominator at `sigma2`:
    /// `(2 pi sigma^2)^1.5 / (V + 1e-12)` (`e_step`, `bg`).
    pub fn outlier_term(&self, sigma2: f64) -> f64 {
        (2.0 * std::f64::consts::PI * sigma2).powf(1.5) / (self.bounding_volume + TINY)
    }
}

/// The centres binned into cubic cells of at least the search radius, stored in cell order
/// (x fastest) so the centres near a point are a few contiguous runs.
pub(super) struct Grid {
    min: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// Centres of cell `i` are `centres[start[i]..start[i + 1]]`.
    start: Vec<usize>,
    centres: Vec<Centre>,
    radius: f64,
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
        let mut cell = radius.max(extent.iter().fold(0.0f64, |m, e| m.max(*e)) * 1e-9).max(1e-12);
        let dims = loop {
            let dims = extent.map(|e| (e / cell).floor() as usize + 1);
            let total = dims.iter().try_fold(1usize, |acc, d| acc.checked_mul(*d));
            match total {
                Some(t) if t <= MAX_CELLS => break dims,
                // Grow the cells by the cube root of the excess (and a little more).
                Some(t) => cell *= (t as f64 / MAX_CELLS as f64).cbrt() * 1.01,
                None => cell *= 2.0,
            }
        };
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
        let mut sorted = centres.clone();
        for (c, &i) in centres.iter().zip(&index) {
            sorted[next[i]] = *c;
            next[i] += 1;
        }
        Self { min, cell, dims, start, centres: sorted, radius }
    }

    /// The responsibilities of point `x` (relative to the origin) as a [`Summary`], and whether
    /// any centre supports it. Only centres within the grid's radius are evaluated, and of
    /// those only terms whose Mahalanobis distance is within the radius too; every other term
    /// is at most `exp(-radius^2 / (2 sigma^2))` of its centre's peak.
    pub fn e_step(&self, x: &Vector3<f64>, half_inv_sigma2: f64, outlier: f64) -> (Summary, bool) {
        let r = self.radius;
        let r2 = r * r;
        // Cell range per axis, clamped to the grid; empty when the ball misses it.
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for i in 0..3 {
            let a = ((x[i] - r - self.min[i]) / self.cell).floor();
            let b = ((x[i] + r - self.min[i]) / self.cell).floor();
            let top = (self.dims[i] - 1) as f64;
            if !(b >= 0.0 && a <= top) {
                return (Summary::default(), false);
            }
            lo[i] = a.max(0.0) as usize;
            hi[i] = b.min(top) as usize;
        }
        let (px, py, pz) = (x[0], x[1], x[2]);
        let mut s = 0.0;
        let mut nn = [0.0f64; 6];
        let mut m1 = [0.0f64; 3];
        let mut m2 = 0.0;
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                let base = self.dims[0] * (iy + self.dims[1] * iz);
                let run = self.start[base + lo[0]]..self.start[base + hi[0] + 1];
                for k in &self.centres[run] {
                    let (dx, dy, dz) = (px - k.c[0], py - k.c[1], pz - k.c[2]);
                    let d2 = dx * dx + dy * dy + dz * dz;
                    if d2 > r2 {
                        continue;
                    }
                    let nd = k.n[0] * dx + k.n[1] * dy + k.n[2] * dz;
                    let m = d2 + k.a * nd * nd;
                    if m > r2 {
                        continue;
                    }
                    let e = k.f * (-m * half_inv_sigma2).exp();
                    s += e;
                    let ea = e * k.a;
                    let [nx, ny, nz] = k.n;
                    nn[0] += ea * nx * nx;
                    nn[1] += ea * nx * ny;
                    nn[2] += ea * nx * nz;
                    nn[3] += ea * ny * ny;
                    nn[4] += ea * ny * nz;
                    nn[5] += ea * nz * nz;
                    m1[0] += e * k.lc[0];
                    m1[1] += e * k.lc[1];
                    m1[2] += e * k.lc[2];
                    m2 += e * k.clc;
                }
            }
        }
        if s <= 0.0 {
            return (Summary::default(), false);
        }
        // CADCalib `e_step`: alpha = F_k exp(..) / (sum + bg + 1e-12).
        let scale = 1.0 / (s + outlier + TINY);
        let summary = Summary {
            w: s * scale,
            m0: [
                (s + nn[0]) * scale,
                nn[1] * scale,
                nn[2] * scale,
                (s + nn[3]) * scale,
                nn[4] * scale,
                (s + nn[5]) * scale,
            ],
            m1: m1.map(|v| v * scale),
            m2: m2 * scale,
        };
        (summary, true)
    }
}

/// `[v]_x`, the cross-product matrix.
fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Gauss-Newton steps for one sensor's pose on `sum_ik r_ik (T y_i - c_k)^T Lambda_k (T y_i -
/// c_k)` with the responsibilities fixed: `points` and `summaries` are the sensor's raw points
/// and their sums. The increment is a rotation `omega` about the origin then a shift `v`
/// (left-multiplied), damped by `damping` on the diagonal as CADCalib does
/// (`_solve_shared_extrinsics`); a step whose system cannot be solved is skipped (CADCalib:
/// zero delta).
pub(super) fn gauss_newton(
    pose: &mut Pose,
    origin: &Vector3<f64>,
    points: impl Iterator<Item = (Vector3<f64>, Summary)> + Clone,
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
        for (y, summary) in points.clone() {
            if summary.w <= 0.0 {
                continue;
            }
            let x = pose.transform_point(&y.into()).coords - origin;
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
