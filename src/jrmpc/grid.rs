//! Components binned by mean into a uniform grid, with their E-step constants stored in cell
//! order (structure of arrays), so the components near a cell are a few contiguous runs.
//!
//! Which components a point may skip follows from a bound on the mass it neglects: every
//! binned component outside the box of cells around the point is farther than `reach`, so the
//! skipped terms sum to at most `N = sum_k p_k Q_k^1.5 exp(-Q_k reach^2 / 2)` over the binned
//! components. `reach` is chosen so `N <= NEGLECTED * beta`, and the posterior denominator is
//! never below the outlier term `beta`, so no posterior moves by more than `NEGLECTED` of the
//! point's total. The widest components (above the 90th percentile of sigma) would make the
//! reach, and the box, as large as the scene: they are not binned and every point visits them.
//! By the same bound, a term whose exponent exceeds `ln(S / (NEGLECTED beta))`, `S` the sum of
//! all `p_k Q_k^1.5`, may be dropped inside the box too ([`Grid::cutoff`]); that also keeps
//! the lanes clear of subnormal numbers.

use nalgebra::Vector3;

use super::kernel::Block;
use super::model::Mixture;

/// Largest share of a point's posterior denominator the skipped components may hold.
pub const NEGLECTED: f64 = 1e-8;

/// At most this many grid cells; beyond it the cells grow.
const MAX_CELLS: usize = 1 << 18;

pub struct Grid {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// CSR over cells (x fastest): entries `start[c]..start[c + 1]` of the arrays below.
    start: Vec<usize>,
    /// Original component index of each entry; binned entries first, then the wide ones.
    pub order: Vec<usize>,
    /// Means; each block moves them to its own origin.
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    half_q: Vec<f64>,
    scale: Vec<f64>,
    /// Entries `wide..` are visited by every point.
    wide: usize,
    /// Largest exponent `Q_k d^2 / 2` worth evaluating.
    pub cutoff: f64,
}

impl Grid {
    /// Builds the grid for one iteration. `beta` is the outlier term of the posterior.
    pub fn new(mixture: &Mixture, beta: f64) -> Self {
        let k = mixture.len();
        let scale = mixture.peak_scales();
        let active: Vec<usize> = (0..k).filter(|&c| scale[c] > 0.0).collect();
        let mut sigmas: Vec<f64> = active.iter().map(|&c| mixture.variances[c].sqrt()).collect();
        sigmas.sort_by(f64::total_cmp);
        let sigma_binned = sigmas.get(sigmas.len() * 9 / 10).copied().unwrap_or(1.0);
        let (binned, wide): (Vec<usize>, Vec<usize>) =
            active.iter().partition(|&&c| mixture.variances[c].sqrt() <= sigma_binned);
        // With every binned term at most `scale_k exp(-reach^2 / (2 sigma_binned^2))`:
        // reach = sigma_binned sqrt(2 ln(S / (NEGLECTED beta))), S the sum of binned scales.
        let s: f64 = binned.iter().map(|&c| scale[c]).sum();
        let reach = sigma_binned * (2.0 * (s / (NEGLECTED * beta)).ln().max(0.0)).sqrt();
        let s_all: f64 = active.iter().map(|&c| scale[c]).sum();
        let cutoff = (s_all / (NEGLECTED * beta)).ln().max(0.0);

        let means = &mixture.means;
        let (lo, hi) = binned.iter().fold(
            (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)),
            |(lo, hi), &c| (lo.inf(&means[c]), hi.sup(&means[c])),
        );
        let (origin, extent) =
            if binned.is_empty() { (Vector3::zeros(), Vector3::zeros()) } else { (lo, hi - lo) };
        // Cells of half the reach: a point visits 5 cells a side.
        let mut cell = (reach / 2.0).max(1e-6);
        let dims = loop {
            let d = extent.map(|e| (e / cell).floor() as usize + 1);
            if d.iter().product::<usize>() <= MAX_CELLS {
                break [d.x, d.y, d.z];
            }
            cell *= 2.0;
        };
        let mut keyed: Vec<(usize, usize)> = binned
            .iter()
            .map(|&c| {
                let i = cell_of(&means[c], &origin, cell, &dims);
                (i[0] + dims[0] * (i[1] + dims[1] * i[2]), c)
            })
            .collect();
        keyed.sort_unstable();
        let mut start = vec![0usize; dims.iter().product::<usize>() + 1];
        for &(c, _) in &keyed {
            start[c + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let order: Vec<usize> = keyed.iter().map(|&(_, c)| c).chain(wide.iter().copied()).collect();
        let field = |f: &dyn Fn(usize) -> f64| order.iter().map(|&c| f(c)).collect();
        Self {
            origin,
            cell,
            dims,
            start,
            x: order.iter().map(|&c| means[c].x).collect(),
            y: order.iter().map(|&c| means[c].y).collect(),
            z: order.iter().map(|&c| means[c].z).collect(),
            half_q: field(&|c| 0.5 / mixture.variances[c]),
            scale: field(&|c| scale[c]),
            wide: keyed.len(),
            order,
            cutoff,
        }
    }

    /// The cell of `p` (unclamped: points may lie outside the grid).
    pub fn cell_key(&self, p: &Vector3<f64>) -> [i64; 3] {
        let s = (p - self.origin) / self.cell;
        [s.x.floor() as i64, s.y.floor() as i64, s.z.floor() as i64]
    }

    /// The centre of cell `key`: the origin of its block's coordinates, so that f32 holds
    /// differences of a few reaches instead of positions in the scene.
    pub fn cell_centre(&self, key: [i64; 3]) -> Vector3<f64> {
        self.origin
            + Vector3::new(key[0] as f64, key[1] as f64, key[2] as f64).add_scalar(0.5) * self.cell
    }

    /// Fills `block` with every component a point in cell `key` must visit: the binned ones
    /// in the 5 x 5 x 5 cells around it, then the wide ones, with means relative to
    /// `cell_centre(key)`. `entries` receives the grid entry (index into `order`) of each.
    pub fn gather(&self, key: [i64; 3], block: &mut Block, entries: &mut Vec<usize>) {
        block.clear();
        block.origin = self.cell_centre(key);
        entries.clear();
        let range = |i: usize| {
            let lo = (key[i] - 2).max(0);
            let hi = (key[i] + 2).min(self.dims[i] as i64 - 1);
            (lo as usize, hi as usize, lo <= hi)
        };
        let ((x0, x1, okx), (y0, y1, oky), (z0, z1, okz)) = (range(0), range(1), range(2));
        if okx && oky && okz && self.wide > 0 {
            for z in z0..=z1 {
                for y in y0..=y1 {
                    let row = self.dims[0] * (y + self.dims[1] * z);
                    self.push(self.start[row + x0]..self.start[row + x1 + 1], block, entries);
                }
            }
        }
        self.push(self.wide..self.order.len(), block, entries);
        block.pad();
    }

    fn push(&self, r: std::ops::Range<usize>, block: &mut Block, entries: &mut Vec<usize>) {
        let o = block.origin;
        block.x.extend(self.x[r.clone()].iter().map(|v| v - o.x));
        block.y.extend(self.y[r.clone()].iter().map(|v| v - o.y));
        block.z.extend(self.z[r.clone()].iter().map(|v| v - o.z));
        block.half_q.extend_from_slice(&self.half_q[r.clone()]);
        block.scale.extend_from_slice(&self.scale[r.clone()]);
        entries.extend(r);
    }
}

fn cell_of(p: &Vector3<f64>, origin: &Vector3<f64>, cell: f64, dims: &[usize; 3]) -> [usize; 3] {
    let s = (p - origin) / cell;
    std::array::from_fn(|i| (s[i].floor().max(0.0) as usize).min(dims[i] - 1))
}
