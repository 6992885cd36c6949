//! Joint plane adjustment: the last word on `gmm`'s corrections.
//!
//! The per-frame GICP matches each point to a neighbourhood of the reference's; on 0.5 m cubes
//! many neighbourhoods straddle an edge, and those matches bias the yaw (docs/method.md, "Where the bias
//! comes from"). Planar targets have a maximum-likelihood estimator that needs no neighbours:
//!
//! 1. every sensor's views go into the vehicle frame with its averaged refined correction;
//! 2. per frame, the planes are found on the merged cloud: the reference's ground, and the
//!    planes of each cluster of points above it (sequential RANSAC, least-squares refits);
//! 3. each point is assigned to the nearest plane of its cluster (or the ground) within a few
//!    noise widths; points near two planes (an edge) or near none are dropped;
//! 4. Gauss-Newton over one 6-dof motion per non-reference sensor, shared by all its frames,
//!    and every plane's normal and offset, the reference fixed; residuals are point-to-plane
//!    distances with Cauchy weights;
//! 5. the covariance at the solution gives each sensor's [`Precision`].
//!
//! Planes are per frame, so a target that moves between frames costs nothing (for a static
//! scene the relative pose is as well determined: each plane compares the sensors' samples of
//! it). A motion beyond `max_departure` is not trusted and the refinement stays.

mod detect;
mod solve;
#[cfg(test)]
mod tests;

use nalgebra::{Point3, Vector3};

use super::average::robust_average;
use super::notes::{GroundWindow, NoteKind};
use super::pairs::PairCorrections;
use crate::plane::Plane;
use crate::se3::Pose;
use detect::frame_observations;
use solve::solve;

/// The plane adjustment's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneSettings {
    /// RANSAC inlier distance (m) when finding planes.
    pub inlier_distance: f64,
    /// Points farther than this (m) from every plane are left out.
    pub assign_distance: f64,
    /// Points within this distance (m) of a second plane of their cluster (an edge) are left
    /// out: about 3 times the range noise (2 cm measured worse on the twin, 4-5 cm no better).
    pub edge_distance: f64,
    /// How far (m) above the reference's ground a point may still be ground (the clusters
    /// take the rest), one run of the adjustment per value; the run whose sensors' grounds
    /// meet best stands (`calib::finish`). 3 cm leaves out what stands on a road (grass,
    /// kerbs, litter); 5 cm keeps the whole noise of a sensor that sees the ground steeply,
    /// whose upper tail the 3 cm cut takes off (5 mm low on the `sideways` twin).
    pub ground_windows: Vec<f64>,
    /// Clusters above the ground: points closer than about this (m) join (grid cells).
    pub cluster_gap: f64,
    /// Fewest points that make a plane, and fewest per sensor for it to count.
    pub min_plane_points: usize,
    pub min_sensor_points: usize,
    /// Most planes per cluster.
    pub max_planes_per_cluster: usize,
    /// Cauchy scale (m) of the residuals: three times the range noise. Tighter scales and
    /// assignment cut the noise's tails unevenly and leave a yaw bias (twin: Cauchy 5 mm
    /// -0.015 deg); 3 cm beat 2 cm on 20 seeds x 5 (2 sensors 1.6 against 2.0 mm, 3 sensors
    /// 2.7 against 3.1 mm, median).
    pub robust_scale: f64,
    /// Gauss-Newton iterations (at most).
    pub iterations: usize,
    /// A sensor motion beyond this (rad, m) is rejected: the refinement stays.
    pub max_departure: (f64, f64),
    /// Edge (m) of the patches of a plane whose residuals the precision takes as one: what
    /// the plane model misses is shared by neighbouring points.
    pub patch: f64,
    pub seed: u64,
}

impl Default for PlaneSettings {
    fn default() -> Self {
        Self {
            inlier_distance: 0.02,
            // Twin, 20 seeds x 1 (signed mean yaw / median): assign 3 cm, Cauchy 1 cm
            // -0.0104 / 0.0116 deg; 5 cm, 2 cm -0.0075 / 0.0094 deg; 5 cm, 3 cm -0.0068 /
            // 0.0091 deg; 8 cm, 3 cm -0.022 deg.
            assign_distance: 0.05,
            edge_distance: 0.03,
            ground_windows: vec![0.03, 0.05],
            cluster_gap: 0.15,
            min_plane_points: 30,
            min_sensor_points: 10,
            max_planes_per_cluster: 5,
            robust_scale: 0.03,
            iterations: 10,
            max_departure: (0.2f64.to_radians(), 0.02),
            patch: 1.0,
            seed: 0,
        }
    }
}

/// What the adjustment did for one non-reference sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorAdjustment {
    /// Sensor index.
    pub sensor: usize,
    /// The motion found, applied on the left of every frame's correction when accepted.
    pub motion: Pose,
    /// Points of this sensor used (all frames).
    pub points: usize,
    pub accepted: bool,
    /// What the points allow: the spread of the motion's estimate.
    pub precision: Option<Precision>,
}

/// One-sigma uncertainty of a sensor's calibration. The plane adjustment measures it as the
/// covariance of its motion at the solution, from the point-to-plane residuals (see
/// `covariance`): the spread the point noise leaves (the twin's errors follow it;
/// docs/accuracy.md, "How precise"). The calibration then floors it by what the scans tell
/// apart and widens it by the loops that do not close (`calib::finish`); it is no bound on
/// errors no evidence sees (a target that moved, a wrong nominal beyond reach).
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Precision {
    /// Rotation about the vehicle's x, y, z axes (rad).
    pub rotation: [f64; 3],
    /// The sensor's position along x, y, z (m).
    pub position: [f64; 3],
}

/// One point used: its sensor, its (frame-)plane, its position in the vehicle frame.
struct Observation {
    sensor: usize,
    plane: usize,
    point: Vector3<f64>,
}

/// A plane as normal and offset at a fixed centre: `normal . (p - centre) + offset = 0`
/// (the centre keeps the normal and offset uncorrelated at 10 m from the origin).
#[derive(Clone, Copy, Debug)]
struct FramePlane {
    normal: Vector3<f64>,
    centre: Vector3<f64>,
    offset: f64,
}

impl FramePlane {
    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(&(p - self.centre)) + self.offset
    }
}

/// Adjusts `corrections` (per sensor, per frame pair `(reference view, sensor view)`, as
/// the refinement leaves them) by one motion per non-reference sensor. `origins` are the
/// sensors' positions in the clouds' frame (for [`Precision::position`]); `ground` is the
/// reference's ground plane in the vehicle frame and how far (m) above it a point may still be
/// ground; without it nothing is done.
pub fn adjust(
    clouds: &[&[[f32; 3]]],
    origins: &[Vector3<f64>],
    pairs: &[Vec<(usize, usize)>],
    reference: usize,
    corrections: &mut [PairCorrections],
    ground: Option<(Plane, f64)>,
    settings: &PlaneSettings,
) -> Vec<SensorAdjustment> {
    let Some((ground, above)) = ground else {
        return Vec::new();
    };
    let sensors = pairs.len();
    // Each sensor's calibration is constant: its frames go in with the averaged correction.
    let means: Vec<Option<Pose>> = (0..sensors)
        .map(|s| {
            if s == reference {
                return Some(Pose::identity());
            }
            let poses: Vec<Pose> = corrections[s].iter().map(|(_, c)| *c).collect();
            robust_average(&poses).map(|(m, _, _)| m)
        })
        .collect();
    // Frames by the reference's view: (sensor, view) of every sensor that has it.
    let mut frames: Vec<(usize, Vec<(usize, usize)>)> = Vec::new();
    for (s, list) in pairs.iter().enumerate() {
        if s == reference || means[s].is_none() {
            continue;
        }
        for &(r, v) in list {
            match frames.iter_mut().find(|(rv, _)| *rv == r) {
                Some((_, members)) => members.push((s, v)),
                None => frames.push((r, vec![(reference, r), (s, v)])),
            }
        }
    }
    let mut planes: Vec<FramePlane> = Vec::new();
    let mut observations: Vec<Observation> = Vec::new();
    for (f, (_, members)) in frames.iter().enumerate() {
        let points: Vec<(usize, Vector3<f64>)> = members
            .iter()
            .flat_map(|&(s, v)| {
                let pose = means[s].unwrap_or_else(Pose::identity);
                clouds[v].iter().map(move |p| {
                    let p = nalgebra::Point3::from(Vector3::from(p.map(f64::from)));
                    (s, (pose * p).coords)
                })
            })
            .collect();
        let seed = settings.seed.wrapping_add(f as u64);
        let (found, used) = (&mut planes, &mut observations);
        frame_observations(&points, &ground, above, settings, seed, found, used);
    }
    let solution = solve(&observations, &mut planes, sensors, reference, settings);
    let mut outcomes = Vec::new();
    for s in (0..sensors).filter(|&s| s != reference && means[s].is_some()) {
        let points = observations.iter().filter(|o| o.sensor == s).count();
        let motion = solution.motions[s];
        let origin = motion * means[s].unwrap_or_else(Pose::identity) * Point3::from(origins[s]);
        let precision = solution.precision(s, &origin.coords);
        let (angle, shift) = (motion.rotation.angle(), motion.translation.vector.norm());
        let accepted =
            points > 0 && angle <= settings.max_departure.0 && shift <= settings.max_departure.1;
        if accepted {
            corrections[s].iter_mut().for_each(|(_, c)| *c = motion * *c);
        }
        outcomes.push(SensorAdjustment { sensor: s, motion, points, accepted, precision });
    }
    outcomes
}

impl SensorAdjustment {
    /// What to note on the sensor: the motion applied, or why the refinement stays.
    pub fn note(&self, limit: (f64, f64), window: GroundWindow) -> NoteKind {
        let (angle, shift) = (self.motion.rotation.angle(), self.motion.translation.vector.norm());
        if self.accepted {
            NoteKind::PlanesApplied { angle, shift, points: self.points, window }
        } else if self.points == 0 {
            NoteKind::PlanesWithoutPoints
        } else {
            NoteKind::PlanesRejected { angle, shift, limit }
        }
    }
}
