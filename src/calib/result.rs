//! What a calibration returns: typed values, no prose.

use super::bev::BevAlignment;
use super::global::GlobalAlignment;
use super::notes::{BevWarning, LevellingSkipped, Note};
use super::planes::Precision;
use super::select::SensorSelection;
use super::settings::Method;
use super::verdict::Verdict;
use crate::jrmpc;
use crate::plane::Plane;
use crate::se3::Pose;
use crate::targets::{Placement, ShapeFit};

/// Per-axis standard deviation of the per-frame corrections around their mean.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Spread {
    /// Translation, m.
    pub xyz: [f64; 3],
    /// Rotation about x, y, z (rad), from the rotation vector of `mean^-1 C(f)`.
    pub rpy: [f64; 3],
    /// Frames averaged.
    pub frames: usize,
}

#[derive(Clone, Debug)]
pub struct SensorResult {
    pub name: String,
    /// `C_ref_s`: maps this sensor's nominally pre-aligned points onto the reference's.
    pub correction: Pose,
    /// Corrected `T_vehicle_sensor = C_ref_s * T_vehicle_sensor_nominal`.
    pub extrinsic: Pose,
    /// `T_ref_s`: maps points from this sensor's frame into the reference sensor's frame.
    pub relative: Pose,
    pub spread: Spread,
    /// `gmm`: the plane adjustment's one-sigma uncertainty, when it applied its motion.
    pub precision: Option<Precision>,
}

/// The reconstructed target: the final mixture, mapped into the reference sensor's
/// pre-aligned (vehicle) frame by the mean of the reference views' JRMPC poses.
#[derive(Clone, Debug, Default)]
pub struct Reconstruction {
    pub means: Vec<[f64; 3]>,
    /// Standard deviations (m).
    pub sigmas: Vec<f64>,
    pub priors: Vec<f64>,
    /// The target's shape fitted to each target among the means, off the reference's ground,
    /// largest first (empty for the ICP methods, which reconstruct nothing).
    pub fits: Vec<ShapeFit>,
    /// Where a CAD-model target was found standing in the reference's data, before any
    /// registration (`T_vehicle_model` per copy, best first); empty for the other targets.
    pub placements: Vec<Placement>,
}

/// The ground of one sensor and the levelling applied to its points.
#[derive(Clone, Debug, PartialEq)]
pub struct Levelling {
    pub sensor: String,
    /// The sensor's ground plane, in the nominal vehicle frame (before levelling).
    pub ground: Option<Plane>,
    /// Points on it (all frames).
    pub inliers: usize,
    /// The motion applied to the sensor's pre-aligned points before cropping: the levelling,
    /// then the bird's-eye search's; identity when either this sensor's or the reference's
    /// ground was not found.
    pub motion: Pose,
    /// The bird's-eye search's yaw and shift (non-reference sensors with a ground, when on).
    pub bev: Option<BevAlignment>,
    /// Why nothing was applied, if nothing was.
    pub skipped: Option<LevellingSkipped>,
    /// What the user should check, if anything: a bird's-eye search that suggests the nominal
    /// is further off than it reaches.
    pub warning: Option<BevWarning>,
}

#[derive(Clone, Debug)]
pub struct Calibration {
    pub method: Method,
    pub reference: String,
    pub sensors: Vec<SensorResult>,
    pub reconstruction: Reconstruction,
    pub iterations: usize,
    pub converged: bool,
    pub cancelled: bool,
    /// JRMPC ran with its exact E-step ([`crate::jrmpc::EmSettings::exact`]).
    pub exact: bool,
    /// Views left out (too few points in the ROI, failed registration, outliers).
    pub skipped: Vec<Note>,
    /// Per non-reference sensor, every stage's hypothesis, scored, and the one chosen.
    pub selection: Vec<SensorSelection>,
    /// `gmm`'s plane adjustment, per non-reference sensor: the motion it applied to every
    /// frame, or why the refinement was kept; empty when it is off.
    pub plane_adjustment: Vec<Note>,
    /// Per sensor, the ground found and the levelling applied; empty when levelling is off.
    pub levelling: Vec<Levelling>,
    /// Per sensor, the global alignment from the nominal; empty when it is off.
    pub global: Vec<GlobalAlignment>,
    /// The region cropped to (m, vehicle frame): the rig's, or where the sensors' clouds
    /// overlap.
    pub roi: crate::cloud::Aabb,
    pub roi_source: super::region::RoiSource,
    pub history: Vec<jrmpc::IterationStats>,
    /// How far to trust the result, and why.
    pub verdict: Verdict,
}
