//! Ground levelling: before cropping, tilt and lift each sensor's pre-aligned points so that
//! its ground plane lies on the reference sensor's.
//!
//! Why: each sensor is cropped to the ROI in its own, wrong, nominal frame. With a few degrees
//! of pitch error the ground 10 m ahead moves tens of centimetres, so one sensor's crop holds
//! ground the other's lacks, and every registration then fits lopsided data (docs/method.md,
//! "Where the bias comes from"). The ground fixes roll, pitch and height; levelling applies exactly
//! that and nothing else (the shortest rotation between the two normals, about a point on the
//! plane under the ROI), so yaw and the in-plane translation are left to the registration.

use crate::cloud::{Aabb, is_valid_point};
pub use crate::plane::Plane;
use crate::se3::{Pose, rotation_about};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// How the ground is searched for.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundSettings {
    /// How far the search box reaches beyond the ROI (m) along x, y (each side) and z (each
    /// side): wide enough for the ground under a sensor pitched by the largest expected error.
    pub margin: [f64; 3],
    /// RANSAC inlier distance (m).
    pub inlier_distance: f64,
    /// Largest angle (rad) between a ground normal and the vehicle's z axis.
    pub max_tilt: f64,
    /// Fewest inliers that make a ground plane.
    pub min_inliers: usize,
    /// Smallest extent (m) of the inliers across their narrower in-plane direction: the top
    /// of a box or a calibration board is a horizontal plane too, but not the ground.
    pub min_extent: f64,
    /// Points within this distance (m) of the reference's ground plane take the plane's normal
    /// in the refinement (ground rings lie too far apart for neighbour normals).
    pub normal_band: f64,
}

impl Default for GroundSettings {
    fn default() -> Self {
        Self {
            margin: [4.0, 2.0, 2.0],
            inlier_distance: 0.05,
            max_tilt: 20f64.to_radians(),
            min_inliers: 200,
            min_extent: 1.5,
            normal_band: 0.03,
        }
    }
}

/// RANSAC plane fit over `points` with a normal within `max_tilt` of +z, refined by least
/// squares on its inliers. Seeded; `None` when no plane has `min_inliers` points.
pub fn fit_ground(
    points: &[Vector3<f64>],
    settings: &GroundSettings,
    seed: u64,
) -> Option<(Plane, usize)> {
    const TRIALS: usize = 300;
    // Scoring every trial on every point is wasted work: a strided sample ranks the planes.
    const SCORED: usize = 4000;
    if points.len() < settings.min_inliers.max(3) {
        return None;
    }
    let stride = points.len().div_ceil(SCORED);
    let sample: Vec<&Vector3<f64>> = points.iter().step_by(stride).collect();
    let mut rng = Pcg64::seed_from_u64(seed);
    let min_up = settings.max_tilt.cos();
    let mut best: Option<(Plane, usize)> = None;
    for _ in 0..TRIALS {
        let [a, b, c] = [(); 3].map(|_| points[rng.random_range(0..points.len())]);
        let Some(normal) = (b - a).cross(&(c - a)).try_normalize(1e-9) else {
            continue;
        };
        let normal = if normal.z < 0.0 { -normal } else { normal };
        if normal.z < min_up {
            continue;
        }
        let plane = Plane { normal, offset: -normal.dot(&a) };
        let score =
            sample.iter().filter(|p| plane.distance(p).abs() <= settings.inlier_distance).count();
        if best.is_none_or(|(_, s)| score > s) {
            best = Some((plane, score));
        }
    }
    let (mut plane, _) = best?;
    // Least squares on the inliers, twice: the second pass uses the better plane's inliers.
    let mut inliers = 0;
    for band in [settings.inlier_distance, 0.5 * settings.inlier_distance] {
        let on: Vec<&Vector3<f64>> =
            points.iter().filter(|p| plane.distance(p).abs() <= band).collect();
        inliers = on.len();
        if inliers < settings.min_inliers.max(3) {
            return None;
        }
        let extent;
        (plane, extent) = least_squares_plane(&on)?;
        if plane.normal.z < min_up || extent < settings.min_extent {
            return None;
        }
    }
    Some((plane, inliers))
}

/// The plane through the centroid whose normal is the direction of least spread, and the
/// points' extent (m) along the in-plane direction of lesser spread (the side of a uniformly
/// covered rectangle).
fn least_squares_plane(points: &[&Vector3<f64>]) -> Option<(Plane, f64)> {
    let (plane, extent) = crate::plane::least_squares_plane(points.iter().copied())?;
    // Pointing up: the negated normal and offset are exactly what the fit would give.
    Some((if plane.normal.z < 0.0 { plane.flipped() } else { plane }, extent))
}

/// The smallest rigid motion taking `from` onto `to`: the shortest rotation between the
/// normals about `pivot`'s foot on `from`, then a shift along `to`'s normal.
pub fn levelling(from: &Plane, to: &Plane, pivot: &Vector3<f64>) -> Pose {
    let foot = from.project(pivot);
    let rotation = UnitQuaternion::rotation_between(&from.normal, &to.normal)
        .unwrap_or_else(UnitQuaternion::identity);
    rotation_about(rotation, &foot, &(-to.normal * to.distance(&foot)))
}

/// The search box for the ground: the ROI grown by `margin`.
pub fn search_box(roi: &Aabb, margin: [f64; 3]) -> Aabb {
    let min = std::array::from_fn(|i| roi.min[i] - margin[i]);
    let max = std::array::from_fn(|i| roi.max[i] + margin[i]);
    Aabb::new(min, max)
}

/// Points of `cloud` mapped by `pose` that fall in `bounds`, in f64.
pub fn points_in(cloud: &[[f32; 3]], pose: &Pose, bounds: &Aabb) -> Vec<Vector3<f64>> {
    cloud
        .iter()
        .filter(|p| is_valid_point(p))
        .map(|p| (pose * Point3::from(p.map(f64::from))).coords)
        .filter(|p| bounds.contains([p.x, p.y, p.z]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    fn ground_with_clutter(pose: &Pose) -> Vec<Vector3<f64>> {
        let mut points = Vec::new();
        for i in 0..60 {
            for j in 0..40 {
                let p = Vector3::new(8.0 + 0.1 * i as f64, -2.0 + 0.1 * j as f64, 0.0);
                points.push(pose * Point3::from(p));
            }
        }
        // A wall and a box top: planes too, but steep or small.
        for i in 0..30 {
            for k in 0..30 {
                points.push(pose * Point3::new(12.0, -1.5 + 0.1 * i as f64, 0.1 * k as f64));
                points.push(pose * Point3::new(10.0 + 0.01 * i as f64, 0.01 * k as f64, 0.5));
            }
        }
        points.into_iter().map(|p| p.coords).collect()
    }

    #[test]
    fn finds_the_ground_among_other_planes() {
        let pose = pose_from_xyz_rpy([0.0, 0.0, 0.3], [0.02, -0.04, 0.3]);
        let points = ground_with_clutter(&pose);
        let (plane, inliers) = fit_ground(&points, &GroundSettings::default(), 1).unwrap();
        let expected = pose.rotation * Vector3::z();
        assert!((plane.normal - expected).norm() < 1e-9, "{:?}", plane.normal);
        assert!(plane.distance(&pose.translation.vector).abs() < 1e-9);
        assert!(inliers >= 2400, "{inliers}");
    }

    #[test]
    fn a_box_top_is_not_the_ground() {
        let top: Vec<Vector3<f64>> = (0..900)
            .map(|i| Vector3::new(12.0 + 0.02 * (i % 30) as f64, 0.02 * (i / 30) as f64, 0.5))
            .collect();
        assert_eq!(fit_ground(&top, &GroundSettings::default(), 1), None);
    }

    #[test]
    fn no_ground_when_every_plane_is_steep() {
        let wall: Vec<Vector3<f64>> = (0..900)
            .map(|i| Vector3::new(5.0, 0.1 * (i % 30) as f64, 0.1 * (i / 30) as f64))
            .collect();
        assert_eq!(fit_ground(&wall, &GroundSettings::default(), 1), None);
    }

    #[test]
    fn levelling_maps_one_ground_onto_the_other_without_yaw() {
        let to = Plane { normal: Vector3::z(), offset: 0.0 };
        let tilt = pose_from_xyz_rpy([0.05, -0.02, 0.08], [0.03, -0.05, 0.0]);
        let normal = tilt.rotation * Vector3::z();
        let from = Plane { normal, offset: -normal.dot(&tilt.translation.vector) };
        let pivot = Vector3::new(12.0, 0.0, 0.3);
        let level = levelling(&from, &to, &pivot);
        for p in [Vector3::new(10.0, 1.0, 0.0), Vector3::new(14.0, -2.0, 0.0)] {
            let on_from = from.project(&p);
            assert!(to.distance(&(level * Point3::from(on_from)).coords).abs() < 1e-12);
        }
        // The shortest rotation between two tilted-up normals has no yaw about z... to first
        // order: its axis lies in the ground plane.
        let axis = level.rotation.axis().unwrap();
        assert!(axis.z.abs() < 0.05, "{axis:?}");
        // The pivot's foot moves only along the normal.
        let foot = from.project(&pivot);
        let moved = level * Point3::from(foot);
        let d = moved.coords - foot;
        assert!((d - to.normal * d.dot(&to.normal)).norm() < 1e-12);
    }
}
