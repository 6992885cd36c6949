//! Generalized-ICP factor (Segal, Haehnel & Thrun 2009, eq. 2): the residual `r = q - T p` is
//! weighted by the inverse of the combined covariance `C_t + R C_s R^T`, so each match is
//! judged by its distance across, not along, the two local surfaces.

use nalgebra::{Matrix3, Matrix3x6, Matrix6, Point3, Vector3, Vector6};

use super::normals::PLANE_NORMAL;
use super::solver::{Factor, Pair, cauchy_weight};
use crate::se3::Pose;

/// Target and source points with their (plane-regularised) covariances, m^2.
pub(crate) struct Gicp<'a> {
    pub target: &'a [[f32; 3]],
    pub target_covariances: &'a [Matrix3<f64>],
    pub source: &'a [Vector3<f64>],
    pub source_covariances: &'a [Matrix3<f64>],
    /// Cauchy scale (m) on the distance across the surfaces, or plain least squares.
    pub robust_scale: Option<f64>,
    /// Per pair, the Mahalanobis weight of the last linearisation (times the robust weight);
    /// `error` reuses it, as small_gicp does, so each pair's combined covariance is inverted
    /// once per iteration.
    weights: Vec<Matrix3<f64>>,
}

impl<'a> Gicp<'a> {
    pub fn new(
        target: &'a [[f32; 3]],
        target_covariances: &'a [Matrix3<f64>],
        source: &'a [Vector3<f64>],
        source_covariances: &'a [Matrix3<f64>],
        robust_scale: Option<f64>,
    ) -> Self {
        let weights = Vec::new();
        Self { target, target_covariances, source, source_covariances, robust_scale, weights }
    }

    fn residual(&self, pair: Pair, t: &Pose) -> Vector3<f64> {
        let q = Vector3::from(self.target[pair.target].map(f64::from));
        q - (t * Point3::from(self.source[pair.source])).coords
    }
}

impl Factor for Gicp<'_> {
    fn linearize(&mut self, pairs: &[Pair], t: &Pose) -> (Matrix6<f64>, Vector6<f64>, f64) {
        let rot = t.rotation.to_rotation_matrix().into_inner();
        let (mut h, mut b, mut error) = (Matrix6::zeros(), Vector6::zeros(), 0.0);
        self.weights.clear();
        for &pair in pairs {
            let combined = self.target_covariances[pair.target]
                + rot * self.source_covariances[pair.source] * rot.transpose();
            // A combined covariance that cannot be inverted gives the pair no weight.
            let w = combined.try_inverse().unwrap_or_else(Matrix3::zeros);
            let r = self.residual(pair, t);
            // Two parallel plane covariances add to PLANE_NORMAL twice across the surface, so
            // this is about the distance across it, in metres, whatever the in-plane offset.
            let across = (2.0 * PLANE_NORMAL * r.dot(&(w * r))).max(0.0).sqrt();
            let w = w * cauchy_weight(across, self.robust_scale);
            self.weights.push(w);
            // dr/d(omega, v) = -[-R [p]x, R] = [R [p]x, -R].
            let mut j = Matrix3x6::zeros();
            j.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(rot * self.source[pair.source].cross_matrix()));
            j.fixed_view_mut::<3, 3>(0, 3).copy_from(&-rot);
            let jt_w = j.transpose() * w;
            h += jt_w * j;
            b += jt_w * r;
            error += 0.5 * r.dot(&(w * r));
        }
        (h, b, error)
    }

    fn error(&self, pairs: &[Pair], t: &Pose) -> f64 {
        pairs
            .iter()
            .zip(&self.weights)
            .map(|(&pair, w)| {
                let r = self.residual(pair, t);
                0.5 * r.dot(&(w * r))
            })
            .sum()
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
        let mut factor =
            Gicp::new(&target, &target_covariances, &source, &source_covariances, None);
        let pairs = [Pair { source: 0, target: 0 }];
        let t = crate::se3::pose_from_xyz_rpy([0.1, 0.2, -0.3], [0.3, -0.2, 0.5]);
        let (h, b, e) = factor.linearize(&pairs, &t);
        assert!((e - factor.error(&pairs, &t)).abs() < 1e-12);
        assert!((h - h.transpose()).abs().max() < 1e-9);
        // The weight is the inverse of C_t + R C_s R^T.
        let rot = t.rotation.to_rotation_matrix().into_inner();
        let combined = target_covariances[0] + rot * source_covariances[0] * rot.transpose();
        assert!((factor.weights[0] * combined - Matrix3::identity()).abs().max() < 1e-9);
        // With the weight held fixed, d(error)/d delta = J^T W r = b.
        let eps = 1e-7;
        for k in 0..6 {
            let mut delta = Vector6::zeros();
            delta[k] = eps;
            let numeric = (factor.error(&pairs, &retract(&t, &delta)) - e) / eps;
            let tolerance = 1e-4 * (1.0 + b[k].abs());
            assert!((numeric - b[k]).abs() < tolerance, "component {k}: {numeric} vs {}", b[k]);
        }
    }
}
