//! Point-to-plane factor (Chen & Medioni 1992): the residual is the distance of the mapped
//! source point from the tangent plane of its target match, `r = n^T (q - T p)`.

use nalgebra::{Matrix6, Point3, Vector3, Vector6};

use super::solver::{Factor, Pair, cauchy_weight};
use crate::se3::Pose;

/// Target points with their unit normals (zero normals contribute nothing), and source points.
pub(crate) struct PointToPlane<'a> {
    pub target: &'a [[f32; 3]],
    pub normals: &'a [Vector3<f64>],
    pub source: &'a [Vector3<f64>],
    /// Cauchy scale (m), or plain least squares.
    pub robust_scale: Option<f64>,
    /// Per pair, the robust weight of the last linearisation (IRLS); `error` reuses it.
    weights: Vec<f64>,
}

impl<'a> PointToPlane<'a> {
    pub fn new(
        target: &'a [[f32; 3]],
        normals: &'a [Vector3<f64>],
        source: &'a [Vector3<f64>],
        robust_scale: Option<f64>,
    ) -> Self {
        Self { target, normals, source, robust_scale, weights: Vec::new() }
    }

    fn residual(&self, pair: Pair, t: &Pose) -> f64 {
        let q = Vector3::from(self.target[pair.target].map(f64::from));
        let tp = t * Point3::from(self.source[pair.source]);
        self.normals[pair.target].dot(&(q - tp.coords))
    }
}

impl Factor for PointToPlane<'_> {
    fn linearize(&mut self, pairs: &[Pair], t: &Pose) -> (Matrix6<f64>, Vector6<f64>, f64) {
        let (mut h, mut b, mut error) = (Matrix6::zeros(), Vector6::zeros(), 0.0);
        let inverse = t.rotation.inverse();
        self.weights.clear();
        for &pair in pairs {
            let r = self.residual(pair, t);
            let weight = cauchy_weight(r, self.robust_scale);
            self.weights.push(weight);
            // dr/d(omega, v) = -n^T [-R [p]x, R] = [(R^T n x p)^T, -(R^T n)^T].
            let rn = inverse * self.normals[pair.target];
            let w = rn.cross(&self.source[pair.source]);
            let j = Vector6::new(w.x, w.y, w.z, -rn.x, -rn.y, -rn.z);
            h.ger(weight, &j, &j, 1.0);
            b.axpy(weight * r, &j, 1.0);
            error += 0.5 * weight * r * r;
        }
        (h, b, error)
    }

    fn error(&self, pairs: &[Pair], t: &Pose) -> f64 {
        pairs
            .iter()
            .zip(&self.weights)
            .map(|(&pair, w)| 0.5 * w * self.residual(pair, t).powi(2))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::icp::solver::retract;

    #[test]
    fn jacobian_matches_finite_differences() {
        let target = [[1.0f32, 2.0, 3.0]];
        let normals = [Vector3::new(0.0, 0.6, 0.8)];
        let source = [Vector3::new(0.5, -1.0, 2.0)];
        let mut factor = PointToPlane::new(&target, &normals, &source, None);
        let pair = Pair { source: 0, target: 0 };
        let t = crate::se3::pose_from_xyz_rpy([0.1, 0.2, -0.3], [0.3, -0.2, 0.5]);
        let (h, b, e) = factor.linearize(&[pair], &t);
        let r = factor.residual(pair, &t);
        assert!((e - 0.5 * r * r).abs() < 1e-12);
        assert!((e - factor.error(&[pair], &t)).abs() < 1e-12);
        let j = b / r;
        assert!((h - j * j.transpose()).abs().max() < 1e-9);
        let eps = 1e-7;
        for k in 0..6 {
            let mut delta = Vector6::zeros();
            delta[k] = eps;
            let numeric = (factor.residual(pair, &retract(&t, &delta)) - r) / eps;
            assert!((numeric - j[k]).abs() < 1e-6, "component {k}: {numeric} vs {}", j[k]);
        }
    }

    #[test]
    fn cauchy_weights_scale_the_normal_equations() {
        let target = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let normals = [Vector3::z(), Vector3::z()];
        let source = [Vector3::new(0.0, 0.0, 0.02), Vector3::new(1.0, 0.0, 0.5)];
        let pairs = [Pair { source: 0, target: 0 }, Pair { source: 1, target: 1 }];
        let t = Pose::identity();
        let (_, _, plain) =
            PointToPlane::new(&target, &normals, &source, None).linearize(&pairs, &t);
        let mut robust = PointToPlane::new(&target, &normals, &source, Some(0.02));
        let (_, _, weighted) = robust.linearize(&pairs, &t);
        assert!((plain - 0.5 * (0.02f64.powi(2) + 0.25)).abs() < 1e-7);
        // Weights 1/2 (r = scale) and 1/626 (r = 25 scale): the far match nearly vanishes.
        let expected = 0.5 * (0.5 * 0.02f64.powi(2) + 0.25 / 626.0);
        assert!((weighted - expected).abs() < 1e-7, "{weighted} vs {expected}");
        assert!((robust.error(&pairs, &t) - weighted).abs() < 1e-12);
    }
}
