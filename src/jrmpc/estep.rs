//! E-step: posteriors of every point under every component, folded straight into the
//! sufficient statistics so nothing of size points x K is ever stored.
//!
//! Terms `exp(-x)` with `x` above [`NEGLIGIBLE_EXPONENT`] are skipped, and a uniform grid over
//! the means finds the components that can be within reach of a point, so late iterations
//! (small sigma) visit a few components per point instead of all K. Skipped terms are below
//! 1e-20 of a component's peak: even the largest peak a component can reach (variance floor
//! 1e-6 m^2, `Q^1.5 = 1e9`) then adds less than 1e-10 of the outlier term `beta`, so posteriors
//! agree with the dense sum to that order.

use nalgebra::{Matrix3, Vector3};

use super::model::{Mixture, ViewStats};

const NEGLIGIBLE_EXPONENT: f64 = 46.0;

/// At most this many grid cells; beyond it the cells grow.
const MAX_CELLS: usize = 1 << 18;

/// Per-component constants of the E-step and the lookup grid, rebuilt once per iteration.
pub struct EStepTerms {
    /// `p_k Q_k^1.5`.
    scale: Vec<f64>,
    /// `Q_k / 2`.
    half_q: Vec<f64>,
    /// Uniform outlier term `beta = gamma / (h (1 + gamma))`.
    beta: f64,
    grid: ComponentGrid,
}

impl EStepTerms {
    pub fn new(mixture: &Mixture, beta: f64) -> Self {
        let q: Vec<f64> = mixture.variances.iter().map(|v| 1.0 / v).collect();
        let scale: Vec<f64> =
            q.iter().zip(&mixture.priors).map(|(q, p)| p * q * q.sqrt()).collect();
        // Beyond this distance a component's term is negligible.
        let reach: Vec<f64> = mixture
            .variances
            .iter()
            .zip(&scale)
            .map(|(v, s)| if *s > 0.0 { (2.0 * NEGLIGIBLE_EXPONENT * v).sqrt() } else { -1.0 })
            .collect();
        let grid = ComponentGrid::new(&mixture.means, &reach);
        Self { scale, half_q: q.iter().map(|q| 0.5 * q).collect(), beta, grid }
    }
}

/// Components binned by mean into cubic cells, plus the few "wide" ones whose reach exceeds
/// `reach` (the 90th percentile), which every point visits.
struct ComponentGrid {
    origin: Vector3<f64>,
    cell: f64,
    /// Largest reach of a binned component (m).
    reach: f64,
    dims: [usize; 3],
    /// CSR layout: the components of cell `c` are `members[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    members: Vec<usize>,
    wide: Vec<usize>,
}

impl ComponentGrid {
    fn new(means: &[Vector3<f64>], reach: &[f64]) -> Self {
        let active: Vec<usize> = (0..means.len()).filter(|&k| reach[k] >= 0.0).collect();
        let mut reaches: Vec<f64> = active.iter().map(|&k| reach[k]).collect();
        reaches.sort_by(f64::total_cmp);
        let (lo, hi) = active.iter().fold(
            (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)),
            |(lo, hi), &k| (lo.inf(&means[k]), hi.sup(&means[k])),
        );
        let extent = if active.is_empty() { Vector3::zeros() } else { hi - lo };
        // Cells of half the binned reach: a point then visits a box of 2.5 reaches a side.
        let reach_binned = reaches.get(reaches.len() * 9 / 10).copied().unwrap_or(1.0).max(1e-9);
        let mut cell = reach_binned / 2.0;
        let dims = loop {
            let d = extent.map(|e| (e / cell).floor() as usize + 1);
            if d.iter().product::<usize>() <= MAX_CELLS {
                break [d.x, d.y, d.z];
            }
            cell *= 2.0;
        };
        let origin = if active.is_empty() { Vector3::zeros() } else { lo };
        let mut wide = Vec::new();
        let mut cell_of = Vec::with_capacity(active.len());
        for &k in &active {
            if reach[k] > reach_binned {
                wide.push(k);
            } else {
                let c = Self::clamp_index(&((means[k] - origin) / cell), &dims);
                cell_of.push((c[0] + dims[0] * (c[1] + dims[1] * c[2]), k));
            }
        }
        let mut start = vec![0usize; dims.iter().product::<usize>() + 1];
        for &(c, _) in &cell_of {
            start[c + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut members = vec![0; cell_of.len()];
        for &(c, k) in &cell_of {
            members[fill[c]] = k;
            fill[c] += 1;
        }
        Self { origin, cell, reach: reach_binned, dims, start, members, wide }
    }

    fn clamp_index(scaled: &Vector3<f64>, dims: &[usize; 3]) -> [usize; 3] {
        std::array::from_fn(|i| (scaled[i].floor().max(0.0) as usize).min(dims[i] - 1))
    }

    /// Calls `visit(k)` for every component that may reach `p`: the wide ones and those binned
    /// within `reach` of `p` along every axis.
    fn for_each_near(&self, p: &Vector3<f64>, mut visit: impl FnMut(usize)) {
        for &k in &self.wide {
            visit(k);
        }
        let s = (p - self.origin) / self.cell;
        let r = self.reach / self.cell;
        let range = |i: usize| {
            let lo = (s[i] - r).floor().max(0.0);
            let hi = (s[i] + r).floor().min(self.dims[i] as f64 - 1.0);
            (lo as usize, hi as usize, lo <= hi)
        };
        let ((x0, x1, okx), (y0, y1, oky), (z0, z1, okz)) = (range(0), range(1), range(2));
        if !(okx && oky && okz) {
            return;
        }
        for z in z0..=z1 {
            for y in y0..=y1 {
                let row = self.dims[0] * (y + self.dims[1] * z);
                for &k in &self.members[self.start[row + x0]..self.start[row + x1 + 1]] {
                    visit(k);
                }
            }
        }
    }
}

/// Accumulates the statistics of one view whose current transform is `(rotation, translation)`
/// (TPAMI 2018 eq. 9: `alpha_ik = a_ik / (sum_l a_il + beta)`, `a_ik = p_k Q_k^1.5
/// exp(-Q_k |R v_i + t - x_k|^2 / 2)`). `scratch` is reused across calls.
pub fn accumulate(
    points: &[Vector3<f64>],
    rotation: &Matrix3<f64>,
    translation: &Vector3<f64>,
    means: &[Vector3<f64>],
    terms: &EStepTerms,
    stats: &mut ViewStats,
    scratch: &mut Vec<(usize, f64)>,
) {
    for v in points {
        let p = rotation * v + translation;
        scratch.clear();
        let mut total = 0.0;
        terms.grid.for_each_near(&p, |c| {
            let x = terms.half_q[c] * (p - means[c]).norm_squared();
            if x < NEGLIGIBLE_EXPONENT {
                let a = terms.scale[c] * (-x).exp();
                total += a;
                scratch.push((c, a));
            }
        });
        if total == 0.0 {
            // Far from every component: all of the point's mass goes to the outlier class.
            continue;
        }
        let norm = 1.0 / (total + terms.beta);
        let v2 = v.norm_squared();
        for &(c, a) in scratch.iter() {
            let alpha = a * norm;
            stats.lambda[c] += alpha;
            stats.s1[c] += alpha * v;
            stats.s2[c] += alpha * v2;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dense sum the grid must reproduce.
    fn dense(points: &[Vector3<f64>], mixture: &Mixture, beta: f64) -> ViewStats {
        let mut st = ViewStats::zeros(mixture.len());
        for v in points {
            let a: Vec<f64> = (0..mixture.len())
                .map(|k| {
                    let q = 1.0 / mixture.variances[k];
                    mixture.priors[k]
                        * q.powf(1.5)
                        * (-0.5 * q * (v - mixture.means[k]).norm_squared()).exp()
                })
                .collect();
            let total: f64 = a.iter().sum::<f64>() + beta;
            for (k, a) in a.iter().enumerate() {
                st.lambda[k] += a / total;
                st.s1[k] += a / total * v;
                st.s2[k] += a / total * v.norm_squared();
            }
        }
        st
    }

    #[test]
    fn grid_matches_the_dense_sum() {
        // Components of very different widths, spread over 4 m, and points inside and outside.
        let k = 300;
        let means: Vec<_> = (0..k)
            .map(|i| {
                let f = i as f64;
                Vector3::new((f * 0.37).sin() * 2.0, (f * 0.11).cos() * 2.0, (f * 0.05).sin())
            })
            .collect();
        let variances: Vec<f64> = (0..k).map(|i| [1e-6, 1e-4, 4e-4, 0.01, 0.3][i % 5]).collect();
        let mut priors = vec![1.0 / (k as f64 * 1.1); k];
        priors[7] = 0.0; // a dropped component
        let mixture = Mixture { means: means.clone(), variances, priors };
        let points: Vec<_> = (0..2000)
            .map(|i| {
                let f = i as f64;
                means[i % k]
                    + Vector3::new((f * 1.3).sin(), (f * 0.7).cos(), (f * 2.1).sin())
                        * 0.05
                        * (i % 7) as f64
            })
            .collect();
        let terms = EStepTerms::new(&mixture, 0.05);
        let mut fast = ViewStats::zeros(k);
        accumulate(
            &points,
            &Matrix3::identity(),
            &Vector3::zeros(),
            &means,
            &terms,
            &mut fast,
            &mut Vec::new(),
        );
        let exact = dense(&points, &mixture, 0.05);
        for c in 0..k {
            assert!((fast.lambda[c] - exact.lambda[c]).abs() < 1e-9, "component {c}");
            assert!(
                (fast.s1[c] - exact.s1[c]).norm() < 1e-9 && (fast.s2[c] - exact.s2[c]).abs() < 1e-9
            );
        }
    }
}
