//! The verdict on a calibration: per sensor and overall, `good`, `check` or `failed`, with the
//! reasons in order of weight, each a typed kind with its numbers. `failed` means: do not use
//! this extrinsic. The evidence is measured after the calibration (`evidence`), so a verdict
//! never moves a result.
//!
//! The limits below were set on a labelled suite (`tests/calib/verdict.rs`: twin rigs within and
//! beyond the spec, and known-bad rigs) and are stated with what they catch there
//! (docs/accuracy.md, "The verdict").

use super::evidence::{Observability, SensorEvidence};
use super::global::GlobalSkip;
use super::notes::{BevWarning, LevellingSkipped};
use super::select::{GroundAgreement, Source};
use crate::targets::{ShapeFit, Target};

/// What `good` promises: within this (rad, m) of the truth. What `check` promises: within
/// `USABLE`; beyond it a result must read `failed`.
pub const GOOD_WITHIN: (f64, f64) = (0.1 * std::f64::consts::PI / 180.0, 0.01);
pub const USABLE_WITHIN: (f64, f64) = (1.0 * std::f64::consts::PI / 180.0, 0.1);
/// Fewest ground patches seen by two sensors to judge their grounds by.
pub const MIN_GROUND_PATCHES: usize = 3;

/// Below this share of a sensor's compared points overlapping the reference's surfaces, and
/// with fewer than [`MIN_OVERLAPPING`] of them, the result has nothing to stand on (the twin:
/// 0.28 or more; OpenCalib's raw guess: 0.00; a Mid-100's units, overlapping in a strip: 0.05
/// and a thousand points).
pub const MIN_OVERLAP: f64 = 0.05;
/// Fewest overlapping points to judge agreement by.
pub const MIN_OVERLAPPING: usize = 200;
/// Share of the overlapping structure that must lie within three noise widths of the
/// reference's surfaces (the twin within and beyond the spec: 0.61-0.74; another scene for one
/// sensor 0.20, frames shifted in time 0.04); below `FAILED_AGREEMENT` most of it is elsewhere.
pub const GOOD_AGREEMENT: f64 = 0.5;
pub const FAILED_AGREEMENT: f64 = 0.3;
/// A direction whose one-sigma spread exceeds these (rad, m) is not constrained by the data
/// (a region holding only ground: yaw and the shift come out at thousands of degrees and
/// metres); beyond the `WEAK_` limits it is constrained worse than a calibration should be
/// (the twin: 0.02 deg / 0.6 mm at most).
pub const FREE_ROTATION: f64 = 5.0 * std::f64::consts::PI / 180.0;
pub const FREE_TRANSLATION: f64 = 0.5;
pub const WEAK_ROTATION: f64 = 0.05 * std::f64::consts::PI / 180.0;
pub const WEAK_TRANSLATION: f64 = 0.005;
/// Frames whose corrections spread (one sigma, the largest axis) beyond these (rad, m)
/// disagree: a moving rig, a time offset, a bad frame. On the twin the refinement's per-frame
/// corrections spread up to 0.055 deg / 12.4 mm (GICP's bias differs from frame to frame, far
/// beyond what one frame's noise allows), so the limits sit above that.
pub const FRAMES_CHECK: (f64, f64) = (0.15 * std::f64::consts::PI / 180.0, 0.03);
pub const FRAMES_FAILED: (f64, f64) = (1.0 * std::f64::consts::PI / 180.0, 0.2);
/// A correction beyond this (rad, m) says the nominal was wrong, or the result is.
pub const FAR_FROM_NOMINAL: (f64, f64) = (20.0 * std::f64::consts::PI / 180.0, 1.0);
/// A global alignment whose runner-up scores this close to its best (runner-up over best) is
/// ambiguous: the scene allows another overlay almost as good (the twin's three cubes in a row:
/// 0.88 at most).
pub const AMBIGUOUS: f64 = 0.95;
/// A global overlay scoring at least this share supports a result far from the nominal
/// (OpenCalib's side LiDARs: 0.86-0.93).
pub const SUPPORTED_OVERLAY: f64 = 0.5;
/// Two sensors closer than this (m) and turned less than this (rad) are one sensor, when they
/// see one view (`SAME_VIEW`).
pub const SAME_PLACE: (f64, f64) = (0.01, 0.1 * std::f64::consts::PI / 180.0);
/// The share of a sensor's points beside another's surfaces from which two sensors at one
/// place see one view: one sensor given twice, or its frames taken for sensors. Units whose
/// driver gives their clouds in one frame (a Livox Mid-100's three) share a place and look
/// different ways, overlapping in a strip.
pub const SAME_VIEW: f64 = 0.5;
/// A fitted target whose size is off by more than this share, or whose RMS exceeds this share
/// of its size, fits badly.
pub const TARGET_SIZE_OFF: f64 = 0.2;
/// A mesh fits badly when less of the reconstructed target than this lies within a tenth of
/// its size of its surface (as a placement needs of the data).
const MESH_INLIERS: f64 = 0.7;
pub const TARGET_RMS: f64 = 0.1;

/// How many combined sigmas of the two sensors' precision a loop's gap must pass to be open.
pub const LOOP_SIGMAS: f64 = 3.0;
/// Two methods (two registrations) agree when every sensor's extrinsics are within this
/// (rad, m).
pub const METHODS_AGREE: (f64, f64) = (0.2 * std::f64::consts::PI / 180.0, 0.02);

/// How far to trust a result; in the JSON by its name.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    Good,
    Check,
    Failed,
}

impl Level {
    pub fn name(&self) -> &'static str {
        match self {
            Level::Good => "good",
            Level::Check => "check",
            Level::Failed => "failed",
        }
    }
}

/// One reason, with the level it sets and its numbers (angles in rad, lengths in m).
#[derive(Clone, Debug, PartialEq)]
pub struct Reason {
    pub level: Level,
    pub kind: ReasonKind,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ReasonKind {
    /// Too little of the sensor's structure overlaps the reference's after the calibration.
    NothingOverlaps { overlap: f64, overlapping: usize, neighbour: Option<(String, f64)> },
    /// Too few of the sensor's points overlap the reference's to judge agreement by.
    FewPoints { overlapping: usize },
    /// Share of the overlapping structure (all points where no ground is known) that lands on
    /// the reference's surfaces, after and before.
    Agreement { after: f64, before: f64, tolerance: f64 },
    /// Directions the data leave free (`free`) or constrain weakly, with their spreads.
    Observability { free: Vec<Axis>, weak: Vec<Axis>, spread: Observability },
    /// The frames' corrections spread `ratio` times what one frame's data allow.
    FramesDisagree { ratio: f64, rotation: f64, translation: f64 },
    /// Frames left out of the average (outliers, failed registrations).
    FramesLeftOut { frames: usize, of: usize },
    /// No stage's hypothesis landed the sensor's scans better on the others' than its
    /// nominal: the nominal is the answer (`share`: of its points landing).
    NominalKept { share: f64 },
    /// A placement elsewhere (another start's family) that the chosen one does not beat:
    /// `angle` (rad) and `distance` (m) away, landing `share` of the points against the
    /// chosen's `chosen`.
    Rival { source: Source, angle: f64, distance: f64, share: f64, chosen: f64 },
    /// The scans contradict the chosen placement: `contradiction` of its points stand where
    /// another sensor saw through, weighing more than the `landing` share on their surfaces
    /// (the selection's score below zero).
    Contradicted { landing: f64, contradiction: f64 },
    /// The method's own result lands the scans worse than the nominal did (`share` against
    /// the nominal's `nominal`): a paper method that slid away.
    WorseThanNominal { share: f64, nominal: f64 },
    /// The correction moves the sensor this far from its nominal; `supported` when a clear
    /// global alignment found the move (a tape-measure nominal, the data placed it).
    FarFromNominal { angle: f64, distance: f64, supported: bool },
    /// The global alignment was not applied to this sensor: why.
    GlobalSkipped(GlobalSkip),
    /// Where this sensor and another see the same patches of ground, their grounds lie `height`
    /// (m) and `tilt` (rad) apart, each with its one sigma, over `patches` patches.
    GroundApart(GroundAgreement),
    /// The sensor sits where `other` sits: one sensor twice, or one sensor's frames as sensors.
    SamePlace { other: String, angle: f64, distance: f64 },
    /// A scan of this sensor is a scan of `other`.
    SameScans { other: String },
    /// Scans without a single valid point (every point NaN or zero).
    EmptyScans { scans: usize },
    /// The bird's-eye search's warning.
    Search(BevWarning),
    /// Not levelled: why.
    NotLevelled(LevellingSkipped),
    /// JRMPC stopped at its iteration limit before the convergence test.
    NotConverged { iterations: usize },
    /// How the target's shape fits the reconstruction: information (a chair is not a cube).
    TargetFit { target: Target, fit: ShapeFit },
    /// No target stands out of the reconstruction.
    NoTarget,
    /// At its start (its nominal, or the global stage's placement) none of the sensor's
    /// points lie in the region: the user's (`given`), or the one found where the clouds
    /// overlap. The others were calibrated without it, and its nominal is kept.
    OutsideRegion { given: bool },
    /// Registered alone onto `other` (or it onto this one), from the result, the pair moved
    /// `angle` (rad) / `distance` (m): beyond what two registrations agree within and beyond
    /// both sensors' precision. The result does not hold together where the two overlap.
    LoopOpen { other: String, angle: f64, distance: f64 },
    /// Compared with the other methods that ran: those within `METHODS_AGREE` on every
    /// sensor, and the largest difference to each of the others (rad, m).
    Methods { agree: Vec<&'static str>, differ: Vec<(&'static str, f64, f64)> },
}

/// The verdict on one sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorVerdict {
    pub sensor: String,
    pub level: Level,
    /// In order of weight: the heaviest first.
    pub reasons: Vec<Reason>,
    /// The measurements the reasons come from (none for the reference).
    pub evidence: Option<SensorEvidence>,
}

/// The verdict on a calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// The worst sensor's, or a calibration-wide reason's.
    pub level: Level,
    /// Calibration-wide reasons (the reconstruction, convergence).
    pub reasons: Vec<Reason>,
    pub sensors: Vec<SensorVerdict>,
}

impl ReasonKind {
    /// A fitted target that fits badly: its size off, or its surface blurred.
    pub fn fits_badly(target: &Target, fit: &ShapeFit) -> bool {
        let Some(size) = target.size() else { return false };
        // A rigid mesh keeps its size; most of the target must lie on it instead.
        let off_the_mesh = matches!(target, Target::Mesh(_)) && fit.inlier_share < MESH_INLIERS;
        (fit.size - size).abs() > TARGET_SIZE_OFF * size
            || fit.rms > TARGET_RMS * size
            || off_the_mesh
    }
}

/// A direction of a sensor's motion: rotation about, or translation along, a vehicle axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    Roll,
    Pitch,
    Yaw,
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: [Axis; 6] = [Axis::Roll, Axis::Pitch, Axis::Yaw, Axis::X, Axis::Y, Axis::Z];

    pub fn index(&self) -> usize {
        *self as usize
    }

    pub fn name(&self) -> &'static str {
        ["roll", "pitch", "yaw", "x", "y", "z"][self.index()]
    }
}
