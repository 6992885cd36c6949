//! Sentences from the calibration's typed notes. `Display` for each note type, so the CLI, the
//! JSON's `reason` fields and the page read the same words.

use std::fmt;

use crate::calib::{BevWarning, LevellingSkipped, Method, NoteKind, SearchRange};

impl Method {
    /// What the method does, in a few words (the page's method picker).
    pub fn label(&self) -> &'static str {
        match self {
            Method::Gmm => "GMM + GICP refinement + plane adjustment",
            Method::Jrmpc => "plain JRMPC (the paper's method)",
            Method::Icp(crate::icp::Metric::PointToPoint) => "ICP point-to-point",
            Method::Icp(crate::icp::Metric::PointToPlane) => "ICP point-to-plane",
            Method::Icp(crate::icp::Metric::Gicp) => "GICP",
        }
    }
}

impl fmt::Display for NoteKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NoteKind::TooFewPoints { points, needed } => {
                write!(f, "{points} points in the ROI, need {needed}")
            }
            NoteKind::PointsCoincide => f.write_str("all points in the ROI coincide"),
            NoteKind::FrameOutlier { angle, distance } => write!(
                f,
                "left out of the average: {:.3} deg / {:.1} mm from the other frames",
                angle.to_degrees(),
                distance * 1e3
            ),
            NoteKind::PairFailed { metric, error } => {
                write!(f, "{} failed: {error}", metric.name())
            }
            NoteKind::RefinementDeparted { angle, distance, .. } => write!(
                f,
                "refinement moved {:.2} deg / {distance:.3} m from the JRMPC correction; kept \
                 that instead",
                angle.to_degrees()
            ),
            NoteKind::PlanesApplied { angle, shift, points } => write!(
                f,
                "plane adjustment: moved {:.4} deg / {:.2} mm ({points} points)",
                angle.to_degrees(),
                shift * 1e3
            ),
            NoteKind::PlanesWithoutPoints => {
                f.write_str("plane adjustment: no points on planes; kept the refinement")
            }
            NoteKind::PlanesRejected { angle, shift, .. } => write!(
                f,
                "plane adjustment moved {:.3} deg / {:.1} mm; kept the refinement",
                angle.to_degrees(),
                shift * 1e3
            ),
        }
    }
}

impl NoteKind {
    /// The kind's name in the JSON (`tooFewPoints`, `planesApplied`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            NoteKind::TooFewPoints { .. } => "tooFewPoints",
            NoteKind::PointsCoincide => "pointsCoincide",
            NoteKind::FrameOutlier { .. } => "frameOutlier",
            NoteKind::PairFailed { .. } => "pairFailed",
            NoteKind::RefinementDeparted { .. } => "refinementDeparted",
            NoteKind::PlanesApplied { .. } => "planesApplied",
            NoteKind::PlanesWithoutPoints => "planesWithoutPoints",
            NoteKind::PlanesRejected { .. } => "planesRejected",
        }
    }
}

impl fmt::Display for LevellingSkipped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LevellingSkipped::NoGround => f.write_str("no ground plane found near the ROI"),
            LevellingSkipped::ReferenceWithoutGround { reference } => {
                write!(f, "the reference sensor {reference} shows no ground plane")
            }
        }
    }
}

impl fmt::Display for SearchRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "yaw {:.0} deg, shift {:.2} m either way", self.yaw.to_degrees(), self.shift)
    }
}

impl fmt::Display for BevWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BevWarning::NothingToOverlay { range } => write!(
                f,
                "the bird's-eye search found no structure above the ground to overlay on the \
                 reference's: the nominal extrinsic may be far off (the search covers {range}), \
                 or no target stands near the ROI"
            ),
            BevWarning::LowOverlap { share, range } => write!(
                f,
                "seen from above, only {:.0} % of this sensor's structure lands on the \
                 reference's at the best overlay the search found ({range}): the nominal \
                 extrinsic may be further off than that; check it, and the result",
                100.0 * share
            ),
            BevWarning::AtEdge { range } => write!(
                f,
                "the bird's-eye search ended at the edge of its range ({range}): the nominal \
                 extrinsic may be further off than that; check it, and the result"
            ),
        }
    }
}

impl BevWarning {
    /// The warning's name in the JSON.
    pub fn name(&self) -> &'static str {
        match self {
            BevWarning::NothingToOverlay { .. } => "nothingToOverlay",
            BevWarning::LowOverlap { .. } => "lowOverlap",
            BevWarning::AtEdge { .. } => "atEdge",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_read_as_before() {
        let range = SearchRange { yaw: 10f64.to_radians(), shift: 0.75 };
        let edge = BevWarning::AtEdge { range }.to_string();
        assert!(edge.contains("edge of its range (yaw 10 deg, shift 0.75 m either way)"), "{edge}");
        let low = BevWarning::LowOverlap { share: 0.0, range }.to_string();
        assert!(low.contains("only 0 % of this sensor"), "{low}");
        let none = BevWarning::NothingToOverlay { range }.to_string();
        assert!(none.contains("no structure above the ground"), "{none}");
    }
}
