//! Plausibility of a reconstruction: fit the target's shape (cube or sphere) to the reconstructed
//! means. A good calibration reconstructs a crisp target of the right size; a poor one a blurred
//! or doubled shape, which shows as a large RMS or a wrong size.
//!
//! A scene may hold several targets on a ground (the paper's three cubes): [`fit_targets`] drops
//! the components on the ground, splits the rest into groups separated by gaps, and fits the
//! shape to each group. One shape fitted across all of them would measure nothing.

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

use super::Target;
use super::place::{ModelCloud, PlaceSettings};

/// The fitted shape.
/// Serialized as it is (camelCase) in the result's JSON.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ShapeFit {
    /// The shape fitted: `cube` or `sphere` ([`Target::kind`]).
    pub shape: &'static str,
    /// RMS distance (m) of the means from the fitted surface, weighted by the mixture's priors.
    pub rms: f64,
    /// Fitted size (m): cube edge, a box's largest edge or sphere diameter.
    pub size: f64,
    /// Fitted extents (m) along the shape's own axes: a box's three edges, else `size` thrice.
    pub extents: [f64; 3],
    /// Fitted centre (m).
    pub centre: [f64; 3],
    /// Fitted orientation: rotation vector (rad) from the shape's axes to the means' frame.
    pub rotation: [f64; 3],
    /// Share of the fitted components' weight within 10% of the size from the surface.
    pub inlier_share: f64,
    /// Share of the mixture's weight off the ground that this fit covers.
    pub weight: f64,
}

/// A group smaller than this share of the weight off the ground is clutter, not a target.
const MIN_TARGET_WEIGHT: f64 = 0.05;

/// The target's shape fitted to each target among `means` (weighted by the mixture's `priors`),
/// largest share first. Components within a tenth of the target's size of `ground`
/// (`normal . p + offset = 0`) are left out; the rest split where a gap wider than half the
/// target's size separates them.
pub fn fit_targets(
    target: &Target,
    means: &[Vector3<f64>],
    priors: &[f64],
    ground: Option<(Vector3<f64>, f64)>,
) -> Vec<ShapeFit> {
    let Some(size) = target.size() else { return Vec::new() };
    let kept: Vec<usize> = (0..means.len().min(priors.len()))
        .filter(|&k| priors[k] > 0.0)
        .filter(|&k| ground.is_none_or(|(n, d)| (n.dot(&means[k]) + d).abs() > 0.1 * size))
        .collect();
    let total: f64 = kept.iter().map(|&k| priors[k]).sum();
    let mut fits: Vec<ShapeFit> = groups(&kept, means, 0.5 * size)
        .into_iter()
        .filter_map(|group| {
            let weight = group.iter().map(|&k| priors[k]).sum::<f64>() / total;
            let members: Vec<Vector3<f64>> = group.iter().map(|&k| means[k]).collect();
            let weights: Vec<f64> = group.iter().map(|&k| priors[k]).collect();
            (weight >= MIN_TARGET_WEIGHT)
                .then(|| fit_shape(target, &members, &weights))
                .flatten()
                .map(|fit| ShapeFit { weight, ..fit })
        })
        .collect();
    fits.sort_by(|a, b| b.weight.total_cmp(&a.weight));
    fits
}

/// Single-linkage groups of `indices` (into `means`): two components share a group when a
/// chain of steps no longer than `gap` joins them (the placement's grouping, on these means).
fn groups(indices: &[usize], means: &[Vector3<f64>], gap: f64) -> Vec<Vec<usize>> {
    let points: Vec<[f32; 3]> = indices
        .iter()
        .map(|&k| [means[k].x as f32, means[k].y as f32, means[k].z as f32])
        .collect();
    super::place::groups(&points, gap)
        .into_iter()
        .map(|group| group.into_iter().map(|i| indices[i]).collect())
        .collect()
}

/// Fits the target's shape to `means` weighted by `priors`. `None` when fewer than four
/// components hold data.
pub fn fit_shape(target: &Target, means: &[Vector3<f64>], priors: &[f64]) -> Option<ShapeFit> {
    let points: Vec<(Vector3<f64>, f64)> =
        means.iter().zip(priors).filter(|(_, w)| **w > 0.0).map(|(m, w)| (*m, *w)).collect();
    if points.len() < 4 {
        return None;
    }
    let total: f64 = points.iter().map(|(_, w)| w).sum();
    let centroid = points.iter().fold(Vector3::zeros(), |c, (m, w)| c + m * *w) / total;
    match target {
        Target::Cube { .. } | Target::Box { .. } => {
            // Half extents `p[6] * aspect`: the shape is the given one's, its scale is fitted
            // (a cube's aspect is exactly 1 on every axis).
            let edges = match target {
                Target::Box { size } => *size,
                _ => [target.size().unwrap_or(0.0); 3],
            };
            let largest = edges.iter().copied().fold(0.0, f64::max);
            let aspect = Vector3::from(edges.map(|s| s / largest));
            let distance = move |p: &Params, x: &Vector3<f64>| {
                let q = local(p, x).abs() - aspect * p[6].abs();
                q.sup(&Vector3::zeros()).norm() + q.max().min(0.0)
            };
            // The target's yaw in the scene is unknown: start from several and keep the best.
            (0..6)
                .map(|i| {
                    let yaw = i as f64 * 15f64.to_radians();
                    let start = [0.0, 0.0, yaw, centroid.x, centroid.y, centroid.z, largest / 2.0];
                    fit(&points, &start, &distance)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, p)| summary(target, &points, &p, &distance, 2.0 * p[6].abs()))
        }
        Target::Sphere { diameter } => {
            let start = [0.0, 0.0, 0.0, centroid.x, centroid.y, centroid.z, 0.5 * diameter];
            let (_, p) = fit(&points, &start, &sphere_distance);
            Some(summary(target, &points, &p, &sphere_distance, 2.0 * p[6].abs()))
        }
        Target::Mesh(m) => {
            // The reconstruction's means as the placement's data: the rigid fit of the model
            // (not rescaled) from every yaw about +z, its base below the means' centroid.
            let size = target.size().unwrap_or(0.0);
            let settings = PlaceSettings { tolerance: 0.1 * size, ..PlaceSettings::default() };
            let model = ModelCloud::new(&m.mesh, &settings)?;
            let data: Vec<[f32; 3]> =
                points.iter().map(|(p, _)| p.map(|c| c as f32).into()).collect();
            let low = points.iter().map(|(p, _)| p.z).fold(f64::INFINITY, f64::min);
            let base = Vector3::new(centroid.x, centroid.y, low);
            let fit = model.best_fit(&data, &base, &Vector3::z(), &settings)?;
            let b = m.mesh.bounds();
            let extents: [f64; 3] = std::array::from_fn(|i| b.max[i] - b.min[i]);
            let middle =
                Vector3::from(std::array::from_fn::<f64, 3, _>(|i| 0.5 * (b.min[i] + b.max[i])));
            Some(ShapeFit {
                shape: target.kind(),
                rms: fit.rms,
                size,
                extents,
                centre: (fit.pose * nalgebra::Point3::from(middle)).coords.into(),
                rotation: fit.pose.rotation.scaled_axis().into(),
                inlier_share: fit.inliers,
                weight: 1.0,
            })
        }
        Target::None => None,
    }
}

/// Shape parameters: rotation vector (3), centre (3), half size (1).
type Params = [f64; 7];

fn local(p: &Params, x: &Vector3<f64>) -> Vector3<f64> {
    let r = Rotation3::new(Vector3::new(p[0], p[1], p[2]));
    r.inverse() * (x - Vector3::new(p[3], p[4], p[5]))
}

fn sphere_distance(p: &Params, x: &Vector3<f64>) -> f64 {
    local(p, x).norm() - p[6].abs()
}

/// Iteratively reweighted Gauss-Newton (Cauchy weights, numeric Jacobian); returns the final
/// robust cost and parameters.
fn fit(
    points: &[(Vector3<f64>, f64)],
    start: &Params,
    dist: &dyn Fn(&Params, &Vector3<f64>) -> f64,
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
    target: &Target,
    points: &[(Vector3<f64>, f64)],
    p: &Params,
    dist: &dyn Fn(&Params, &Vector3<f64>) -> f64,
    size: f64,
) -> ShapeFit {
    let total: f64 = points.iter().map(|(_, w)| w).sum();
    let extents = match target {
        Target::Box { size: edges } => {
            let largest = edges.iter().copied().fold(0.0, f64::max);
            edges.map(|e| e / largest * size)
        }
        _ => [size; 3],
    };
    let (mut sq, mut inliers) = (0.0, 0.0);
    for (x, w) in points {
        let d = dist(p, x);
        sq += w * d * d;
        if d.abs() < 0.1 * size {
            inliers += w;
        }
    }
    ShapeFit {
        shape: target.kind(),
        rms: (sq / total).sqrt(),
        size,
        extents,
        centre: [p[3], p[4], p[5]],
        rotation: [p[0], p[1], p[2]],
        inlier_share: inliers / total,
        weight: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::targets::{cube_surface, sphere_surface};

    #[test]
    fn recovers_a_rotated_cube_and_a_sphere() {
        let r = Rotation3::from_euler_angles(0.02, -0.03, 0.5);
        let c = Vector3::new(10.0, -1.0, 0.3);
        let means: Vec<_> =
            cube_surface(0.6, 300, 3).iter().map(|p| r * Vector3::from(*p) + c).collect();
        let fit = fit_shape(&Target::Cube { edge: 0.5 }, &means, &vec![1.0; 300]).unwrap();
        assert!((fit.size - 0.6).abs() < 1e-3, "{fit:?}");
        assert!(fit.rms < 1e-3 && fit.inlier_share > 0.99, "{fit:?}");
        let means: Vec<_> =
            sphere_surface(0.3, 200).iter().map(|p| Vector3::from(*p) + c).collect();
        let fit = fit_shape(&Target::Sphere { diameter: 0.5 }, &means, &vec![1.0; 200]).unwrap();
        assert!((fit.size - 0.6).abs() < 1e-6 && fit.rms < 1e-6, "{fit:?}");
        assert!(fit_shape(&Target::Cube { edge: 0.5 }, &means[..3], &[1.0; 3]).is_none());
    }

    #[test]
    fn fits_each_cube_on_a_ground_apart() {
        let mut means = Vec::new();
        let yaws = [0.0, 0.35, 0.7];
        for (i, yaw) in yaws.iter().enumerate() {
            let r = Rotation3::from_euler_angles(0.0, 0.0, *yaw);
            let c = Vector3::new(12.3, -1.5 + 1.5 * i as f64, 0.25);
            // Only the sides and top, as a LiDAR sees them.
            means.extend(
                cube_surface(0.5, 120, i as u64)
                    .iter()
                    .map(|p| r * Vector3::from(*p) + c)
                    .filter(|p| p.z > 0.01),
            );
        }
        // A ground sheet whose components sit closer than the gap, as JRMPC leaves them.
        for x in 0..14 {
            for y in 0..26 {
                means.push(Vector3::new(11.0 + 0.2 * x as f64, -2.5 + 0.2 * y as f64, 0.0));
            }
        }
        let priors = vec![1.0; means.len()];
        let ground = Some((Vector3::z(), 0.0));
        let fits = fit_targets(&Target::Cube { edge: 0.5 }, &means, &priors, ground);
        assert_eq!(fits.len(), 3, "{fits:?}");
        for fit in &fits {
            assert!((fit.size - 0.5).abs() < 0.01 && fit.rms < 0.01, "{fit:?}");
            let cube = ((fit.centre[1] + 1.5) / 1.5).round() as usize;
            // A cube's yaw is defined modulo 90 deg.
            let yaw = Rotation3::new(Vector3::from(fit.rotation)).euler_angles().2;
            let off = (yaw - yaws[cube]).rem_euclid(std::f64::consts::FRAC_PI_2);
            assert!(off.min(std::f64::consts::FRAC_PI_2 - off) < 0.02, "{fit:?}");
            assert!((fit.weight - 1.0 / 3.0).abs() < 0.05, "{fit:?}");
        }
        // Without the ground dropped, the sheet joins the cubes into one group.
        let joined = fit_targets(&Target::Cube { edge: 0.5 }, &means, &priors, None);
        assert_eq!(joined.len(), 1);
    }
}
