//! The ICP loop shared by all metrics: match every source point to its nearest target point
//! within range, let a [`Step`] propose the next `T_target_source`, stop when the update is small.
//! Also the Levenberg-Marquardt step on SE(3) over any linearisable [`Factor`] (small_gicp's
//! `LevenbergMarquardtOptimizer`).

use nalgebra::{Matrix6, Point3, Translation3, UnitQuaternion, Vector3, Vector6};

use super::kdtree::{KdTree, sq_distance};
use super::{Alignment, IcpError, IcpSettings};
use crate::se3::Pose;

/// A correspondence: source point index, target point index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Pair {
    pub source: usize,
    pub target: usize,
}

/// Proposes the next `T_target_source` from the correspondences found at the current one.
pub(crate) trait Step {
    /// `Err` carries the reason when the correspondences cannot determine a pose.
    fn next(&mut self, pairs: &[Pair], t: &Pose) -> Result<Pose, &'static str>;
}

/// Residuals of correspondences, linearised with respect to a right perturbation
/// `T * exp(delta)`, `delta = (omega, v)`, retracted as rotation `exp(omega)`, translation `v`.
pub(crate) trait Factor {
    /// At `t`: `H = sum J^T W J`, `b = sum J^T W r` and the error `sum r^T W r / 2`.
    fn linearize(&mut self, pairs: &[Pair], t: &Pose) -> (Matrix6<f64>, Vector6<f64>, f64);
    /// The error at `t` of the pairs last linearised (with the weights fixed then).
    fn error(&self, pairs: &[Pair], t: &Pose) -> f64;
}

/// The Cauchy (Lorentzian) IRLS weight of a residual `r` for kernel `scale`; 1 without one.
pub(crate) fn cauchy_weight(r: f64, scale: Option<f64>) -> f64 {
    scale.map_or(1.0, |c| 1.0 / (1.0 + (r / c).powi(2)))
}

/// `T * exp(delta)` with the retraction the factors' Jacobians assume.
pub(crate) fn retract(t: &Pose, delta: &Vector6<f64>) -> Pose {
    let omega = Vector3::new(delta[0], delta[1], delta[2]);
    let v = Vector3::new(delta[3], delta[4], delta[5]);
    t * Pose::from_parts(Translation3::from(v), UnitQuaternion::from_scaled_axis(omega))
}

/// Levenberg-Marquardt with correspondences held fixed inside each outer iteration: solve
/// `(H + lambda I) delta = -b`, accept if the error does not grow (then lambda / 10), else
/// lambda * 10 and retry, at most `MAX_INNER` times.
pub(crate) struct LevenbergMarquardt<F> {
    factor: F,
    lambda: f64,
}

const INITIAL_LAMBDA: f64 = 1e-3;
const LAMBDA_FACTOR: f64 = 10.0;
const MAX_INNER: usize = 10;

impl<F: Factor> LevenbergMarquardt<F> {
    pub fn new(factor: F) -> Self {
        Self { factor, lambda: INITIAL_LAMBDA }
    }
}

impl<F: Factor> Step for LevenbergMarquardt<F> {
    fn next(&mut self, pairs: &[Pair], t: &Pose) -> Result<Pose, &'static str> {
        let (h, b, error) = self.factor.linearize(pairs, t);
        if !error.is_finite() {
            return Err("the error is not finite");
        }
        for _ in 0..MAX_INNER {
            let damped = h + Matrix6::identity() * self.lambda;
            let Some(delta) = damped.cholesky().map(|c| c.solve(&-b)) else {
                return Err("the normal equations are not positive definite");
            };
            if !delta.iter().all(|d| d.is_finite()) {
                return Err("the update is not finite");
            }
            let candidate = retract(t, &delta);
            let new_error = self.factor.error(pairs, &candidate);
            if new_error <= error {
                self.lambda /= LAMBDA_FACTOR;
                return Ok(candidate);
            }
            self.lambda *= LAMBDA_FACTOR;
        }
        // No step lowers the error for these correspondences: `t` is a fixed point.
        Ok(*t)
    }
}

/// Nearest-neighbour matching of source points into the target, warm-started: a point's
/// previous match, at its distance under the new pose, bounds the search, which then only
/// looks where a nearer point can be. The result is the same as an unbounded search.
struct Matcher<'a> {
    tree: &'a KdTree,
    target: &'a [[f32; 3]],
    previous: Vec<Option<usize>>,
}

impl<'a> Matcher<'a> {
    fn new(tree: &'a KdTree, target: &'a [[f32; 3]], source_len: usize) -> Self {
        Self { tree, target, previous: vec![None; source_len] }
    }

    /// Matches each source point, mapped by `t`, to its nearest target point within
    /// `max_distance` (m). Returns the sum of squared distances (m^2).
    fn correspond(
        &mut self,
        source: &[Vector3<f64>],
        t: &Pose,
        max_distance: f64,
        pairs: &mut Vec<Pair>,
    ) -> f64 {
        pairs.clear();
        let max_sq = max_distance * max_distance;
        let mut sum_sq = 0.0;
        for (i, p) in source.iter().enumerate() {
            let q = t * Point3::from(*p);
            let q = [q.x, q.y, q.z];
            let bound =
                self.previous[i].map_or(max_sq, |j| sq_distance(q, self.target[j]).min(max_sq));
            self.previous[i] = self.tree.nearest_within_sq(q, bound).map(|nb| {
                pairs.push(Pair { source: i, target: nb.index });
                sum_sq += nb.sq_distance;
                nb.index
            });
        }
        sum_sq
    }
}

/// Fewest correspondences that determine a rigid transform.
pub(crate) const MIN_PAIRS: usize = 3;

/// Runs ICP from `init` (`tree` is built over `target`) until the update is below both
/// tolerances or `max_iterations` is reached.
pub(crate) fn run(
    tree: &KdTree,
    target: &[[f32; 3]],
    source: &[Vector3<f64>],
    step: &mut dyn Step,
    init: &Pose,
    settings: &IcpSettings,
) -> Result<Alignment, IcpError> {
    let max_distance = settings.max_correspondence_distance;
    let mut t = *init;
    let mut pairs = Vec::with_capacity(source.len());
    let mut matcher = Matcher::new(tree, target, source.len());
    let mut converged = false;
    let mut iterations = 0;
    while iterations < settings.max_iterations && !converged {
        matcher.correspond(source, &t, max_distance, &mut pairs);
        if pairs.len() < MIN_PAIRS {
            return Err(IcpError::NoCorrespondences {
                found: pairs.len(),
                max_distance,
                iteration: iterations,
            });
        }
        let next = step
            .next(&pairs, &t)
            .map_err(|reason| IcpError::IllConditioned { iteration: iterations, reason })?;
        if !is_finite(&next) {
            return Err(IcpError::IllConditioned {
                iteration: iterations,
                reason: "the pose is not finite",
            });
        }
        let update = t.inverse() * next;
        converged = update.rotation.angle() < settings.rotation_tolerance
            && update.translation.vector.norm() < settings.translation_tolerance;
        t = next;
        iterations += 1;
    }
    // Score the final pose with fresh correspondences.
    let sum_sq = matcher.correspond(source, &t, max_distance, &mut pairs);
    if pairs.is_empty() {
        return Err(IcpError::NoCorrespondences { found: 0, max_distance, iteration: iterations });
    }
    Ok(Alignment {
        target_from_source: t,
        iterations,
        converged,
        inliers: pairs.len(),
        rmse: (sum_sq / pairs.len() as f64).sqrt(),
    })
}

/// True when every rotation and translation component is finite.
pub(crate) fn is_finite(pose: &Pose) -> bool {
    pose.translation.vector.iter().chain(pose.rotation.coords.iter()).all(|c| c.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warm_started_matching_equals_fresh_search() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        // A coarse grid makes equal distances (ties) common.
        let mut cloud = |n: usize| -> Vec<[f32; 3]> {
            (0..n).map(|_| std::array::from_fn(|_| rng.random_range(0..40) as f32 * 0.1)).collect()
        };
        let target = cloud(500);
        let source: Vec<Vector3<f64>> =
            cloud(300).iter().map(|p| Vector3::from(p.map(f64::from))).collect();
        let tree = KdTree::new(&target);
        let mut matcher = Matcher::new(&tree, &target, source.len());
        let mut pairs = Vec::new();
        for step in 0..6 {
            let s = step as f64;
            let t =
                crate::se3::pose_from_xyz_rpy([0.05 * s, -0.1 * s, 0.0], [0.0, 0.01 * s, -0.1 * s]);
            let sum = matcher.correspond(&source, &t, 0.3, &mut pairs);
            let mut expected = Vec::new();
            let mut expected_sum = 0.0;
            for (i, p) in source.iter().enumerate() {
                let q = t * Point3::from(*p);
                if let Some(nb) = tree.nearest_within([q.x, q.y, q.z], 0.3) {
                    expected.push(Pair { source: i, target: nb.index });
                    expected_sum += nb.sq_distance;
                }
            }
            assert_eq!(pairs, expected, "step {step}");
            assert_eq!(sum, expected_sum);
        }
    }

    #[test]
    fn retraction_matches_first_order_jacobian() {
        // d(T exp(delta) p)/d delta at 0 is [-R [p]x, R]: check by finite differences.
        let t = crate::se3::pose_from_xyz_rpy([0.3, -1.0, 2.0], [0.2, -0.4, 1.1]);
        let p = Vector3::new(1.5, -0.7, 0.25);
        let r = t.rotation.to_rotation_matrix().into_inner();
        let eps = 1e-7;
        for k in 0..6 {
            let mut delta = Vector6::zeros();
            delta[k] = eps;
            let moved = retract(&t, &delta) * Point3::from(p) - t * Point3::from(p);
            let unit = Vector3::from_fn(|i, _| if i == k % 3 { 1.0 } else { 0.0 });
            let expected = if k < 3 { r * unit.cross(&p) } else { r * unit };
            assert!((moved / eps - expected).norm() < 1e-6, "component {k}");
        }
    }
}
