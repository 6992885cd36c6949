//! Plausibility of a reconstruction: fit the prior shape (cube or sphere) to the reconstructed
//! means. A good calibration reconstructs a crisp target of the right size; a poor one a blurred
//! or doubled shape, which shows as a large RMS or a wrong size.

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

use crate::jrmpc::Prior;

/// The fitted shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeFit {
    /// Prior-weighted RMS distance (m) of the means from the fitted surface.
    pub rms: f64,
    /// Fitted size (m): cube edge or sphere diameter.
    pub size: f64,
    /// Fitted centre (m).
    pub centre: [f64; 3],
    /// Share of the mixture's weight within 10% of the size from the surface.
    pub inlier_share: f64,
}

/// Fits the prior's shape to `means` weighted by `priors`. `None` for user-given means or when
/// no component holds data.
pub fn fit_prior(prior: &Prior, means: &[Vector3<f64>], priors: &[f64]) -> Option<ShapeFit> {
    let points: Vec<(Vector3<f64>, f64)> =
        means.iter().zip(priors).filter(|(_, w)| **w > 0.0).map(|(m, w)| (*m, *w)).collect();
    if points.len() < 4 {
        return None;
    }
    let total: f64 = points.iter().map(|(_, w)| w).sum();
    let centroid = points.iter().fold(Vector3::zeros(), |c, (m, w)| c + m * *w) / total;
    match prior {
        Prior::Cube { edge } => {
            // The cube's yaw in the scene is unknown: start from several and keep the best.
            (0..6)
                .map(|i| {
                    let yaw = i as f64 * 15f64.to_radians();
                    let start = [0.0, 0.0, yaw, centroid.x, centroid.y, centroid.z, edge / 2.0];
                    fit(&points, &start, cube_distance)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, p)| summary(&points, &p, cube_distance, 2.0 * p[6].abs()))
        }
        Prior::Sphere { radius } => {
            let start = [0.0, 0.0, 0.0, centroid.x, centroid.y, centroid.z, *radius];
            let (_, p) = fit(&points, &start, sphere_distance);
            Some(summary(&points, &p, sphere_distance, 2.0 * p[6].abs()))
        }
        Prior::Means(_) => None,
    }
}

/// Shape parameters: rotation vector (3), centre (3), half size (1).
type Params = [f64; 7];

fn local(p: &Params, x: &Vector3<f64>) -> Vector3<f64> {
    let r = Rotation3::new(Vector3::new(p[0], p[1], p[2]));
    r.inverse() * (x - Vector3::new(p[3], p[4], p[5]))
}

/// Signed distance from the surface of a cube of half edge `p[6]`.
fn cube_distance(p: &Params, x: &Vector3<f64>) -> f64 {
    let q = local(p, x).abs() - Vector3::repeat(p[6].abs());
    q.sup(&Vector3::zeros()).norm() + q.max().min(0.0)
}

fn sphere_distance(p: &Params, x: &Vector3<f64>) -> f64 {
    local(p, x).norm() - p[6].abs()
}

/// Iteratively reweighted Gauss-Newton (Cauchy weights, numeric Jacobian); returns the final
/// robust cost and parameters.
fn fit(
    points: &[(Vector3<f64>, f64)],
    start: &Params,
    dist: fn(&Params, &Vector3<f64>) -> f64,
) -> (f64, Params) {
    let mut p = *start;
    let scale = 0.1 * start[6].abs().max(1e-3);
    let cost = |p: &Params| {
        points.iter().map(|(x, w)| w * (1.0 + (dist(p, x) / scale).powi(2)).ln()).sum::<f64>()
    };
    for _ in 0..30 {
        let n = points.len();
        let mut j = DMatrix::zeros(n, 7);
        let mut r = DVector::zeros(n);
        for (i, (x, w)) in points.iter().enumerate() {
            let d = dist(&p, x);
            let sw = (w / (1.0 + (d / scale).powi(2))).sqrt();
            r[i] = sw * d;
            for k in 0..7 {
                let mut q = p;
                q[k] += 1e-6;
                j[(i, k)] = sw * (dist(&q, x) - d) / 1e-6;
            }
        }
        let jt = j.transpose();
        let h = &jt * &j + DMatrix::identity(7, 7) * 1e-9;
        let Some(step) = h.cholesky().map(|c| c.solve(&(-&jt * &r))) else { break };
        let next: Params = std::array::from_fn(|k| p[k] + step[k]);
        if !next.iter().all(|v| v.is_finite()) || cost(&next) > cost(&p) {
            break;
        }
        p = next;
        if step.norm() < 1e-9 {
            break;
        }
    }
    (cost(&p), p)
}

fn summary(
    points: &[(Vector3<f64>, f64)],
    p: &Params,
    dist: fn(&Params, &Vector3<f64>) -> f64,
    size: f64,
) -> ShapeFit {
    let total: f64 = points.iter().map(|(_, w)| w).sum();
    let (mut sq, mut inliers) = (0.0, 0.0);
    for (x, w) in points {
        let d = dist(p, x);
        sq += w * d * d;
        if d.abs() < 0.1 * size {
            inliers += w;
        }
    }
    ShapeFit {
        rms: (sq / total).sqrt(),
        size,
        centre: [p[3], p[4], p[5]],
        inlier_share: inliers / total,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jrmpc::init::{cube_surface, sphere_surface};

    #[test]
    fn recovers_a_rotated_cube_and_a_sphere() {
        let r = Rotation3::from_euler_angles(0.02, -0.03, 0.5);
        let c = Vector3::new(10.0, -1.0, 0.3);
        let means: Vec<_> =
            cube_surface(0.6, 300, 3).iter().map(|p| r * Vector3::from(*p) + c).collect();
        let fit = fit_prior(&Prior::Cube { edge: 0.5 }, &means, &vec![1.0; 300]).unwrap();
        assert!((fit.size - 0.6).abs() < 1e-3, "{fit:?}");
        assert!(fit.rms < 1e-3 && fit.inlier_share > 0.99, "{fit:?}");
        let means: Vec<_> =
            sphere_surface(0.3, 200).iter().map(|p| Vector3::from(*p) + c).collect();
        let fit = fit_prior(&Prior::Sphere { radius: 0.25 }, &means, &vec![1.0; 200]).unwrap();
        assert!((fit.size - 0.6).abs() < 1e-6 && fit.rms < 1e-6, "{fit:?}");
        assert!(fit_prior(&Prior::Means(vec![]), &means, &vec![1.0; 200]).is_none());
    }
}
