//! Point-to-point ICP step (Besl & McKay 1992): the least-squares rigid transform between matched
//! points in closed form, by SVD of their cross-covariance (Arun et al. 1987) with Umeyama's
//! (1991) guard against reflections.

use nalgebra::{Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::solver::{Pair, Step};
use crate::se3::Pose;

/// Closed-form step: each iteration jumps straight to the best pose for its correspondences.
pub(crate) struct PointToPoint<'a> {
    pub target: &'a [[f32; 3]],
    pub source: &'a [Vector3<f64>],
}

impl Step for PointToPoint<'_> {
    fn next(&mut self, pairs: &[Pair], _t: &Pose) -> Result<Pose, &'static str> {
        let matched = pairs.iter().map(|pair| {
            (self.source[pair.source], Vector3::from(self.target[pair.target].map(f64::from)))
        });
        kabsch(matched).ok_or("the matched points are collinear")
    }
}

/// The pose `T` minimising `sum |q - T p|^2` over the `(p, q)` pairs; `None` when the pairs do
/// not determine a rotation (fewer than three, or all collinear or coincident).
pub fn kabsch(pairs: impl Iterator<Item = (Vector3<f64>, Vector3<f64>)> + Clone) -> Option<Pose> {
    let (mut n, mut sum_p, mut sum_q) = (0usize, Vector3::zeros(), Vector3::zeros());
    for (p, q) in pairs.clone() {
        n += 1;
        sum_p += p;
        sum_q += q;
    }
    if n < 3 {
        return None;
    }
    let (mean_p, mean_q) = (sum_p / n as f64, sum_q / n as f64);
    // Cross-covariance of the centred points.
    let mut cross = Matrix3::zeros();
    for (p, q) in pairs {
        cross += (q - mean_q) * (p - mean_p).transpose();
    }
    let svd = cross.try_svd(true, true, f64::EPSILON, 1000)?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let s = svd.singular_values; // descending
    // Rank 1 or less: a line of pairs leaves the rotation about it free.
    if s[0].is_nan() || s[1] <= 1e-9 * s[0] {
        return None;
    }
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let translation = mean_q - rotation * mean_p;
    Some(Pose::from_parts(Translation3::from(translation), rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::{angle_between, pose_from_xyz_rpy};
    use nalgebra::Point3;

    #[test]
    fn recovers_exact_pose_without_reflection() {
        let truth = pose_from_xyz_rpy([0.5, -2.0, 1.0], [0.4, -0.3, 2.5]);
        // A planar set: the reflection through the plane fits equally well and must be rejected.
        let source: Vec<Vector3<f64>> =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [3.0, 1.0, 0.0]]
                .map(Vector3::from)
                .to_vec();
        let pairs = source.iter().map(|p| (*p, (truth * Point3::from(*p)).coords));
        let got = kabsch(pairs).unwrap();
        assert!(angle_between(&got.rotation, &truth.rotation) < 1e-12);
        assert!((got.translation.vector - truth.translation.vector).norm() < 1e-12);
    }

    #[test]
    fn rejects_too_few_and_collinear_pairs() {
        let line: Vec<(Vector3<f64>, Vector3<f64>)> = (0..5)
            .map(|i| (Vector3::new(i as f64, 0.0, 0.0), Vector3::new(0.0, i as f64, 1.0)))
            .collect();
        assert!(kabsch(line.iter().copied()).is_none());
        assert!(kabsch(line.iter().take(2).copied()).is_none());
        let same = [(Vector3::new(1.0, 2.0, 3.0), Vector3::zeros()); 4];
        assert!(kabsch(same.iter().copied()).is_none());
    }
}
