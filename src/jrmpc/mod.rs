//! Joint registration of multiple point sets (JRMPC; Evangelidis & Horaud, TPAMI 2018), as
//! GMMCalib uses it: every view is registered to one Gaussian mixture that floats freely, and
//! the mixture ends up as a reconstruction of the scene the views share.
//!
//! The data are centred on their common centroid before EM and accumulated in f64, so the
//! expanded variance formula does not cancel with coordinates around 10 m; results are moved
//! back to the caller's frame.

mod em;
mod estep;
mod grid;
mod kernel;
pub mod model;
mod mstep;
pub mod wire;

use std::fmt;

use nalgebra::{Matrix3, Vector3};

pub use em::Em;
pub use kernel::exp_neg_f32;
pub use model::Mixture;

use crate::se3::Pose;
pub use model::ViewStats;

/// EM settings. Defaults are GMMCalib's, except the variance floor and the convergence test.
#[derive(Clone, Debug, PartialEq)]
pub struct EmSettings {
    /// Upper bound on EM iterations (GMMCalib runs exactly 100).
    pub max_iterations: usize,
    /// Stop once no view's transform relative to the first view's moves by more than this in
    /// one iteration: rotation in rad, translation in m (about the data centroid). 0 runs all
    /// `max_iterations`.
    pub tolerance: f64,
    /// Weight of the uniform outlier class relative to the mixture.
    pub gamma: f64,
    /// Added to every variance (m^2). The references use 1e-9; we floor sigma at 1 mm, ten
    /// times below LiDAR range noise so it never binds on real data, which keeps `Q^1.5` small
    /// enough for f32 arithmetic and stops a component collapsing onto a single point.
    pub variance_floor: f64,
    /// Re-estimate the mixing weights each iteration.
    pub update_priors: bool,
    /// Initial standard deviation of every component (m). `None`: the references' rule, the
    /// diagonal of the bounding box of all points and means.
    pub initial_sigma: Option<f64>,
    /// The exact E-step: every point against every component in f64 with libm's exp, every
    /// point every iteration (no multi-resolution). The reference the fast E-step (a grid with
    /// a bound on the neglected mass, SIMD lanes, a polynomial exp) is tested against, and the
    /// paper's method computed as it states it (`--exact`, `exact: true`). Slow.
    pub exact: bool,
    /// Threads sharing the E-step's views (native only; wasm runs one). Each view's sums are
    /// computed by one thread and combined in view order, so results do not depend on it.
    pub threads: usize,
    /// Multi-resolution EM: while the mixture is wide, each view's points are merged in cubes
    /// (each cube's mean standing for its points, with their count and spread; [`Em::cell`]).
    /// A Gaussian many cubes wide sees the cubes as it sees the points, and the first
    /// iterations, where every component reaches every point, are the costly ones. Off: every
    /// point every iteration (the reference).
    pub multiresolution: bool,
}

impl Default for EmSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-8,
            gamma: 0.1,
            variance_floor: 1e-6,
            update_priors: true,
            initial_sigma: None,
            exact: false,
            threads: 1,
            multiresolution: false,
        }
    }
}

/// What the progress callback sees after each iteration.
pub struct Iteration {
    /// 1-based iteration just completed.
    pub iteration: usize,
    /// `T_model_view` for every view, in the caller's frame.
    pub poses: Vec<Pose>,
    /// Mean component standard deviation (m).
    pub mean_sigma: f64,
    /// Largest transform change in this iteration (rad or m).
    pub max_change: f64,
}

/// The callback's answer: go on or stop now (cancel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    Continue,
    Stop,
}

/// Per-iteration figures, for convergence plots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterationStats {
    pub mean_sigma: f64,
    pub max_change: f64,
    /// Gaussian terms the E-step evaluated (a dense E-step: points x K).
    pub terms: u64,
}

/// The outcome of a registration.
#[derive(Clone, Debug)]
pub struct Registration {
    /// `T_model_view` per view: maps the view's points into the mixture's frame.
    pub poses: Vec<Pose>,
    /// The reconstructed scene, in the caller's frame.
    pub mixture: Mixture,
    /// Iterations run.
    pub iterations: usize,
    /// The tolerance was reached before `max_iterations`.
    pub converged: bool,
    /// The progress callback asked to stop.
    pub cancelled: bool,
    /// Views that lost all support at the last iteration; they kept their previous transform.
    pub unsupported: Vec<usize>,
    pub history: Vec<IterationStats>,
}

/// Why a registration could not start.
#[derive(Clone, Debug, PartialEq)]
pub enum JrmpcError {
    NoViews,
    NoComponents,
    /// A view with fewer than three points, or whose points all coincide.
    DegenerateView {
        view: usize,
        points: usize,
    },
    NonFinitePoint {
        view: usize,
        index: usize,
    },
    NonFiniteMean {
        index: usize,
    },
    InvalidSetting(&'static str),
}

impl fmt::Display for JrmpcError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoViews => write!(f, "no views to register"),
            Self::NoComponents => write!(f, "the mixture needs at least one component"),
            Self::DegenerateView { view, points } => write!(
                f,
                "view {view} is degenerate ({points} points, need at least 3 distinct points)"
            ),
            Self::NonFinitePoint { view, index } => {
                write!(f, "view {view}: point {index} is not finite")
            }
            Self::NonFiniteMean { index } => write!(f, "initial mean {index} is not finite"),
            Self::InvalidSetting(what) => write!(f, "invalid setting: {what}"),
        }
    }
}

impl std::error::Error for JrmpcError {}

/// Registers `views` (points in a common, roughly aligned frame) jointly to a mixture that
/// starts at `initial_means`. `progress` runs after every iteration and may stop the run.
///
/// The loop of [`Em`] and [`Shards`] that a caller with its own workers drives step by step
/// (the browser's worker pool); with `settings.threads` > 1 the shards run on native threads.
pub fn register(
    views: &[&[[f32; 3]]],
    initial_means: &[[f64; 3]],
    settings: &EmSettings,
    mut progress: impl FnMut(&Iteration) -> Control,
) -> Result<Registration, JrmpcError> {
    let (mut em, points) = Em::start(views, initial_means, settings)?;
    let mut shards = Shards::new(points, settings.threads);
    while !em.finished() {
        shards.iterate(&mut em);
        if progress(&em.latest()) == Control::Stop {
            em.cancel();
        }
    }
    Ok(em.into_registration())
}

/// What every shard's E-step takes from EM for one iteration ([`Em::step`]).
#[derive(Clone, Copy, Debug)]
pub struct Step<'a> {
    pub mixture: &'a Mixture,
    pub beta: f64,
    /// Multi-resolution's cube edge ([`Em::cell`]); 0: every point.
    pub cell: f64,
    /// The exact E-step ([`EmSettings::exact`]).
    pub exact: bool,
}

/// The views split into contiguous [`Shard`]s, one per thread (native; one in wasm32), and
/// the statistics they fill.
pub struct Shards {
    shards: Vec<Shard>,
    /// Views per shard (the last may hold fewer).
    per: usize,
    stats: Vec<ViewStats>,
}

impl Shards {
    pub fn new(points: CentredViews, threads: usize) -> Self {
        let threads = crate::threads_here(threads);
        let per = points.len().div_ceil(threads.min(points.len()).max(1));
        let mut shards: Vec<Shard> = Vec::new();
        let mut points = points.into_iter().peekable();
        while points.peek().is_some() {
            shards.push(Shard::new(points.by_ref().take(per).collect()));
        }
        Self { shards, per, stats: Vec::new() }
    }

    /// One EM iteration: every shard's E-step (on threads when there are several), then
    /// `em`'s M-step with all the views' statistics in view order.
    pub fn iterate(&mut self, em: &mut Em) {
        if self.stats.len() != em.transforms().len() {
            self.stats = em.empty_stats();
        }
        let step = em.step();
        let per = self.per.max(1);
        let jobs =
            self.shards.iter_mut().zip(self.stats.chunks_mut(per)).zip(em.transforms().chunks(per));
        let terms = if jobs.len() == 1 {
            jobs.map(|((shard, st), t)| shard.e_step(&step, t, st)).sum()
        } else {
            std::thread::scope(|scope| {
                let handles: Vec<_> = jobs
                    .map(|((shard, st), t)| {
                        let step = &step;
                        scope.spawn(move || shard.e_step(step, t, st))
                    })
                    .collect();
                handles.into_iter().map(|h| h.join().expect("E-step thread")).sum()
            })
        };
        em.m_step(&self.stats, terms);
    }
}

/// Every view's points, centred on the views' common centroid: what the shards hold.
pub type CentredViews = Vec<Vec<Vector3<f64>>>;

/// A contiguous slice of the views (centred points) and the E-step's buffers: one per thread
/// or worker. Its statistics depend only on its own views and the mixture, never on the split.
pub struct Shard {
    views: Vec<Vec<Vector3<f64>>>,
    /// The coarse iterations' cube edge, and each view's points merged in cubes (`None`:
    /// the view's own points, when merging would not halve them).
    coarse: Option<(f64, Vec<Option<Cells>>)>,
    scratch: estep::Scratch,
    dense_terms: Vec<f64>,
}

/// A view's points merged in cubes (multi-resolution): each cube's mean, with the points it
/// stands for ([`estep::Weight`]).
struct Cells {
    means: Vec<Vector3<f64>>,
    weights: Vec<estep::Weight>,
}

/// A merged view keeps at least this many cubes (its transform's M-step): the edge halves
/// until it does.
const MIN_VIEW_CELLS: usize = 64;
/// Halvings of the edge tried before a view keeps its own points.
const MAX_HALVINGS: u32 = 20;

impl Cells {
    /// `points` merged in cubes of at most `edge`, or `None` when that would not halve them
    /// while keeping [`MIN_VIEW_CELLS`] (as with a view of fewer distinct places than that:
    /// no edge gives it enough cubes, so the halving stops after a millionth of `edge`).
    fn merged(points: &[Vector3<f64>], edge: f64) -> Option<Self> {
        if points.len() < 2 * MIN_VIEW_CELLS {
            return None;
        }
        (0..MAX_HALVINGS).find_map(|h| {
            let cells = Self::of(points, edge / f64::from(1u32 << h));
            if 2 * cells.means.len() > points.len() {
                return Some(None);
            }
            (cells.means.len() >= MIN_VIEW_CELLS).then_some(Some(cells))
        })?
    }

    /// `points` merged in the cubes of edge `edge` (aligned on the centred frame's origin),
    /// in the cubes' order: the same on every run.
    fn of(points: &[Vector3<f64>], edge: f64) -> Self {
        let mut keyed: Vec<([i64; 3], usize)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (std::array::from_fn(|a| (p[a] / edge).floor() as i64), i))
            .collect();
        keyed.sort_unstable();
        let (mut means, mut weights) = (Vec::new(), Vec::new());
        for cube in keyed.chunk_by(|a, b| a.0 == b.0) {
            let n = cube.len() as f64;
            let mean = cube.iter().map(|&(_, i)| points[i]).sum::<Vector3<f64>>() / n;
            let spread = cube.iter().map(|&(_, i)| (points[i] - mean).norm_squared()).sum::<f64>();
            means.push(mean);
            weights.push([n, spread / n]);
        }
        Self { means, weights }
    }
}

impl Shard {
    pub fn new(views: Vec<Vec<Vector3<f64>>>) -> Self {
        Self { views, coarse: None, scratch: estep::Scratch::new(), dense_terms: Vec::new() }
    }

    pub fn len(&self) -> usize {
        self.views.len()
    }

    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// Fills `stats` (one per view of the shard) from the views under `transforms` (likewise),
    /// with each view's points merged in cubes of edge `step.cell` when it is positive
    /// ([`Em::cell`]; smaller where a view would keep too few cubes, and none where merging
    /// would not halve its points); returns the Gaussian terms evaluated. Each view's cubes
    /// depend on its points alone, so the result does not depend on the split.
    pub fn e_step(
        &mut self,
        step: &Step,
        transforms: &[(Matrix3<f64>, Vector3<f64>)],
        stats: &mut [ViewStats],
    ) -> u64 {
        let Step { mixture, beta, cell, exact } = *step;
        stats.iter_mut().for_each(ViewStats::clear);
        if cell <= 0.0 {
            self.coarse = None;
        } else if self.coarse.as_ref().is_none_or(|(edge, _)| *edge != cell) {
            // A view left whole at a larger edge stays whole: smaller cubes merge less.
            let before = self.coarse.take().map(|(_, cells)| cells);
            let cells = self.views.iter().enumerate().map(|(v, points)| {
                let whole = before.as_ref().is_some_and(|b| b[v].is_none());
                if whole { None } else { Cells::merged(points, cell) }
            });
            self.coarse = Some((cell, cells.collect()));
        }
        let views: Vec<estep::Points> = (0..self.views.len())
            .map(|v| match self.coarse.as_ref().and_then(|(_, cells)| cells[v].as_ref()) {
                Some(cells) => estep::Points { at: &cells.means, weights: Some(&cells.weights) },
                None => estep::Points::plain(&self.views[v]),
            })
            .collect();
        if exact {
            let views = views.iter().zip(stats.iter_mut()).zip(transforms);
            return views
                .map(|((view, st), (r, t))| {
                    estep::dense(*view, r, t, mixture, beta, st, &mut self.dense_terms)
                })
                .sum();
        }
        let grid = grid::Grid::new(mixture, beta);
        estep::accumulate(&views, transforms, mixture, &grid, beta, stats, &mut self.scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A view of many points at few places has no edge that gives it enough cubes: it keeps
    /// its own points (the halving once ran for ever here). One of many places merges.
    #[test]
    fn a_view_of_few_places_keeps_its_points() {
        let few: Vec<Vector3<f64>> =
            (0..400).map(|i| Vector3::new((i % 2) as f64, 0.0, 0.0)).collect();
        assert!(Cells::merged(&few, 0.5).is_none());
        let many: Vec<Vector3<f64>> = (0..4000)
            .map(|i| Vector3::new((i % 100) as f64 * 0.01, (i / 100) as f64 * 0.01, 0.0))
            .collect();
        let cells = Cells::merged(&many, 0.04).expect("merges");
        // 4 cm cubes over a 1 m x 0.4 m sheet of 1 cm spacing: about 250, 16 points each.
        let n = cells.means.len();
        assert!((MIN_VIEW_CELLS..=2000).contains(&n) && n.abs_diff(250) < 30, "{n} cubes");
        let count: f64 = cells.weights.iter().map(|w| w[0]).sum();
        assert_eq!(count, 4000.0);
    }
}
