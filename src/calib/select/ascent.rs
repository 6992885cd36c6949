//! Polishing a placement by climbing the selection score itself: iteratively reweighted
//! Gauss-Newton on the score's own point-to-surface correspondences (both ways, every other
//! sensor, the whole scans), each weighted as the score weighs it (a Gaussian of the
//! noise-scaled distance: the Welsch M-estimator, whose minimum is the score's maximum). The
//! widths start a few times the measured noise and shrink to it; a step is kept only when the
//! score rises, so the result never scores below its start and stays in its start's basin.

use nalgebra::{Matrix6, Point3, Translation3, UnitQuaternion, Vector3, Vector6};

use super::score::Scenes;
use super::surface::Surface;
use crate::se3::Pose;

/// Widths, in units of the measured noise, the climb passes through.
const ANNEAL: [f64; 3] = [4.0, 2.0, 1.0];
/// Gauss-Newton steps per width, at most.
const STEPS: usize = 8;
/// A step smaller than this (rad, m) ends a width.
const TINY: f64 = 1e-7;

/// The normal equations of one sensor's motion (a twist about `centre`, vehicle frame).
struct Normal {
    h: Matrix6<f64>,
    g: Vector6<f64>,
    centre: Vector3<f64>,
    /// Per class, the weight of its points' terms: one over the class's total.
    class_scale: [f64; 2],
}

impl Scenes {
    /// Sensor `s` moved from `poses[s]` (every sensor's `T_vehicle_sensor`) to where its score
    /// is highest nearby, the others held; `poses[s]` itself when no step raises the score.
    pub fn ascend(&self, s: usize, poses: &[Pose]) -> Pose {
        let mut at = poses.to_vec();
        let start = self.score(s, &at);
        let mut best = start.value();
        let class_scale = start.total.map(|t| if t > 0.0 { 1.0 / t } else { 0.0 });
        let centre = self.centre(s, &at[s]);
        for scale in ANNEAL {
            for _ in 0..STEPS {
                let mut normal =
                    Normal { h: Matrix6::zeros(), g: Vector6::zeros(), centre, class_scale };
                self.each_pair(s, &at, |source, target, t_target_source, moving_source, p_v| {
                    linearize(
                        source,
                        target,
                        t_target_source,
                        moving_source,
                        p_v,
                        scale,
                        &mut normal,
                    )
                });
                let Some(step) = normal.h.try_inverse().map(|inv| -(inv * normal.g)) else {
                    break;
                };
                let mut taken = false;
                let mut step = step;
                for _ in 0..4 {
                    let mut trial = at.clone();
                    trial[s] = twist(&step, &centre) * at[s];
                    let value = self.score(s, &trial).value();
                    if value > best {
                        (best, at, taken) = (value, trial, true);
                        break;
                    }
                    step *= 0.5;
                }
                if !taken || step.norm() < TINY {
                    break;
                }
            }
        }
        at[s]
    }

    /// The centroid (vehicle frame) of sensor `s`'s scored points at `pose`: the twist's pivot,
    /// so that rotation and translation stay apart far from the vehicle's origin.
    fn centre(&self, s: usize, pose: &Pose) -> Vector3<f64> {
        let mut sum = Vector3::zeros();
        let mut n = 0.0;
        for surface in self.surfaces_of(s) {
            for &i in &surface.samples {
                let p = surface.points[i].map(f64::from);
                sum += (pose * Point3::new(p[0], p[1], p[2])).coords;
                n += 1.0;
            }
        }
        if n > 0.0 { sum / n } else { pose.translation.vector }
    }
}

/// Adds to `normal` the terms of `source`'s samples on `target` (`t_target_source` maps one
/// into the other); `moving_source`: the moving sensor is the source (else the target), and
/// `pose_v` maps the source's frame into the vehicle's.
fn linearize(
    source: &Surface,
    target: &Surface,
    t_target_source: &Pose,
    moving_source: bool,
    pose_v: &Pose,
    scale: f64,
    normal: &mut Normal,
) {
    // The target's rotation into the vehicle frame: its normals there.
    let target_v = pose_v * t_target_source.inverse();
    for (k, &i) in source.samples.iter().enumerate() {
        let p = source.points[i].map(f64::from);
        let p = Point3::new(p[0], p[1], p[2]);
        let q = (t_target_source * p).coords;
        let Some(near) = target.tree.nearest_within([q.x, q.y, q.z], 1.0) else { continue };
        let j = near.index;
        if near.sq_distance.sqrt() > 2.0 * target.reach[j] as f64 {
            continue;
        }
        let Some(n) = target.normals[j] else { continue };
        let x = Vector3::from(target.points[j].map(f64::from));
        let e = n.dot(&(q - x));
        let sigma2 =
            ((source.noise[i] as f64).powi(2) + (target.noise[j] as f64).powi(2)) * scale * scale;
        // As the score weighs it: each class's share counts alike.
        let class = normal.class_scale[source.classes[k] as usize];
        let w = class * source.weights[k] * (-0.5 * e * e / sigma2).exp() / sigma2;
        let n_v = target_v.rotation * n;
        let y = (pose_v * p).coords - normal.centre;
        let sign = if moving_source { 1.0 } else { -1.0 };
        let c = y.cross(&n_v);
        let jac = Vector6::new(c.x, c.y, c.z, n_v.x, n_v.y, n_v.z) * sign;
        normal.h += jac * jac.transpose() * w;
        normal.g += jac * (w * e);
    }
}

/// The motion `exp(step)` about `centre`: rotation by `step[..3]` (rad, axis-angle), then a
/// shift by `step[3..]` (m).
fn twist(step: &Vector6<f64>, centre: &Vector3<f64>) -> Pose {
    let rotation = UnitQuaternion::from_scaled_axis(Vector3::new(step[0], step[1], step[2]));
    let shift = Vector3::new(step[3], step[4], step[5]);
    let t = centre - rotation * centre + shift;
    Pose::from_parts(Translation3::from(t), rotation)
}
