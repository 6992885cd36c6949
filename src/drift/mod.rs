//! The drift check: has a sensor moved since a stored calibration? [`compare`] takes the stored
//! [`Extrinsics`] (our result JSON, or a URDF / `/tf_static` YAML we exported, read by
//! [`read`]) and a new calibration's, and gives per sensor the rotation and translation
//! change, the new result's precision and whether the change is beyond the [`Tolerance`].
//!
//! A calibration measures each sensor relative to the reference, whose extrinsic is its
//! nominal. So each sensor is compared by its pose relative to the reference, expressed in the
//! new calibration's vehicle frame: `T_vehicle_s_stored' = T_vehicle_ref_new *
//! T_ref_s_stored`. When both share the reference's nominal this is the plain difference of
//! the extrinsics; when the nominals differ it still measures only what the sensors did.
//! Typed data only: the words are made in `report`.

mod read;

pub use read::{ReadError, read};

use crate::calib::Precision;
use crate::se3::Pose;

/// One sensor's calibrated mount.
#[derive(Clone, Debug, PartialEq)]
pub struct Mount {
    pub sensor: String,
    /// `T_vehicle_sensor` (for a URDF or tf tree, `T_root_sensor`).
    pub extrinsic: Pose,
    /// One sigma, when the calibration measured it (our JSON, `gmm`).
    pub precision: Option<Precision>,
}

/// Where a set of extrinsics came from: our JSON lists exactly the calibrated sensors; a
/// URDF or tf tree holds every frame, sensors among them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    Json,
    Urdf,
    TfYaml,
}

/// A calibration's extrinsics, stored or new.
#[derive(Clone, Debug, PartialEq)]
pub struct Extrinsics {
    pub source: Source,
    /// The reference sensor (our JSON says which; a tree does not).
    pub reference: Option<String>,
    pub mounts: Vec<Mount>,
}

impl Extrinsics {
    pub fn mount(&self, sensor: &str) -> Option<&Mount> {
        self.mounts.iter().find(|m| m.sensor == sensor)
    }
}

/// Default rotation tolerance (rad): 0.1 deg, the accuracy the twin studies hold.
pub const DEFAULT_ROTATION_TOLERANCE: f64 = 0.1 * std::f64::consts::PI / 180.0;
/// Default translation tolerance (m): 1 cm.
pub const DEFAULT_TRANSLATION_TOLERANCE: f64 = 0.01;

/// When a change counts as drift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tolerance {
    /// A rotation angle (rad) and a distance (m).
    Fixed { rotation: f64, translation: f64 },
    /// `sigmas` times the combined one-sigma precision (new and, when stored, the stored
    /// one's), per axis; a sensor without a precision falls back to `fallback`.
    Precision { sigmas: f64, rotation: f64, translation: f64 },
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance::Fixed {
            rotation: DEFAULT_ROTATION_TOLERANCE,
            translation: DEFAULT_TRANSLATION_TOLERANCE,
        }
    }
}

/// The limit one sensor was held to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Limit {
    /// Angle (rad) and distance (m).
    Fixed { rotation: f64, translation: f64 },
    /// Per axis of the vehicle frame: `sigmas` times the combined sigma, rotation (rad) and
    /// position (m).
    Sigmas { sigmas: f64, rotation: [f64; 3], position: [f64; 3] },
}

/// One sensor's change from the stored calibration to the new one.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorDrift {
    pub sensor: String,
    /// The rotation change as a rotation vector about the vehicle's x, y, z axes (rad):
    /// `R_new = exp(rotation) R_stored'`.
    pub rotation: [f64; 3],
    /// The position change along the vehicle's x, y, z (m).
    pub translation: [f64; 3],
    /// The rotation's angle (rad) and the translation's length (m).
    pub angle: f64,
    pub distance: f64,
    /// The new calibration's precision, one sigma.
    pub precision: Option<Precision>,
    pub limit: Limit,
    pub moved: bool,
    /// Beyond a fixed limit, yet within [`UNRESOLVED_SIGMAS`] of both calibrations' combined
    /// precision on every axis: the two cannot tell such a change from their own scatter, so
    /// it is not called a move.
    pub unresolved: bool,
}

/// With a fixed limit, a change within this many combined sigmas on every axis is
/// unresolved rather than moved (three: a one-sided 99.9 % on one axis, about 99 % over six).
pub const UNRESOLVED_SIGMAS: f64 = 3.0;

/// The comparison of two calibrations.
#[derive(Clone, Debug, PartialEq)]
pub struct Drift {
    /// The sensor both are measured relative to (unchanged by construction).
    pub reference: String,
    /// Every other sensor of the new calibration that the stored one has, in the new order.
    pub sensors: Vec<SensorDrift>,
    /// Sensors the stored calibration (our JSON) lists and the new one lacks.
    pub missing: Vec<String>,
    /// Sensors of the new calibration the stored one lacks (nothing to compare with).
    pub added: Vec<String>,
}

impl Drift {
    /// No sensor moved beyond its limit and none went missing.
    pub fn passed(&self) -> bool {
        self.missing.is_empty() && self.sensors.iter().all(|s| !s.moved)
    }
}

/// Why two calibrations cannot be compared.
#[derive(Clone, Debug, PartialEq)]
pub enum CompareError {
    /// The reference sensor (named) is not in the stored calibration.
    NoReference { reference: String },
    /// The new calibration has no sensors.
    Empty,
}

impl std::fmt::Display for CompareError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CompareError::NoReference { reference } => write!(
                f,
                "the stored calibration has no sensor '{reference}', the new calibration's reference"
            ),
            CompareError::Empty => write!(f, "the new calibration has no sensors"),
        }
    }
}

impl std::error::Error for CompareError {}

/// Each sensor of `new` against `stored`, relative to the reference (the new calibration's,
/// else the stored one's, else the new's first sensor).
pub fn compare(
    stored: &Extrinsics,
    new: &Extrinsics,
    tolerance: &Tolerance,
) -> Result<Drift, CompareError> {
    let reference = new
        .reference
        .clone()
        .or_else(|| stored.reference.clone())
        .or_else(|| new.mounts.first().map(|m| m.sensor.clone()))
        .ok_or(CompareError::Empty)?;
    let reference_new = new.mount(&reference).ok_or(CompareError::Empty)?;
    let reference_stored = stored
        .mount(&reference)
        .ok_or_else(|| CompareError::NoReference { reference: reference.clone() })?;
    // T_vehicle_ref_new * T_ref_vehicle_stored maps a stored extrinsic into the new frame.
    let into_new = reference_new.extrinsic * reference_stored.extrinsic.inverse();
    let mut sensors = Vec::new();
    let mut added = Vec::new();
    for m in new.mounts.iter().filter(|m| m.sensor != reference) {
        let Some(old) = stored.mount(&m.sensor) else {
            added.push(m.sensor.clone());
            continue;
        };
        let was = into_new * old.extrinsic;
        let rotation: [f64; 3] =
            (m.extrinsic.rotation * was.rotation.inverse()).scaled_axis().into();
        let translation: [f64; 3] =
            (m.extrinsic.translation.vector - was.translation.vector).into();
        let limit = limit(tolerance, m.precision.as_ref(), old.precision.as_ref());
        let (angle, distance) = (norm(rotation), norm(translation));
        let beyond = |r: [f64; 3], p: [f64; 3]| {
            (0..3).any(|i| rotation[i].abs() > r[i] || translation[i].abs() > p[i])
        };
        let (moved, unresolved) = match limit {
            Limit::Fixed { rotation: r, translation: t } => {
                let over = angle > r || distance > t;
                // Both precisions must be known: one calibration's alone would let the
                // other's scatter pass for a move.
                let scatter = match (m.precision.as_ref(), old.precision.as_ref()) {
                    (Some(a), Some(b)) => {
                        let Limit::Sigmas { rotation, position, .. } =
                            limit_of(UNRESOLVED_SIGMAS, a, Some(b))
                        else {
                            unreachable!()
                        };
                        !beyond(rotation, position)
                    }
                    _ => false,
                };
                (over && !scatter, over && scatter)
            }
            Limit::Sigmas { rotation: r, position: p, .. } => (beyond(r, p), false),
        };
        sensors.push(SensorDrift {
            sensor: m.sensor.clone(),
            rotation,
            translation,
            angle,
            distance,
            precision: m.precision,
            limit,
            moved,
            unresolved,
        });
    }
    let missing = match stored.source {
        Source::Json => stored
            .mounts
            .iter()
            .filter(|m| new.mount(&m.sensor).is_none())
            .map(|m| m.sensor.clone())
            .collect(),
        // A tree holds every frame of the robot, not only the sensors calibrated.
        Source::Urdf | Source::TfYaml => Vec::new(),
    };
    Ok(Drift { reference, sensors, missing, added })
}

/// The limit for a sensor with precision `new` (and `stored`, when the stored one had one).
fn limit(tolerance: &Tolerance, new: Option<&Precision>, stored: Option<&Precision>) -> Limit {
    match (*tolerance, new) {
        (Tolerance::Fixed { rotation, translation }, _)
        | (Tolerance::Precision { rotation, translation, .. }, None) => {
            Limit::Fixed { rotation, translation }
        }
        (Tolerance::Precision { sigmas, .. }, Some(p)) => limit_of(sigmas, p, stored),
    }
}

/// `sigmas` times the combined precision of `new` and, when known, `stored`.
fn limit_of(sigmas: f64, new: &Precision, stored: Option<&Precision>) -> Limit {
    // Independent estimates: their variances add.
    let combined = |a: [f64; 3], b: Option<[f64; 3]>| {
        std::array::from_fn(|i| {
            let b = b.map_or(0.0, |b| b[i]);
            sigmas * (a[i] * a[i] + b * b).sqrt()
        })
    };
    Limit::Sigmas {
        sigmas,
        rotation: combined(new.rotation, stored.map(|s| s.rotation)),
        position: combined(new.position, stored.map(|s| s.position)),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    fn mounts(source: Source, poses: &[(&str, Pose)]) -> Extrinsics {
        Extrinsics {
            source,
            reference: Some("a".into()),
            mounts: poses
                .iter()
                .map(|(n, p)| Mount { sensor: n.to_string(), extrinsic: *p, precision: None })
                .collect(),
        }
    }

    #[test]
    fn a_moved_sensor_is_found_and_a_still_one_passes() {
        let a = pose_from_xyz_rpy([1.0, 0.5, 1.6], [0.1, 0.0, 0.3]);
        let b = pose_from_xyz_rpy([1.0, -0.5, 1.6], [-0.1, 0.02, -0.3]);
        let c = pose_from_xyz_rpy([0.0, 0.0, 2.0], [0.0, 0.0, 3.0]);
        let stored = mounts(Source::Json, &[("a", a), ("b", b), ("c", c)]);
        // b turned 0.5 deg about its own z; c shifted 4 mm.
        let yaw = pose_from_xyz_rpy([0.0; 3], [0.0, 0.0, 0.5f64.to_radians()]);
        let shift = Pose::translation(0.004, 0.0, 0.0);
        let new = mounts(Source::Json, &[("a", a), ("b", b * yaw), ("c", shift * c)]);
        let drift = compare(&stored, &new, &Tolerance::default()).unwrap();
        assert_eq!(drift.reference, "a");
        let [db, dc] = [&drift.sensors[0], &drift.sensors[1]];
        assert!((db.angle.to_degrees() - 0.5).abs() < 1e-9, "{}", db.angle.to_degrees());
        assert!(db.distance < 1e-12 && db.moved);
        assert!((dc.distance - 0.004).abs() < 1e-12 && dc.angle < 1e-12 && !dc.moved);
        assert!(!drift.passed());
        // The same change relative to a reference whose nominal differs: unchanged.
        let offset = pose_from_xyz_rpy([0.2, 0.0, 0.0], [0.0, 0.0, 0.2]);
        let shifted =
            mounts(Source::Json, &[("a", offset * a), ("b", offset * b), ("c", offset * c)]);
        let drift = compare(&shifted, &new, &Tolerance::default()).unwrap();
        assert!((drift.sensors[0].angle.to_degrees() - 0.5).abs() < 1e-9);
        assert!((drift.sensors[1].distance - 0.004).abs() < 1e-9);
    }

    #[test]
    fn a_change_within_both_calibrations_scatter_is_not_a_move() {
        let (a, b) = (Pose::identity(), Pose::translation(0.0, 1.0, 0.0));
        // 0.2 deg and 18 mm apart, each calibration good to 0.1 deg / 10 mm per axis.
        let turned = pose_from_xyz_rpy([0.018, 1.0, 0.0], [0.0, 0.0, 0.2f64.to_radians()]);
        let scatter = Precision { rotation: [0.1f64.to_radians(); 3], position: [0.01; 3] };
        let mut stored = mounts(Source::Json, &[("a", a), ("b", b)]);
        let mut new = mounts(Source::Json, &[("a", a), ("b", turned)]);
        // Without the precisions: beyond 0.1 deg / 1 cm, moved.
        let drift = compare(&stored, &new, &Tolerance::default()).unwrap();
        assert!(drift.sensors[0].moved && !drift.sensors[0].unresolved);
        // With them: within 3 combined sigmas (0.42 deg, 42 mm), unresolved, and it passes.
        stored.mounts[1].precision = Some(scatter);
        new.mounts[1].precision = Some(scatter);
        let drift = compare(&stored, &new, &Tolerance::default()).unwrap();
        assert!(!drift.sensors[0].moved && drift.sensors[0].unresolved);
        assert!(drift.passed());
        // A move beyond them is a move.
        let far = pose_from_xyz_rpy([0.06, 1.0, 0.0], [0.0, 0.0, 0.0]);
        new.mounts[1].extrinsic = far;
        let drift = compare(&stored, &new, &Tolerance::default()).unwrap();
        assert!(drift.sensors[0].moved && !drift.sensors[0].unresolved);
    }

    #[test]
    fn sigmas_combine_both_precisions_and_missing_sensors_fail() {
        let a = Pose::identity();
        let b = Pose::translation(0.0, 1.0, 0.0);
        let precision = Precision { rotation: [1e-4; 3], position: [1e-3; 3] };
        let mut stored = mounts(Source::Json, &[("a", a), ("b", b), ("gone", a)]);
        stored.mounts[1].precision = Some(precision);
        let mut new = mounts(Source::Json, &[("a", a), ("b", Pose::translation(0.005, 1.0, 0.0))]);
        new.mounts[1].precision = Some(precision);
        let tolerance = Tolerance::Precision { sigmas: 3.0, rotation: 1.0, translation: 1.0 };
        let drift = compare(&stored, &new, &tolerance).unwrap();
        let Limit::Sigmas { position, .. } = drift.sensors[0].limit else { panic!() };
        assert!((position[0] - 3.0 * 2f64.sqrt() * 1e-3).abs() < 1e-12);
        assert!(drift.sensors[0].moved, "5 mm is beyond 4.2 mm");
        assert_eq!(drift.missing, ["gone"]);
        // A tree's other frames are not missing sensors.
        stored.source = Source::Urdf;
        assert!(compare(&stored, &new, &tolerance).unwrap().missing.is_empty());
        stored.mounts.remove(0);
        assert_eq!(
            compare(&stored, &new, &tolerance).unwrap_err(),
            CompareError::NoReference { reference: "a".into() }
        );
    }
}
