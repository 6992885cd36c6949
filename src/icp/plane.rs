//! Point-to-plane factor (Chen & Medioni 1992): the residual is the distance of the mapped
//! source point from the tangent plane of its target match, `r = n^T (q - T p)`.

use nalgebra::{Matrix6, Point3, Vector3, Vector6};

use super::solver::{Factor, Pair};
use crate::se3::Pose;

/// Target points with their unit normals (zero normals contribute nothing), and source points.
pub(crate) struct PointToPlane<'a> {
    pub target: &'a [[f32; 3]],
    pub normals: &'a [Vector3<f64>],
    pub source: &'a [Vector3<f64>],
}

impl PointToPlane<'_> {
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
        for &pair in pairs {
            let r = self.residual(pair, t);
            // dr/d(omega, v) = -n^T [-R [p]x, R] = [(R^T n x p)^T, -(R^T n)^T].
            let rn = inverse * self.normals[pair.target];
            let w = rn.cross(&self.source[pair.source]);
            let j = Vector6::new(w.x, w.y, w.z, -rn.x, -rn.y, -rn.z);
            h.ger(1.0, &j, &j, 1.0);
            b.axpy(r, &j, 1.0);
            error += 0.5 * r * r;
        }
        (h, b, error)
    }

    fn error(&self, pairs: &[Pair], t: &Pose) -> f64 {
        pairs.iter().map(|&pair| 0.5 * self.residual(pair, t).powi(2)).sum()
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
        let mut factor = PointToPlane { target: &target, normals: &normals, source: &source };
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
}
