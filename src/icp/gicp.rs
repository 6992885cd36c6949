//! Generalized-ICP factor (Segal, Haehnel & Thrun 2009, eq. 2): the residual `r = q - T p` is
//! weighted by the inverse of the combined covariance `C_t + R C_s R^T`, so each match is
//! judged by its distance across, not along, the two local surfaces.

use nalgebra::{Matrix3, Matrix3x6, Matrix6, Point3, Vector3, Vector6};

use super::solver::{Factor, Pair};
use crate::se3::Pose;

/// Target and source points with their (plane-regularised) covariances, m^2.
pub(crate) struct Gicp<'a> {
    pub target: &'a [[f32; 3]],
    pub target_covariances: &'a [Matrix3<f64>],
    pub source: &'a [Vector3<f64>],
    pub source_covariances: &'a [Matrix3<f64>],
}

impl Gicp<'_> {
    /// Residual `q - T p` and the Mahalanobis weight `(C_t + R C_s R^T)^-1`; `None` when the
    /// combined covariance cannot be inverted (the pair then contributes nothing).
    fn residual(&self, pair: Pair, t: &Pose) -> Option<(Vector3<f64>, Matrix3<f64>)> {
        let q = Vector3::from(self.target[pair.target].map(f64::from));
        let r = q - (t * Point3::from(self.source[pair.source])).coords;
        let rot = t.rotation.to_rotation_matrix().into_inner();
        let combined = self.target_covariances[pair.target]
            + rot * self.source_covariances[pair.source] * rot.transpose();
        let weight = combined.try_inverse()?;
        Some((r, weight))
    }
}

impl Factor for Gicp<'_> {
    fn error(&self, pair: Pair, t: &Pose) -> f64 {
        self.residual(pair, t).map_or(0.0, |(r, w)| 0.5 * r.dot(&(w * r)))
    }

    fn linearize(&self, pair: Pair, t: &Pose, h: &mut Matrix6<f64>, b: &mut Vector6<f64>) -> f64 {
        let Some((r, w)) = self.residual(pair, t) else {
            return 0.0;
        };
        // dr/d(omega, v) = -[-R [p]x, R] = [R [p]x, -R].
        let rot = t.rotation.to_rotation_matrix().into_inner();
        let mut j = Matrix3x6::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(rot * self.source[pair.source].cross_matrix()));
        j.fixed_view_mut::<3, 3>(0, 3).copy_from(&-rot);
        let jt_w = j.transpose() * w;
        *h += jt_w * j;
        *b += jt_w * r;
        0.5 * r.dot(&(w * r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::icp::solver::retract;

    #[test]
    fn gradient_matches_finite_differences() {
        let target = [[1.0f32, 2.0, 3.0]];
        let target_covariances = [Matrix3::new(1.0, 0.2, 0.0, 0.2, 0.8, 0.1, 0.0, 0.1, 0.01)];
        let source = [Vector3::new(0.5, -1.0, 2.0)];
        let source_covariances = [Matrix3::from_diagonal(&Vector3::new(1.0, 1e-3, 1.0))];
        let factor = Gicp {
            target: &target,
            target_covariances: &target_covariances,
            source: &source,
            source_covariances: &source_covariances,
        };
        let pair = Pair { source: 0, target: 0 };
        let t = crate::se3::pose_from_xyz_rpy([0.1, 0.2, -0.3], [0.3, -0.2, 0.5]);
        let (mut h, mut b) = (Matrix6::zeros(), Vector6::zeros());
        let e = factor.linearize(pair, &t, &mut h, &mut b);
        assert!((e - factor.error(pair, &t)).abs() < 1e-12);
        assert!((h - h.transpose()).abs().max() < 1e-9);
        // With the weight held fixed, d(0.5 r^T W r)/d delta = J^T W r = b.
        let (r0, w) = factor.residual(pair, &t).unwrap();
        let eps = 1e-7;
        for k in 0..6 {
            let mut delta = Vector6::zeros();
            delta[k] = eps;
            let moved = retract(&t, &delta);
            let r =
                Vector3::from(target[0].map(f64::from)) - (moved * Point3::from(source[0])).coords;
            let numeric = (0.5 * r.dot(&(w * r)) - 0.5 * r0.dot(&(w * r0))) / eps;
            assert!(
                (numeric - b[k]).abs() < 1e-4 * (1.0 + b[k].abs()),
                "component {k}: {numeric} vs {}",
                b[k]
            );
        }
    }
}
