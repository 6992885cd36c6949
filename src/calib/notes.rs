//! What a calibration has to say besides its poses, as data: each note a typed kind with its
//! numbers. The sentences are made at the edge (`report`, and the page from the JSON).

use crate::icp;

/// A note on one sensor: on one of its frames, or (`frame` `None`) on all of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Note {
    pub sensor: String,
    pub frame: Option<String>,
    pub kind: NoteKind,
}

/// The ground window the plane adjustment kept: how far (m) above the reference's ground its
/// ground reached, and how far apart the sensors' grounds lay (root mean square, m) with it
/// and with the window it left (`None` where no two sensors share ground).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundWindow {
    pub above: f64,
    pub apart: Option<f64>,
    pub other: Option<f64>,
}

/// Angles in rad, distances in m.
#[derive(Clone, Debug, PartialEq)]
pub enum NoteKind {
    /// The scan was left out: it has no valid point at all (every point NaN or zero, or an
    /// empty file).
    NoValidPoints,
    /// The view was left out: too few points in the ROI.
    TooFewPoints { points: usize, needed: usize },
    /// The view was left out: all its points in the ROI coincide.
    PointsCoincide,
    /// The frame was left out of the average: this far from the other frames.
    FrameOutlier { angle: f64, distance: f64 },
    /// The frame pair's ICP failed (the error's own message): the frame is left out.
    PairFailed { metric: icp::Metric, error: String },
    /// `gmm`'s refinement moved the frame this far from JRMPC's correction, beyond `limit`:
    /// the frame keeps JRMPC's correction.
    RefinementDeparted { angle: f64, distance: f64, limit: (f64, f64) },
    /// The plane adjustment moved every frame of the sensor by this much, from `points`
    /// points on planes, with the ground `window` it kept.
    PlanesApplied { angle: f64, shift: f64, points: usize, window: GroundWindow },
    /// JRMPC's correction tilted the frame's up axis by `angle` (rad), beyond `limit`, against
    /// the ground levelling had fixed: left out, the refinement started from the levelled
    /// pre-alignment.
    StartTilted { angle: f64, limit: f64 },
    /// The plane adjustment found none of the sensor's points on planes; the refinement stays.
    PlanesWithoutPoints,
    /// The plane adjustment's motion went beyond `limit`; the refinement stays.
    PlanesRejected { angle: f64, shift: f64, limit: (f64, f64) },
}

/// Why a sensor was not levelled.
#[derive(Clone, Debug, PartialEq)]
pub enum LevellingSkipped {
    /// No ground plane in the box around the ROI.
    NoGround,
    /// The reference sensor shows no ground plane.
    ReferenceWithoutGround { reference: String },
    /// Levelled (and searched), the sensor's scans landed worse on the others' than from its
    /// start: the selection kept the start.
    ScoredWorse,
}

/// What the bird's-eye search suggests the user check: each points at a nominal extrinsic
/// further off than the search covers (`range`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BevWarning {
    /// No structure above the ground to overlay (or none near the ROI).
    NothingToOverlay { range: SearchRange },
    /// At the best overlay only this share of the sensor's structure lands on the reference's.
    LowOverlap { share: f64, range: SearchRange },
    /// The best overlay lies on the border of the range searched.
    AtEdge { range: SearchRange },
}

/// The range a search covers, either side: yaw (rad) and shift (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchRange {
    pub yaw: f64,
    pub shift: f64,
}
