//! Components binned by mean into a uniform grid, with their E-step constants stored in cell
//! order (structure of arrays), so the components near a cell are a few contiguous runs.
//!
//! Which terms a point may skip follows from a bound on the mass it neglects: a term whose
//! exponent `Q_k d^2 / 2` exceeds `cutoff = ln(S / (NEGLECTED beta))`, `S` the sum of all peak
//! scales `p_k Q_k^1.5`, is below `p_k Q_k^1.5 NEGLECTED beta / S`, so all such terms together
//! hold at most `NEGLECTED beta`; the posterior denominator is never below the outlier term
//! `beta`, so no posterior moves by more than `NEGLECTED` of the point's total. Every term the
//! E-step does not evaluate, or evaluates as 0, is past that cutoff:
//! - binned components farther than `reach = sigma_binned sqrt(2 cutoff)` from a point's cell
//!   (outside the box of cells around it, or in a cell of the box whose nearest face is
//!   farther), `sigma_binned` the 90th percentile of sigma, the largest binned one;
//! - any other component whose exponent exceeds the cutoff at every point of the cell
//!   ([`Grid::gather`] tests each against the cell's cube);
//! - inside a block, terms past the cutoff (the kernel zeroes them, which also keeps the
//!   lanes clear of subnormal numbers).
//!
//! The widest components (above the 90th percentile) would make the reach, and the box, as
//! large as the scene: they are not binned and are tested for every cell.

use nalgebra::Vector3;

use super::kernel::Block;
use super::model::Mixture;
use crate::cloud::bounds;

/// Largest share of a point's posterior denominator the skipped components may hold.
pub const NEGLECTED: f64 = 1e-8;

/// Cells of `reach / SUBDIVIDE`: smaller cells fit the gathered blocks closer to their points
/// but leave fewer points per block to share the gathering.
const SUBDIVIDE: f64 = 2.0;

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
    scale: Vec<f32>,
    /// Entries `wide..` are visited by every point.
    wide: usize,
    /// Largest exponent `Q_k d^2 / 2` worth evaluating.
    pub cutoff: f64,
    /// `cutoff` with a margin for rounding: a component is gathered for a cell unless its
    /// exponent exceeds this at every point of the cell.
    cull: f64,
    /// Farther than this from a cell, no binned component is gathered for it.
    reach: f64,
    /// The box of cells around a cell spans this many cells each way (`reach / cell`).
    half_box: usize,
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
        let s: f64 = active.iter().map(|&c| scale[c]).sum();
        let cutoff = (s / (NEGLECTED * beta)).ln().max(0.0);
        // A margin for rounding: the kernel tests the exponent it computes against `cutoff`.
        let cull = cutoff * (1.0 + 1e-9);
        // Beyond it, every binned component's exponent exceeds `cull`.
        let reach = sigma_binned * (2.0 * cull).sqrt();

        let means = &mixture.means;
        let (lo, hi) = bounds(binned.iter().map(|&c| &means[c]));
        let (origin, extent) =
            if binned.is_empty() { (Vector3::zeros(), Vector3::zeros()) } else { (lo, hi - lo) };
        let mut cell = (reach / SUBDIVIDE).max(1e-6);
        // Counted in f64, which cannot wrap; an extent too large for f64 is one cell.
        let extent = if extent.iter().all(|e| e.is_finite()) { extent } else { Vector3::zeros() };
        let dims = loop {
            let d = extent.map(|e| (e / cell).floor() + 1.0);
            if d.iter().product::<f64>() <= MAX_CELLS as f64 {
                break [d.x as usize, d.y as usize, d.z as usize];
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
            scale: order.iter().map(|&c| scale[c] as f32).collect(),
            wide: keyed.len(),
            order,
            cutoff,
            cull,
            reach,
            half_box: (reach / cell).ceil() as usize,
        }
    }

    /// The cell of `p` (unclamped: points may lie outside the grid).
    pub fn cell_key(&self, p: &Vector3<f64>) -> [i64; 3] {
        let s = (p - self.origin) / self.cell;
        [floor(s.x), floor(s.y), floor(s.z)]
    }

    /// The centre of cell `key`: the origin of its block's coordinates, so that f32 holds
    /// differences of a few reaches instead of positions in the scene.
    pub fn cell_centre(&self, key: [i64; 3]) -> Vector3<f64> {
        self.origin
            + Vector3::new(key[0] as f64, key[1] as f64, key[2] as f64).add_scalar(0.5) * self.cell
    }

    /// Fills `block` with every component a point in cell `key` must visit: the binned ones
    /// within `reach` of the cell, then the wide ones, with means relative to
    /// `cell_centre(key)`, less those whose exponent exceeds the cutoff at every point of the
    /// cell. `entries[..block.len]` receive the grid entry (index into `order`) of each.
    pub fn gather(&self, key: [i64; 3], block: &mut Block, entries: &mut Vec<usize>) {
        block.start(self.order.len());
        block.origin = self.cell_centre(key);
        if entries.len() < self.order.len() {
            entries.resize(self.order.len(), 0);
        }
        // Gap between the cell and the cells `m` apart along an axis.
        let gap = |m: i64| (m.saturating_abs() - 1).max(0) as f64 * self.cell;
        let reach2 = self.reach * self.reach;
        let h = self.half_box as i64;
        let span = |i: usize, h: i64| {
            let lo = key[i].saturating_sub(h).max(0);
            let hi = key[i].saturating_add(h).min(self.dims[i] as i64 - 1);
            lo..=hi
        };
        if self.wide > 0 {
            for z in span(2, h) {
                let gz = gap(z.saturating_sub(key[2])).powi(2);
                for y in span(1, h) {
                    let left = reach2 - gz - gap(y.saturating_sub(key[1])).powi(2);
                    if left < 0.0 {
                        continue;
                    }
                    // Cells m apart along x are within reach while gap(m) <= sqrt(left).
                    let hx = ((left.sqrt() / self.cell).floor() as i64 + 1).min(h);
                    let xs = span(0, hx);
                    if xs.is_empty() {
                        continue;
                    }
                    let row = self.dims[0] * (y as usize + self.dims[1] * z as usize);
                    let (x0, x1) = (*xs.start() as usize, *xs.end() as usize);
                    self.push(self.start[row + x0]..self.start[row + x1 + 1], block, entries);
                }
            }
        }
        self.push(self.wide..self.order.len(), block, entries);
        block.pad();
    }

    /// Appends the entries `r` that pass the cull test to `block` and `entries` (branch-free:
    /// each is written, and kept by advancing the length).
    fn push(&self, r: std::ops::Range<usize>, block: &mut Block, entries: &mut [usize]) {
        let o = block.origin;
        let half = 0.5 * self.cell;
        // Squared distance from the cell (a cube about the origin) along one axis.
        let gap = |d: f64| {
            let g = (d.abs() - half).max(0.0);
            g * g
        };
        let mut n = block.len;
        for e in r {
            let (x, y, z) = (self.x[e] - o.x, self.y[e] - o.y, self.z[e] - o.z);
            block.x[n] = x;
            block.y[n] = y;
            block.z[n] = z;
            block.half_q[n] = self.half_q[e];
            block.scale[n] = self.scale[e];
            entries[n] = e;
            n += usize::from(self.half_q[e] * (gap(x) + gap(y) + gap(z)) <= self.cull);
        }
        block.len = n;
    }
}

/// `x.floor() as i64` without libm's `floor`, a call on x86-64 without SSE4.1.
#[inline]
fn floor(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(i64::from((t as f64) > x))
}

fn cell_of(p: &Vector3<f64>, origin: &Vector3<f64>, cell: f64, dims: &[usize; 3]) -> [usize; 3] {
    let s = (p - origin) / cell;
    std::array::from_fn(|i| (s[i].floor().max(0.0) as usize).min(dims[i] - 1))
}
