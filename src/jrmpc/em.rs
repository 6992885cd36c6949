//! EM's state between E-steps and its M-step (TPAMI 2018, eq. 12-18), on data centred on the
//! views' common centroid (the expanded variance formula cancels badly at 10 m otherwise).

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::model::{Mixture, ViewStats};
use super::{CentredViews, EmSettings, Iteration, IterationStats, JrmpcError, Registration, mstep};
use crate::se3::Pose;

/// EM between E-steps: the mixture, the views' transforms and the history, on data centred on
/// the views' common centroid. Each iteration, the [`Shard`](super::Shard)s holding the views compute their
/// statistics against [`Em::mixture`], [`Em::beta`] and [`Em::transforms`], and
/// [`Em::m_step`] takes them all, in view order: so the result does not depend on how the views
/// were split, or where the shards ran.
pub struct Em {
    settings: EmSettings,
    centre: Vector3<f64>,
    mixture: Mixture,
    beta: f64,
    transforms: Vec<(Matrix3<f64>, Vector3<f64>)>,
    history: Vec<IterationStats>,
    unsupported: Vec<usize>,
    converged: bool,
    cancelled: bool,
    /// The next E-step's cube edge (m): each view's points merged in cubes; 0: every point.
    cell: f64,
}

/// The cubes' edge stays within this fraction of the mean sigma: a Gaussian that wide sees the
/// cubes' means, counts and spreads as it sees their points.
const EDGE_PER_SIGMA: f64 = 0.5;

impl Em {
    /// Checks the input and initialises (as jrmpc.m): identity transforms, every variance the
    /// squared diagonal of the bounding box of all points and means (or the given sigma),
    /// equal priors, a fixed outlier term. Also returns the views' points, centred, for the
    /// shards.
    pub fn start(
        views: &[&[[f32; 3]]],
        initial_means: &[[f64; 3]],
        settings: &EmSettings,
    ) -> Result<(Self, CentredViews), JrmpcError> {
        validate(views, initial_means, settings)?;
        let centre = common_centroid(views);
        let points: Vec<Vec<Vector3<f64>>> = views
            .iter()
            .map(|v| v.iter().map(|p| Vector3::from(p.map(f64::from)) - centre).collect())
            .collect();
        let means: Vec<Vector3<f64>> =
            initial_means.iter().map(|m| Vector3::from(*m) - centre).collect();
        let k = means.len();
        let variance = settings
            .initial_sigma
            .map_or_else(
                || bounding_box_diagonal_sq(points.iter().flatten().chain(&means)),
                |s| s * s,
            )
            .max(settings.variance_floor);
        let mixture = Mixture {
            means,
            variances: vec![variance; k],
            priors: vec![1.0 / (k as f64 * (1.0 + settings.gamma)); k],
        };
        let h = 2.0 * variance; // 2 / mean(Q)
        let mut em = Self {
            settings: settings.clone(),
            centre,
            mixture,
            beta: settings.gamma / (h * (1.0 + settings.gamma)),
            transforms: vec![(Matrix3::identity(), Vector3::zeros()); views.len()],
            history: Vec::new(),
            unsupported: Vec::new(),
            converged: false,
            cancelled: false,
            cell: f64::INFINITY,
        };
        em.cell = em.next_cell();
        Ok((em, points))
    }

    /// The mixture the next E-step evaluates (centred frame).
    pub fn mixture(&self) -> &Mixture {
        &self.mixture
    }

    /// The posterior's outlier term.
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// Each view's current transform (rotation, translation) in the centred frame.
    pub fn transforms(&self) -> &[(Matrix3<f64>, Vector3<f64>)] {
        &self.transforms
    }

    /// The next E-step merges each view's points in cubes of this edge (m; 0: every point).
    /// With [`EmSettings::multiresolution`], the largest power of two (in metres) within half
    /// the mean sigma, never larger than the last; the shards take smaller cubes where a view
    /// would keep too few, and its own points where merging would not halve them.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// What the shards' E-step takes for the next iteration.
    pub fn step(&self) -> super::Step<'_> {
        super::Step {
            mixture: &self.mixture,
            beta: self.beta(),
            cell: self.cell,
            exact: self.settings.exact,
        }
    }

    fn next_cell(&self) -> f64 {
        if !self.settings.multiresolution || self.settings.exact {
            return 0.0;
        }
        let edge = (EDGE_PER_SIGMA * self.mixture.mean_sigma()).log2().floor().exp2();
        edge.min(self.cell)
    }

    /// Zeroed statistics for every view, for the E-step to fill.
    pub fn empty_stats(&self) -> Vec<ViewStats> {
        vec![ViewStats::zeros(self.mixture.len()); self.transforms.len()]
    }

    /// Iterations done.
    pub fn iteration(&self) -> usize {
        self.history.len()
    }

    /// Converged, cancelled, or out of iterations.
    pub fn finished(&self) -> bool {
        self.converged || self.cancelled || self.iteration() >= self.settings.max_iterations
    }

    /// Ends the iteration whose E-step gave `stats` (every view's, in view order) after
    /// evaluating `terms` Gaussian terms: transforms, then the mixture.
    pub fn m_step(&mut self, stats: &[ViewStats], terms: u64) {
        self.unsupported.clear();
        let previous = self.transforms.clone();
        for (j, (st, current)) in stats.iter().zip(&mut self.transforms).enumerate() {
            match mstep::view_transform(st, &self.mixture, &current.0) {
                Some(next) => *current = next,
                None => self.unsupported.push(j),
            }
        }
        let max_change = relative_change(&previous, &self.transforms);
        let s = &self.settings;
        mstep::update_mixture(
            &mut self.mixture,
            stats,
            &self.transforms,
            s.gamma,
            s.variance_floor,
            s.update_priors,
        );
        let mean_sigma = self.mixture.mean_sigma();
        self.history.push(IterationStats { mean_sigma, max_change, terms });
        self.converged = max_change <= s.tolerance;
        self.cell = self.next_cell();
    }

    /// The last iteration, with the views' poses in the caller's frame.
    pub fn latest(&self) -> Iteration {
        let last = self.history.last().copied().unwrap_or(IterationStats {
            mean_sigma: self.mixture.mean_sigma(),
            max_change: f64::INFINITY,
            terms: 0,
        });
        Iteration {
            iteration: self.iteration(),
            poses: self.poses(),
            mean_sigma: last.mean_sigma,
            max_change: last.max_change,
        }
    }

    /// `T_model_view` per view, in the caller's frame.
    pub fn poses(&self) -> Vec<Pose> {
        self.transforms.iter().map(|rt| uncentred(rt, &self.centre)).collect()
    }

    /// Stops after the current iteration (unless it has converged: that takes precedence).
    pub fn cancel(&mut self) {
        self.cancelled = !self.converged;
    }

    /// The outcome, in the caller's frame.
    pub fn into_registration(mut self) -> Registration {
        let poses = self.poses();
        for m in &mut self.mixture.means {
            *m += self.centre;
        }
        Registration {
            poses,
            mixture: self.mixture,
            iterations: self.history.len(),
            converged: self.converged,
            cancelled: self.cancelled,
            unsupported: self.unsupported,
            history: self.history,
        }
    }
}

fn validate(
    views: &[&[[f32; 3]]],
    means: &[[f64; 3]],
    settings: &EmSettings,
) -> Result<(), JrmpcError> {
    if views.is_empty() {
        return Err(JrmpcError::NoViews);
    }
    if means.is_empty() {
        return Err(JrmpcError::NoComponents);
    }
    if let Some(index) = means.iter().position(|m| !m.iter().all(|c| c.is_finite())) {
        return Err(JrmpcError::NonFiniteMean { index });
    }
    if !(settings.gamma.is_finite() && settings.gamma > 0.0) {
        return Err(JrmpcError::InvalidSetting("gamma must be positive"));
    }
    if !(settings.variance_floor.is_finite() && settings.variance_floor > 0.0) {
        return Err(JrmpcError::InvalidSetting("variance_floor must be positive"));
    }
    if settings.threads == 0 {
        return Err(JrmpcError::InvalidSetting("threads must be at least 1"));
    }
    if !(settings.tolerance.is_finite() && settings.tolerance >= 0.0) {
        return Err(JrmpcError::InvalidSetting("tolerance must be zero or positive"));
    }
    for (view, points) in views.iter().enumerate() {
        if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(JrmpcError::NonFinitePoint { view, index });
        }
        let distinct = points.iter().any(|p| p != &points[0]);
        if points.len() < 3 || !distinct {
            return Err(JrmpcError::DegenerateView { view, points: points.len() });
        }
    }
    Ok(())
}

fn common_centroid(views: &[&[[f32; 3]]]) -> Vector3<f64> {
    let (sum, n) =
        views.iter().flat_map(|v| v.iter()).fold((Vector3::zeros(), 0usize), |(s, n), p| {
            (s + Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64), n + 1)
        });
    sum / n as f64
}

fn bounding_box_diagonal_sq<'a>(points: impl Iterator<Item = &'a Vector3<f64>>) -> f64 {
    let (lo, hi) = crate::cloud::bounds(points);
    (hi - lo).norm_squared()
}

/// Largest change, in one iteration, of any view's transform relative to the first view's:
/// rotation angle (rad) or translation (m). Relative, because the mixture floats: the views
/// and the model may keep drifting together long after every calibration has settled. With a
/// single view, its absolute change.
fn relative_change(
    before: &[(Matrix3<f64>, Vector3<f64>)],
    after: &[(Matrix3<f64>, Vector3<f64>)],
) -> f64 {
    let relative = |all: &[(Matrix3<f64>, Vector3<f64>)], j: usize| {
        let (r0, t0) = if all.len() > 1 { all[0] } else { (Matrix3::identity(), Vector3::zeros()) };
        let (r, t) = all[j];
        (r0.transpose() * r, r0.transpose() * (t - t0))
    };
    (0..after.len())
        .map(|j| {
            let (a, b) = (relative(before, j), relative(after, j));
            let rotation = Rotation3::from_matrix_unchecked(a.0.transpose() * b.0);
            rotation.angle().max((a.1 - b.1).norm())
        })
        .fold(0.0, f64::max)
}

/// A transform estimated on centred data (`p' = R (v - c) + t + c`) as a pose in the caller's
/// frame: translation `t + c - R c`.
fn uncentred((r, t): &(Matrix3<f64>, Vector3<f64>), centre: &Vector3<f64>) -> Pose {
    let rotation = UnitQuaternion::from_matrix(r);
    let translation = t + centre - rotation * centre;
    Isometry3::from_parts(Translation3::from(translation), rotation)
}
