//! Up from the data: a sensor's ground plane in its OWN frame, whatever its mounting tilt (a
//! side LiDAR pitched 45-60 deg, a LiDAR upside down), with the nominal mounting only a hint.
//!
//! Why: levelling (`level.rs`) looks for the ground near the ROI in the nominal vehicle frame
//! and accepts only planes within 20 deg of up, so a nominal 45 deg off finds a wall or nothing.
//! Here every large plane of the scan is a candidate (sequential RANSAC), oriented so that the
//! sensor lies on its positive side, and weighed by evidence that does not depend on one scene:
//! - its footprint (area covered, m^2), not its point count: a LiDAR samples near surfaces
//!   densely, so a wall beside a side LiDAR can hold more points than the road;
//! - almost nothing lies beyond the ground (a wall of a car or a fence has points behind it);
//! - the sensor sits above it at a plausible height, close to the height the nominal implies;
//! - its normal agrees with the up the nominal implies, within the nominal's expected error.
//!
//! The candidates are returned ranked, so a caller can break a near tie with other evidence
//! (the global stage picks the one whose levelled scan overlays the reference's best).

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::collections::HashSet;

use crate::cloud::is_valid_point;
use crate::plane::{Plane, least_squares_plane};

/// How the ground is searched for in a sensor's own frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UpSettings {
    /// Voxel edge (m) the scan is thinned to before the plane search.
    pub voxel: f64,
    /// Points farther than this from the sensor are ignored (m): far ground bends and is sparse.
    pub max_range: f64,
    /// RANSAC inlier distance (m).
    pub inlier_distance: f64,
    /// Largest number of planes extracted, largest first.
    pub max_planes: usize,
    /// Fewest (thinned) points on a plane.
    pub min_inliers: usize,
    /// Smallest extent (m) of a plane across its narrower in-plane direction.
    pub min_extent: f64,
    /// Cell edge (m) of the footprint that measures a plane's area.
    pub footprint_cell: f64,
    /// The sensor's height above its ground must lie in this range (m).
    pub heights: [f64; 2],
    /// Points farther than this beyond a plane (m, away from the sensor) count as behind it.
    pub behind: f64,
}

impl Default for UpSettings {
    fn default() -> Self {
        Self {
            voxel: 0.2,
            max_range: 30.0,
            inlier_distance: 0.08,
            max_planes: 6,
            min_inliers: 60,
            min_extent: 1.5,
            footprint_cell: 0.5,
            heights: [0.1, 6.0],
            behind: 0.3,
        }
    }
}

/// What the nominal mounting says about the ground, in the sensor's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpHint {
    /// Unit up direction (sensor frame): the nominal rotation's inverse applied to the vehicle's
    /// up.
    pub up: Vector3<f64>,
    /// Standard deviation of the nominal's tilt error (rad).
    pub tilt_sigma: f64,
    /// The sensor's height above the ground that the nominal implies (m), and its standard
    /// deviation (m); `None` when nothing is known (the reference sensor).
    pub height: Option<(f64, f64)>,
}

/// One plane of the scan, weighed as the ground.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroundCandidate {
    /// In the sensor frame, the normal pointing towards the sensor (the sensor's up if this is
    /// the ground).
    pub plane: Plane,
    /// Thinned points on it.
    pub inliers: usize,
    /// Footprint of its inliers (m^2).
    pub area: f64,
    /// The sensor's height above it (m).
    pub height: f64,
    /// Angle between its normal and the hinted up (rad).
    pub tilt: f64,
    /// Share of the thinned scan lying beyond it.
    pub behind: f64,
    /// Log-evidence as the ground: higher is better.
    pub score: f64,
}

/// Why no ground was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NoGround {
    /// Fewer points within range than a plane needs.
    TooFewPoints { points: usize },
    /// Planes were found, but none has the sensor above it at a plausible height, facing the
    /// hinted up's hemisphere.
    NonePlausible { planes: usize },
}

/// The ground found: the best candidate first, then the others that were plausible.
#[derive(Clone, Debug, PartialEq)]
pub struct Up {
    pub candidates: Vec<GroundCandidate>,
}

impl Up {
    /// The most likely ground (sensor frame, normal towards the sensor).
    pub fn ground(&self) -> Plane {
        self.candidates[0].plane
    }
}

/// The ground of one sensor's scan `points` (its own frame, any number of frames together).
/// Seeded: same input, same answer.
pub fn find_up(
    points: &[[f32; 3]],
    hint: &UpHint,
    settings: &UpSettings,
    seed: u64,
) -> Result<Up, NoGround> {
    let thinned = thin(points, settings);
    if thinned.len() < settings.min_inliers.max(3) {
        return Err(NoGround::TooFewPoints { points: thinned.len() });
    }
    let planes = extract_planes(&thinned, settings, seed);
    let mut candidates: Vec<GroundCandidate> =
        planes.iter().filter_map(|p| weigh(p, &thinned, hint, settings)).collect();
    if candidates.is_empty() {
        return Err(NoGround::NonePlausible { planes: planes.len() });
    }
    candidates.sort_by(|a, b| b.score.total_cmp(&a.score));
    Ok(Up { candidates })
}

/// The valid points within range, one per voxel.
fn thin(points: &[[f32; 3]], settings: &UpSettings) -> Vec<Vector3<f64>> {
    let mut seen = HashSet::new();
    points
        .iter()
        .filter(|p| is_valid_point(p))
        .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .filter(|p| p.norm() <= settings.max_range)
        .filter(|p| seen.insert(p.map(|c| (c / settings.voxel).floor() as i64)))
        .collect()
}

/// A plane with its inliers (indices into the thinned scan).
struct Found {
    plane: Plane,
    inliers: Vec<usize>,
}

/// Sequential RANSAC: the plane with most inliers among the points not yet taken, refined by
/// least squares, until `max_planes` or too few points remain.
fn extract_planes(points: &[Vector3<f64>], settings: &UpSettings, seed: u64) -> Vec<Found> {
    const TRIALS: usize = 400;
    const SCORED: usize = 3000;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut free: Vec<usize> = (0..points.len()).collect();
    let mut found = Vec::new();
    let band = settings.inlier_distance;
    while found.len() < settings.max_planes && free.len() >= settings.min_inliers.max(3) {
        let stride = free.len().div_ceil(SCORED);
        let sample: Vec<&Vector3<f64>> = free.iter().step_by(stride).map(|&i| &points[i]).collect();
        let mut best: Option<(Plane, usize)> = None;
        for _ in 0..TRIALS {
            let [a, b, c] = [(); 3].map(|_| points[free[rng.random_range(0..free.len())]]);
            let Some(normal) = (b - a).cross(&(c - a)).try_normalize(1e-9) else {
                continue;
            };
            let plane = Plane { normal, offset: -normal.dot(&a) };
            let score = sample.iter().filter(|p| plane.distance(p).abs() <= band).count();
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((plane, score));
            }
        }
        let Some((mut plane, _)) = best else { break };
        let mut inliers: Vec<usize> = Vec::new();
        let mut extent = 0.0;
        for _ in 0..2 {
            inliers = free
                .iter()
                .copied()
                .filter(|&i| plane.distance(&points[i]).abs() <= band)
                .collect();
            let Some((refined, e)) = fit_plane(inliers.iter().map(|&i| &points[i])) else { break };
            (plane, extent) = (refined, e);
        }
        if inliers.len() < settings.min_inliers {
            break;
        }
        // Take a wider band out, so the next plane is not the same one's noisy fringe.
        free.retain(|&i| plane.distance(&points[i]).abs() > 2.0 * band);
        if extent >= settings.min_extent {
            found.push(Found { plane: toward_origin(plane), inliers });
        }
    }
    found
}

/// The plane with its normal flipped, where needed, so that the origin (the sensor) lies on
/// its positive side.
fn toward_origin(plane: Plane) -> Plane {
    if plane.offset < 0.0 { plane.flipped() } else { plane }
}

/// Least-squares plane ([`least_squares_plane`]) of at least three points.
fn fit_plane<'a>(
    points: impl ExactSizeIterator<Item = &'a Vector3<f64>> + Clone,
) -> Option<(Plane, f64)> {
    if points.len() < 3 {
        return None;
    }
    least_squares_plane(points)
}

/// The evidence that `found` is the ground, or `None` when it cannot be: the sensor not above it
/// at a plausible height, or its normal in the hemisphere opposite the hinted up.
fn weigh(
    found: &Found,
    points: &[Vector3<f64>],
    hint: &UpHint,
    settings: &UpSettings,
) -> Option<GroundCandidate> {
    let plane = found.plane;
    let height = plane.offset;
    let cos = plane.normal.dot(&hint.up).clamp(-1.0, 1.0);
    if height < settings.heights[0] || height > settings.heights[1] || cos <= 0.0 {
        return None;
    }
    let tilt = cos.acos();
    let area = footprint(found, points, settings.footprint_cell);
    let behind = points.iter().filter(|p| plane.distance(p) < -settings.behind).count() as f64
        / points.len() as f64;
    // Log-evidence: footprint, few points behind, tilt and height as the nominal expects.
    let mut score = area.ln() + 2.0 * (1.0 - behind).max(1e-3).ln();
    score -= 0.5 * (tilt / hint.tilt_sigma).powi(2);
    if let Some((expected, sigma)) = hint.height {
        score -= 0.5 * ((height - expected) / sigma).powi(2);
    }
    Some(GroundCandidate { plane, inliers: found.inliers.len(), area, height, tilt, behind, score })
}

/// Area (m^2) of the cells of edge `cell` that the plane's inliers cover.
fn footprint(found: &Found, points: &[Vector3<f64>], cell: f64) -> f64 {
    let n = found.plane.normal;
    let u = n.cross(&if n.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() }).normalize();
    let v = n.cross(&u);
    let cells: HashSet<[i64; 2]> = found
        .inliers
        .iter()
        .map(|&i| [u.dot(&points[i]), v.dot(&points[i])].map(|c| (c / cell).floor() as i64))
        .collect();
    cells.len() as f64 * cell * cell
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::{Pose, pose_from_xyz_rpy};
    use nalgebra::Point3;
    use rand_distr::{Distribution, Normal};

    /// A street seen from a sensor at `mount` (vehicle frame, ground z = 0): ground 24 x 16 m,
    /// a building facade 4 m to the left (36 m long, 15 m high: larger than the ground), a car
    /// beside the sensor, returned in the sensor's frame with 1 cm noise.
    fn street(mount: &Pose, seed: u64) -> Vec<[f32; 3]> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.01).unwrap();
        let mut world = Vec::new();
        for i in 0..120 {
            for j in 0..80 {
                world.push(Vector3::new(-12.0 + 0.2 * i as f64, -12.0 + 0.2 * j as f64, 0.0));
            }
        }
        for i in 0..360 {
            for k in 0..150 {
                world.push(Vector3::new(-18.0 + 0.1 * i as f64, 4.0, 0.1 * k as f64));
            }
        }
        for i in 0..40 {
            for k in 0..15 {
                world.push(Vector3::new(1.0 + 0.1 * i as f64, -2.5, 0.1 * k as f64));
            }
        }
        let to_sensor = mount.inverse();
        world
            .iter()
            .map(|p| {
                let q = to_sensor * Point3::from(*p);
                [q.x, q.y, q.z].map(|c| (c + noise.sample(&mut rng)) as f32)
            })
            .collect()
    }

    fn hint_from(nominal: &Pose, height: f64) -> UpHint {
        UpHint {
            up: nominal.rotation.inverse() * Vector3::z(),
            tilt_sigma: 45f64.to_radians(),
            height: Some((height, 1.0)),
        }
    }

    /// Angle (deg) between the found ground's normal and the true up in the sensor frame.
    fn error_deg(up: &Up, mount: &Pose) -> f64 {
        let truth = mount.rotation.inverse() * Vector3::z();
        up.ground().normal.angle(&truth).to_degrees()
    }

    #[test]
    fn finds_the_ground_under_steep_tilts_and_upside_down_despite_a_larger_wall() {
        let d = std::f64::consts::PI / 180.0;
        let mounts = [
            pose_from_xyz_rpy([0.0, 0.0, 1.8], [0.0, 0.0, 0.3]),
            pose_from_xyz_rpy([0.0, 0.0, 1.5], [0.0, 45.0 * d, 1.2]),
            pose_from_xyz_rpy([0.0, 0.0, 1.2], [-60.0 * d, 0.0, -2.0]),
            pose_from_xyz_rpy([0.0, 0.0, 2.0], [180.0 * d, 10.0 * d, 0.7]),
        ];
        for (k, mount) in mounts.iter().enumerate() {
            let points = street(mount, k as u64);
            // The nominal is off by 40 deg of roll and 35 of pitch, 0.8 m in height.
            let nominal = pose_from_xyz_rpy([0.0, 0.0, 0.8], [40.0 * d, -35.0 * d, 0.0]) * mount;
            let up = find_up(
                &points,
                &hint_from(&nominal, mount.translation.z + 0.8),
                &UpSettings::default(),
                7,
            )
            .unwrap();
            assert!(error_deg(&up, mount) < 0.2, "mount {k}: {:?}", up.candidates);
            let height = up.candidates[0].height;
            assert!((height - mount.translation.z).abs() < 0.02, "mount {k}: {height}");
        }
    }

    #[test]
    fn the_height_above_it_tells_the_ground_from_a_wall_the_hint_favours() {
        let d = std::f64::consts::PI / 180.0;
        let mount = pose_from_xyz_rpy([0.0, 0.0, 1.5], [0.0, 45.0 * d, 1.2]);
        let points = street(&mount, 3);
        // The nominal is rolled 60 deg towards the facade: its up lies 30 deg from the facade's
        // normal and 60 deg from the ground's.
        let nominal = pose_from_xyz_rpy([0.0, 0.0, 0.0], [-60.0 * d, 0.0, 0.0]) * mount;
        let up = find_up(&points, &hint_from(&nominal, 1.5), &UpSettings::default(), 7).unwrap();
        assert!(error_deg(&up, &mount) < 0.2, "{:?}", up.candidates);
        let wall = up.candidates.iter().find(|c| (c.height - 4.0).abs() < 0.05);
        let wall = wall.unwrap_or_else(|| panic!("{:?}", up.candidates));
        assert!(wall.area > up.candidates[0].area && wall.tilt < up.candidates[0].tilt, "{wall:?}");
    }

    #[test]
    fn no_ground_is_said_so() {
        let mount = pose_from_xyz_rpy([0.0, 0.0, 1.8], [0.0, 0.0, 0.0]);
        let hint = hint_from(&mount, 1.8);
        let few = vec![[1.0f32, 0.0, 0.0]; 5];
        assert_eq!(
            find_up(&few, &hint, &UpSettings::default(), 1),
            Err(NoGround::TooFewPoints { points: 1 })
        );
        // Only a ceiling above the sensor: a plane, but the sensor is below it.
        let ceiling: Vec<[f32; 3]> = (0..2500)
            .map(|i| [-5.0 + 0.2 * (i % 50) as f32, -5.0 + 0.2 * (i / 50) as f32, 1.0])
            .collect();
        assert_eq!(
            find_up(&ceiling, &hint, &UpSettings::default(), 1),
            Err(NoGround::NonePlausible { planes: 1 })
        );
    }
}
