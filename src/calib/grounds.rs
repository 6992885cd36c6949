//! The levelling stage over a rig: each sensor's ground near the region, found in all its
//! frames at its start, the motion that puts it on the reference's ground, then (when on) the
//! bird's-eye search for the yaw and in-plane shift the ground leaves free.

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

/// Every sensor's ground in a box around the ROI (all its frames, pre-aligned with its
/// nominal), and the motion putting it on the reference's ground; then, when on, the
/// bird's-eye search for each levelled sensor's yaw and in-plane shift.
pub(super) fn level_grounds(
    rig: &Rig,
    roi: &Aabb,
    sensors: &[String],
    nominals: &[Pose],
    r: usize,
    settings: &Settings,
    stages: &Stages,
) -> Vec<Levelling> {
    let (near_roi, grounds): (Vec<_>, Vec<_>) =
        (0..sensors.len()).map(|s| sensor_ground(rig, roi, sensors, nominals, s, settings)).unzip();
    let pivot = Vector3::from_fn(|i, _| 0.5 * (roi.min[i] + roi.max[i]));
    sensors
        .iter()
        .enumerate()
        .map(|(s, name)| {
            let (ground, inliers) = grounds[s].map_or((None, 0), |(p, n)| (Some(p), n));
            let (mut motion, skipped) = match (ground, grounds[r]) {
                (Some(_), _) if s == r => (Pose::identity(), None),
                (Some(own), Some((reference, _))) => {
                    (level::levelling(&own, &reference, &pivot), None)
                }
                (None, _) => (Pose::identity(), Some(LevellingSkipped::NoGround)),
                (Some(_), None) => (
                    Pose::identity(),
                    Some(LevellingSkipped::ReferenceWithoutGround {
                        reference: sensors[r].clone(),
                    }),
                ),
            };
            // The bird's-eye search runs for every non-reference sensor levelled.
            let searched = stages.bev.as_ref().filter(|_| s != r && skipped.is_none());
            let bev = searched.zip(grounds[r]).and_then(|(bev_settings, (reference, _))| {
                let levelled: Vec<_> =
                    near_roi[s].iter().map(|p| (motion * Point3::from(*p)).coords).collect();
                let sensor = (motion * nominals[s]).translation.vector;
                bev::search(&levelled, &near_roi[r], &reference, &sensor, bev_settings)
            });
            if let Some(found) = &bev {
                motion = found.applied * motion;
            }
            let warning = searched.and_then(|b| bev::warning(bev.as_ref(), b));
            Levelling { sensor: name.clone(), ground, inliers, motion, bev, skipped, warning }
        })
        .collect()
}

/// Sensor `s`'s points (all frames, pre-aligned with its nominal) in the box around the ROI
/// where the ground is searched, and the ground plane found among them.
pub(super) fn sensor_ground(
    rig: &Rig,
    roi: &Aabb,
    sensors: &[String],
    nominals: &[Pose],
    s: usize,
    settings: &Settings,
) -> (Vec<Vector3<f64>>, Option<(Plane, usize)>) {
    let bounds = level::search_box(roi, settings.ground.margin);
    let points: Vec<_> = rig
        .scans
        .iter()
        .filter(|v| v.sensor == sensors[s])
        .flat_map(|v| points_in(&v.points, &nominals[s], &bounds))
        .collect();
    let ground =
        level::fit_ground(&points, &settings.ground, sensor_seed(settings.seed, sensors, s));
    (points, ground)
}
