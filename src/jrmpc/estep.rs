//! E-step: posteriors of every point under every component (TPAMI 2018 eq. 9:
//! `alpha_ik = a_ik / (sum_l a_il + beta)`, `a_ik = p_k Q_k^1.5 exp(-Q_k |R v_i + t - x_k|^2 / 2)`),
//! folded straight into the sufficient statistics so nothing of size points x K is stored.
//!
//! Two paths. [`dense`] evaluates every term in f64: the reference. [`accumulate`] is what runs:
//! the components a point can reach come from the [`Grid`] (with a bound on the neglected
//! mass), the points of a shard's views are sorted by grid cell (a counting sort) so each
//! cell's points share one contiguous block of components, gathered once for all views, and
//! the terms are evaluated in SIMD lanes with a polynomial exp in f32, two points at a time,
//! in block coordinates (about the block's cell); sums in f64.

use nalgebra::{Matrix3, Vector3};

use super::grid::Grid;
use super::kernel::{self, Accumulators, Block};
use super::model::{Mixture, ViewStats};

/// Points evaluated together against a block: 2 measured 3 % faster than 1 natively and 5 %
/// in wasm; 3 and 4 no faster than 2.
const GROUP: usize = 2;

/// Buffers reused across iterations.
pub struct Scratch {
    /// Per point: (cell, view, index into `transformed`).
    keyed: Vec<Keyed>,
    /// The counting sort's buffers.
    sorted: Vec<Keyed>,
    counts: Vec<u32>,
    transformed: Vec<Vector3<f64>>,
    /// Per transformed point: the points it stands for and their spread ([`Weight`]).
    weights: Vec<Weight>,
    /// Per view, per grid entry, the view's sums `[lambda, u_x, u_y, u_z, u2]` (see
    /// [`Accumulators::about_mean`]), `u = x_k - p` in the mixture's frame.
    sums: Vec<Vec<[f64; 5]>>,
    block: Block,
    entries: Vec<usize>,
    /// Terms of the points of a group.
    a: [Vec<f32>; GROUP],
    acc: Accumulators,
}

impl Scratch {
    pub fn new() -> Self {
        Self {
            keyed: Vec::new(),
            sorted: Vec::new(),
            counts: Vec::new(),
            transformed: Vec::new(),
            weights: Vec::new(),
            sums: Vec::new(),
            block: Block::default(),
            entries: Vec::new(),
            a: std::array::from_fn(|_| Vec::new()),
            acc: Accumulators::default(),
        }
    }
}

/// A point that stands for a cube of a view's points (multi-resolution): their count, and
/// their mean squared distance from it (the point is their mean). A plain point is `[1, 0]`.
pub type Weight = [f64; 2];

/// A view's points as an E-step takes them: its own, or its cubes' means with their
/// [`Weight`]s.
#[derive(Clone, Copy, Debug)]
pub struct Points<'a> {
    pub at: &'a [Vector3<f64>],
    pub weights: Option<&'a [Weight]>,
}

impl<'a> Points<'a> {
    /// A view's own points.
    pub fn plain(at: &'a [Vector3<f64>]) -> Self {
        Self { at, weights: None }
    }

    fn weight(&self, i: usize) -> Weight {
        self.weights.map_or([1.0, 0.0], |w| w[i])
    }
}

/// Adds each view's statistics to its `stats` (which the caller clears); view `v`'s current
/// transform is `transforms[v]` (rotation, translation). All views' points are sorted by grid
/// cell together, so a cell's block of components is gathered once for every view with
/// points in it; each view's sums still grow in the same order as on its own, so the result
/// does not depend on which views share a call. Returns the number of Gaussian terms
/// evaluated.
pub fn accumulate(
    views: &[Points],
    transforms: &[(Matrix3<f64>, Vector3<f64>)],
    mixture: &Mixture,
    grid: &Grid,
    beta: f64,
    stats: &mut [ViewStats],
    scratch: &mut Scratch,
) -> u64 {
    let Scratch { keyed, sorted, counts, transformed, weights: w, sums, block, entries, a, acc } =
        scratch;
    keyed.clear();
    transformed.clear();
    w.clear();
    for (v, (points, (rotation, translation))) in views.iter().zip(transforms).enumerate() {
        for (i, p) in points.at.iter().enumerate() {
            let p = rotation * p + translation;
            keyed.push((grid.cell_key(&p), v as u32, transformed.len() as u32));
            transformed.push(p);
            w.push(points.weight(i));
        }
    }
    sort_by_cell(keyed, sorted, counts);
    sums.resize_with(views.len(), Vec::new);
    for sum in sums.iter_mut() {
        sum.clear();
        sum.resize(grid.order.len(), [0.0; 5]);
    }
    let mut terms = 0u64;
    for cell in keyed.chunk_by(|a, b| a.0 == b.0) {
        grid.gather(cell[0].0, block, entries);
        a.iter_mut().for_each(|a| a.resize(block.padded, 0.0));
        let local = |i: u32| {
            let p = transformed[i as usize] - block.origin;
            [p.x, p.y, p.z]
        };
        let norm = |total: f64, i: u32| {
            if total > 0.0 { w[i as usize][0] / (total + beta) } else { 0.0 }
        };
        for run in cell.chunk_by(|a, b| a.1 == b.1) {
            acc.reset(block.padded);
            // A few points at a time: the block's columns and the accumulators pass through
            // the registers once for all of them.
            let mut groups = run.chunks_exact(GROUP);
            for group in &mut groups {
                let p: [[f64; 3]; GROUP] = std::array::from_fn(|j| local(group[j].2));
                let spread = std::array::from_fn(|j| w[group[j].2 as usize][1]);
                let totals = kernel::terms(block, p, grid.cutoff, a);
                acc.add(block, p, spread, a, std::array::from_fn(|j| norm(totals[j], group[j].2)));
            }
            for &(_, _, i) in groups.remainder() {
                let (p, one): (_, &mut [Vec<f32>; 1]) =
                    ([local(i)], (&mut a[..1]).try_into().expect("one"));
                let totals = kernel::terms(block, p, grid.cutoff, one);
                acc.add(block, p, [w[i as usize][1]], one, [norm(totals[0], i)]);
            }
            let view_sums = &mut sums[run[0].1 as usize];
            for (e, &entry) in entries[..block.len].iter().enumerate() {
                let sum = &mut view_sums[entry];
                for (total, add) in sum.iter_mut().zip(acc.about_mean(block, e)) {
                    *total += add;
                }
            }
        }
        terms += (cell.len() * block.len) as u64;
    }
    // Back to sums over untransformed points: with `m = R^T (x_k - t)` the mean in the view's
    // frame, `v = m - R^T u`.
    for ((view_sums, (rotation, translation)), stats) in sums.iter().zip(transforms).zip(stats) {
        let r_t = rotation.transpose();
        for (sum, &c) in view_sums.iter().zip(&grid.order) {
            let [l, ux, uy, uz, u2] = *sum;
            let m = r_t * (mixture.means[c] - translation);
            let u = r_t * Vector3::new(ux, uy, uz);
            stats.lambda[c] += l;
            stats.s1[c] += l * m - u;
            stats.s2[c] += l * m.norm_squared() - 2.0 * m.dot(&u) + u2;
        }
    }
    terms
}

/// A point: its cell, its view, its index into the transformed points.
type Keyed = ([i64; 3], u32, u32);

/// Sorts `keyed`, pushed in view-and-index order, as `sort_unstable` would (by cell, then
/// view and index): a counting sort over the cells of the points' bounding box, which keeps
/// the pushed order within a cell, when that box has at most a few cells per point; a
/// comparison sort otherwise.
fn sort_by_cell(keyed: &mut Vec<Keyed>, sorted: &mut Vec<Keyed>, counts: &mut Vec<u32>) {
    let Some(first) = keyed.first() else { return };
    let (lo, hi) = keyed.iter().fold((first.0, first.0), |(lo, hi), k| {
        (std::array::from_fn(|i| lo[i].min(k.0[i])), std::array::from_fn(|i| hi[i].max(k.0[i])))
    });
    // Checked: points far outside the grid (a transform gone wild) have keys near i64's ends.
    let span = |i: usize| {
        let d = usize::try_from(hi[i].checked_sub(lo[i])?).ok()?;
        d.checked_add(1)
    };
    let cells = span(0).zip(span(1)).zip(span(2)).and_then(|((x, y), z)| {
        let cells = x.checked_mul(y)?.checked_mul(z)?;
        Some((cells, [x, y, z]))
    });
    let Some((cells, dims)) = cells.filter(|&(c, _)| c <= (4 * keyed.len()).max(1 << 16)) else {
        keyed.sort_unstable();
        return;
    };
    // Lexicographic like the tuples: the last coordinate varies fastest.
    let linear = |k: &[i64; 3]| {
        let [x, y, z] = std::array::from_fn(|i| (k[i] - lo[i]) as usize);
        z + dims[2] * (y + dims[1] * x)
    };
    counts.clear();
    counts.resize(cells + 1, 0);
    for k in keyed.iter() {
        counts[linear(&k.0) + 1] += 1;
    }
    for c in 1..counts.len() {
        counts[c] += counts[c - 1];
    }
    sorted.clear();
    sorted.resize(keyed.len(), ([0; 3], 0, 0));
    for k in keyed.iter() {
        let slot = &mut counts[linear(&k.0)];
        sorted[*slot as usize] = *k;
        *slot += 1;
    }
    std::mem::swap(keyed, sorted);
}

/// The reference: every point against every component, in f64. Returns the terms evaluated.
pub fn dense(
    points: Points,
    rotation: &Matrix3<f64>,
    translation: &Vector3<f64>,
    mixture: &Mixture,
    beta: f64,
    stats: &mut ViewStats,
    a: &mut Vec<f64>,
) -> u64 {
    let k = mixture.len();
    let scale = mixture.peak_scales();
    for (i, v) in points.at.iter().enumerate() {
        let [count, spread] = points.weight(i);
        let p = rotation * v + translation;
        a.clear();
        a.extend((0..k).map(|c| {
            scale[c] * (-0.5 * (p - mixture.means[c]).norm_squared() / mixture.variances[c]).exp()
        }));
        let total: f64 = a.iter().sum();
        if total == 0.0 {
            continue;
        }
        let norm = count / (total + beta);
        let v2 = v.norm_squared() + spread;
        for (c, &a) in a.iter().enumerate() {
            let alpha = a * norm;
            stats.lambda[c] += alpha;
            stats.s1[c] += alpha * v;
            stats.s2[c] += alpha * v2;
        }
    }
    (points.at.len() * k) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_counting_sort_sorts_like_the_comparison_sort() {
        // Points as `accumulate` pushes them (views in order, indices rising) in a compact
        // cloud of cells (counting sort), then with one far point (comparison sort).
        for far in [false, true] {
            let mut keyed: Vec<Keyed> = (0..5000u32)
                .map(|i| {
                    let f = f64::from(i);
                    let cell = [(f * 0.37).sin(), (f * 0.11).cos(), (f * 0.05).sin()]
                        .map(|c| (c * 15.0).floor() as i64);
                    (cell, i / 1000, i)
                })
                .collect();
            if far {
                keyed.push(([1 << 40, -3, 5], 4, 5000));
            }
            let mut expected = keyed.clone();
            expected.sort_unstable();
            let (mut sorted, mut counts) = (Vec::new(), Vec::new());
            sort_by_cell(&mut keyed, &mut sorted, &mut counts);
            assert_eq!(keyed, expected);
            assert_eq!(counts.is_empty(), far, "the far point falls back to the comparison sort");
        }
    }

    #[test]
    fn fast_path_matches_the_dense_sum() {
        // Components of very different widths, spread over 4 m, and points inside and outside.
        let k = 300;
        let means: Vec<_> = (0..k)
            .map(|i| {
                let f = i as f64;
                Vector3::new((f * 0.37).sin() * 2.0, (f * 0.11).cos() * 2.0, (f * 0.05).sin())
            })
            .collect();
        // One in twenty is wide (0.5 m): unbinned, visited by every point.
        let variances: Vec<f64> = (0..k)
            .map(|i| if i % 20 == 0 { 0.25 } else { [1e-4, 4e-4, 1e-3, 0.01][i % 4] })
            .collect();
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
        let (rotation, translation) = (
            *nalgebra::Rotation3::from_euler_angles(0.01, -0.02, 0.03).matrix(),
            Vector3::new(0.01, 0.02, -0.01),
        );
        let beta = 0.05;
        let mut fast = ViewStats::zeros(k);
        let grid = Grid::new(&mixture, beta);
        let terms = accumulate(
            &[Points::plain(&points)],
            &[(rotation, translation)],
            &mixture,
            &grid,
            beta,
            std::slice::from_mut(&mut fast),
            &mut Scratch::new(),
        );
        assert!(terms < (points.len() * k) as u64, "the grid skips components");
        let mut exact = ViewStats::zeros(k);
        dense(
            Points::plain(&points),
            &rotation,
            &translation,
            &mixture,
            beta,
            &mut exact,
            &mut Vec::new(),
        );
        // Each point's skipped terms hold at most 1e-8 of its posterior denominator, and each
        // term it evaluates carries f32's relative error (about 1e-7), so its posteriors move
        // by at most about 1e-7 in all: summed over components, the statistics move by at
        // most that much of the point count (times |v|, |v|^2 for s1, s2). Measured: 6e-9.
        let n = points.len() as f64;
        let v1: f64 = points.iter().map(|v| v.norm()).sum();
        let v2: f64 = points.iter().map(|v| v.norm_squared()).sum();
        let d_lambda: f64 = (0..k).map(|c| (fast.lambda[c] - exact.lambda[c]).abs()).sum();
        let d_s1: f64 = (0..k).map(|c| (fast.s1[c] - exact.s1[c]).norm()).sum();
        let d_s2: f64 = (0..k).map(|c| (fast.s2[c] - exact.s2[c]).abs()).sum();
        println!("{:.1e} {:.1e} {:.1e}", d_lambda / n, d_s1 / v1, d_s2 / v2);
        assert!(d_lambda <= 1e-7 * n && d_s1 <= 1e-7 * v1 && d_s2 <= 1e-7 * v2);

        // Points that stand for cells of points (multi-resolution): the same agreement, on
        // sums that differ from the plain ones.
        let weights: Vec<Weight> =
            (0..points.len()).map(|i| [1.0 + (i % 5) as f64, 1e-4 * (i % 3) as f64]).collect();
        let mut fast_w = ViewStats::zeros(k);
        accumulate(
            &[Points { at: &points, weights: Some(&weights) }],
            &[(rotation, translation)],
            &mixture,
            &grid,
            beta,
            std::slice::from_mut(&mut fast_w),
            &mut Scratch::new(),
        );
        let mut exact_w = ViewStats::zeros(k);
        let (r, t) = (&rotation, &translation);
        let weighted = Points { at: &points, weights: Some(&weights) };
        dense(weighted, r, t, &mixture, beta, &mut exact_w, &mut Vec::new());
        let weight: f64 = weights.iter().map(|w| w[0]).sum();
        let (l_fast, l_exact) = (fast_w.support(), exact_w.support());
        assert!((l_fast - l_exact).abs() <= 1e-7 * weight && (l_fast - fast.support()).abs() > 1.0);
        let d_s2: f64 = (0..k).map(|c| (fast_w.s2[c] - exact_w.s2[c]).abs()).sum();
        assert!(d_s2 <= 1e-7 * 5.0 * (v2 + 1e-4 * n), "{d_s2}");
    }
}
