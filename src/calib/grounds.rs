//! The levelling stage over a rig: a sensor's ground near the region, found in all its frames
//! at a start, the motion that puts it on the reference's ground, then (when on) the bird's-eye
//! search for the yaw and in-plane shift the ground leaves free.

use nalgebra::{Point3, Vector3};

use super::Rig;
use super::bev;
use super::level::{self, points_in};
use super::notes::LevellingSkipped;
use super::result::Levelling;
use super::rig::sensor_seed;
use super::settings::{Settings, Stages};
use crate::cloud::Aabb;
use crate::plane::Plane;
use crate::se3::Pose;

/// A sensor's points near the ROI (vehicle frame, at a start) and the ground plane found among
/// them with its inliers: [`sensor_ground`]'s answer.
pub(super) type NearGround = (Vec<Vector3<f64>>, Option<(Plane, usize)>);

/// The reference `r`'s levelling: none, its ground (`reference`, [`sensor_ground`]) being the
/// one the others are levelled onto.
pub(super) fn reference_levelling(name: &str, (_, ground): &NearGround) -> Levelling {
    Levelling {
        sensor: name.to_string(),
        ground: ground.map(|(p, _)| p),
        inliers: ground.map_or(0, |(_, n)| n),
        motion: Pose::identity(),
        bev: None,
        skipped: ground.is_none().then_some(LevellingSkipped::NoGround),
        warning: None,
    }
}

/// Sensor `s`'s (not the reference's) levelling from `start` (its pre-alignment) onto the
/// reference `r`'s ground, found near the ROI with its points ([`sensor_ground`]); then, when
/// `search` and the stages say so, the bird's-eye search. Any start may be levelled, so that
/// each of the global stage's candidates is judged as the levelling leaves it.
#[allow(clippy::too_many_arguments)]
pub(super) fn level_sensor(
    rig: &Rig,
    roi: &Aabb,
    sensors: &[String],
    start: &Pose,
    s: usize,
    r: usize,
    (reference_points, reference_ground): &NearGround,
    settings: &Settings,
    stages: &Stages,
    search: bool,
) -> Levelling {
    let pivot = Vector3::from_fn(|i, _| 0.5 * (roi.min[i] + roi.max[i]));
    let (near_roi, own) = sensor_ground(rig, roi, sensors, start, s, settings);
    let (ground, inliers) = own.map_or((None, 0), |(p, n)| (Some(p), n));
    let (mut motion, skipped) = match (ground, reference_ground) {
        (Some(own), Some((reference, _))) => (level::levelling(&own, reference, &pivot), None),
        (None, _) => (Pose::identity(), Some(LevellingSkipped::NoGround)),
        (Some(_), None) => (
            Pose::identity(),
            Some(LevellingSkipped::ReferenceWithoutGround { reference: sensors[r].clone() }),
        ),
    };
    // The bird's-eye search runs for every non-reference sensor levelled.
    let searched = stages.bev.as_ref().filter(|_| search && skipped.is_none());
    let bev = searched.zip(reference_ground.as_ref()).and_then(|(bev_settings, (reference, _))| {
        let levelled: Vec<_> =
            near_roi.iter().map(|p| (motion * Point3::from(*p)).coords).collect();
        let sensor = (motion * start).translation.vector;
        bev::search(&levelled, reference_points, reference, &sensor, bev_settings)
    });
    if let Some(found) = &bev {
        motion = found.applied * motion;
    }
    let warning = searched.and_then(|b| bev::warning(bev.as_ref(), b));
    Levelling { sensor: sensors[s].clone(), ground, inliers, motion, bev, skipped, warning }
}

/// Sensor `s`'s points (all frames, pre-aligned with `start`) in the box around the ROI
/// where the ground is searched, and the ground plane found among them.
pub(super) fn sensor_ground(
    rig: &Rig,
    roi: &Aabb,
    sensors: &[String],
    start: &Pose,
    s: usize,
    settings: &Settings,
) -> NearGround {
    let bounds = level::search_box(roi, settings.ground.margin);
    let points: Vec<_> = rig
        .scans
        .iter()
        .filter(|v| v.sensor == sensors[s])
        .flat_map(|v| points_in(&v.points, start, &bounds))
        .collect();
    let ground =
        level::fit_ground(&points, &settings.ground, sensor_seed(settings.seed, sensors, s));
    (points, ground)
}
