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
/// looks where a nearer point can be. A point left unmatched remembers how far the target was
/// (searched out to `FAR_REACH` times the match distance) and is not searched again until the
/// pose has moved it that far: converging ICP moves points by micrometres, and on a scene
/// that only partly overlaps most points are unmatched in every iteration. The result is the
/// same as an unbounded search. One matcher may serve several runs on the same clouds (the
/// stages of a staged registration): what it remembers holds whatever the match distance.
pub(crate) struct Matcher<'a> {
    tree: &'a KdTree,
    target: &'a [[f32; 3]],
    previous: Vec<Previous>,
}

/// What the last search found for one source point.
#[derive(Clone, Copy)]
enum Previous {
    Unknown,
    /// Its nearest target point.
    Matched(usize),
    /// No target point lies within `clear` (m) of where the point was, `at`.
    Far {
        at: [f64; 3],
        clear: f64,
    },
}

/// An unmatched point's search reaches this many match distances, to learn how far it may
/// move before it can match.
const FAR_REACH: f64 = 2.0;

impl<'a> Matcher<'a> {
    pub(crate) fn new(tree: &'a KdTree, target: &'a [[f32; 3]], source_len: usize) -> Self {
        Self { tree, target, previous: vec![Previous::Unknown; source_len] }
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
        let reach = FAR_REACH * max_distance;
        // Relative slack: `clear` and the step are square roots of rounded sums.
        let unreachable = max_distance * (1.0 + 1e-9);
        let mut sum_sq = 0.0;
        for (i, p) in source.iter().enumerate() {
            let q = t * Point3::from(*p);
            let q = [q.x, q.y, q.z];
            // A bound within the match distance holds the previous match, so a point is found;
            // beyond it, the nearest point within the reach says how far the target is.
            let bound = match self.previous[i] {
                Previous::Far { at, clear } if clear - distance(at, q) > unreachable => continue,
                Previous::Matched(j) => {
                    let d = sq_distance(q, self.target[j]);
                    if d <= max_sq { d } else { d.min(reach * reach) }
                }
                Previous::Far { .. } | Previous::Unknown => reach * reach,
            };
            self.previous[i] = match self.tree.nearest_within_sq(q, bound) {
                Some(nb) if nb.sq_distance <= max_sq => {
                    pairs.push(Pair { source: i, target: nb.index });
                    sum_sq += nb.sq_distance;
                    Previous::Matched(nb.index)
                }
                Some(nb) => Previous::Far { at: q, clear: nb.sq_distance.sqrt() },
                None => Previous::Far { at: q, clear: reach },
            };
        }
        sum_sq
    }
}

/// Euclidean distance (m) between two points.
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    nalgebra::distance(&Point3::from(a), &Point3::from(b))
}

/// Fewest correspondences that determine a rigid transform.
pub(crate) const MIN_PAIRS: usize = 3;

/// Runs ICP from `init` until the update is below both tolerances or `max_iterations` is
/// reached; `matcher` matches `source` into the target.
pub(crate) fn run(
    matcher: &mut Matcher,
    source: &[Vector3<f64>],
    step: &mut dyn Step,
    init: &Pose,
    settings: &IcpSettings,
) -> Result<Alignment, IcpError> {
    let max_distance = settings.max_correspondence_distance;
    let mut t = *init;
    let mut pairs = Vec::with_capacity(source.len());
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
        // Half the source lies beyond the target's edge, some within the unmatched points'
        // reach (twice the match distance), some beyond it.
        let source: Vec<Vector3<f64>> = cloud(300)
            .iter()
            .enumerate()
            .map(|(i, p)| Vector3::from(p.map(f64::from)) + Vector3::x() * (i % 2) as f64 * 4.1)
            .collect();
        let tree = KdTree::new(&target);
        let mut matcher = Matcher::new(&tree, &target, source.len());
        let mut pairs = Vec::new();
        // Large steps, then steps of micrometres to millimetres (where unmatched points are not
        // searched again), then a jump.
        let steps = [0.0, 1.0, 2.0, 2.0001, 2.001, 2.01, 2.0101, 2.5, 5.0, 5.00001];
        for (step, s) in steps.into_iter().enumerate() {
            let t =
                crate::se3::pose_from_xyz_rpy([0.05 * s, -0.1 * s, 0.0], [0.0, 0.01 * s, -0.1 * s]);
            // The match distance changes too, as between the stages of a staged registration.
            let max_distance = [0.3, 0.6, 0.1, 0.05][step % 4];
            let sum = matcher.correspond(&source, &t, max_distance, &mut pairs);
            let mut expected = Vec::new();
            let mut expected_sum = 0.0;
            for (i, p) in source.iter().enumerate() {
                let q = t * Point3::from(*p);
                if let Some(nb) = tree.nearest_within([q.x, q.y, q.z], max_distance) {
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
