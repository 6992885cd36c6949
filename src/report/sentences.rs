//! Sentences from the calibration's typed notes. `Display` for each note type, so the CLI, the
//! JSON's `reason` fields and the page read the same words.

use std::fmt;

use crate::calib::verdict;
use crate::calib::{Axis, BevWarning, LevellingSkipped, Method, NoteKind, ReasonKind, SearchRange};

impl Method {
    /// What the method does, in a few words (the page's method picker).
    pub fn label(&self) -> &'static str {
        match self {
            Method::Gmm => "GMM + GICP refinement + plane adjustment",
            Method::Jrmpc => "plain JRMPC (the paper's method)",
            Method::Cad => "CADCalib: every sensor onto the placed target model",
            Method::Icp(crate::icp::Metric::PointToPoint) => "ICP point-to-point",
            Method::Icp(crate::icp::Metric::PointToPlane) => "ICP point-to-plane",
            Method::Icp(crate::icp::Metric::Gicp) => "GICP",
        }
    }
}

impl fmt::Display for NoteKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NoteKind::NoValidPoints => {
                f.write_str("no valid point: every point is NaN or zero (or the file is empty)")
            }
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
            NoteKind::StartTilted { angle, limit } => write!(
                f,
                "JRMPC's correction tilted the frame {:.1} deg against the levelled ground \
                 (more than {:.0} deg): left out, the refinement started from the levelling",
                angle.to_degrees(),
                limit.to_degrees()
            ),
            NoteKind::PlanesApplied { angle, shift, points, window } => {
                write!(
                    f,
                    "plane adjustment: moved {:.4} deg / {:.2} mm ({points} points; ground up \
                     to {:.0} cm above the reference's",
                    angle.to_degrees(),
                    shift * 1e3,
                    window.above * 1e2
                )?;
                if let (Some(apart), Some(other)) = (window.apart, window.other) {
                    write!(
                        f,
                        ", where the sensors' grounds lie {:.1} mm apart against {:.1} mm with \
                         the other window",
                        apart * 1e3,
                        other * 1e3
                    )?;
                }
                f.write_str(")")
            }
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
            NoteKind::NoValidPoints => "noValidPoints",
            NoteKind::TooFewPoints { .. } => "tooFewPoints",
            NoteKind::PointsCoincide => "pointsCoincide",
            NoteKind::FrameOutlier { .. } => "frameOutlier",
            NoteKind::PairFailed { .. } => "pairFailed",
            NoteKind::RefinementDeparted { .. } => "refinementDeparted",
            NoteKind::StartTilted { .. } => "startTilted",
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
            LevellingSkipped::ScoredWorse => {
                f.write_str("levelled, its scans landed worse on the others' than from its start")
            }
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

fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

fn axes(list: &[Axis]) -> String {
    list.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
}

impl fmt::Display for ReasonKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReasonKind::NothingOverlaps { overlap, overlapping, neighbour } => {
                write!(
                    f,
                    "after the calibration only {:.0} % of this sensor's points ({overlapping}) \
                     lie near the reference's surfaces: nothing supports this extrinsic",
                    100.0 * overlap
                )?;
                match neighbour {
                    Some((other, share)) => write!(
                        f,
                        "; it overlaps {other}'s scans ({:.0} % of its points), not the \
                         reference's: calibrate with {other} as the reference",
                        100.0 * share
                    ),
                    None => write!(
                        f,
                        " (a nominal far off, another scene, or a region of interest the \
                         sensors do not share)"
                    ),
                }
            }
            ReasonKind::FewPoints { overlapping } => write!(
                f,
                "only {overlapping} of this sensor's points overlap the reference's surfaces: \
                 too few to judge the result by"
            ),
            ReasonKind::Agreement { after, before, tolerance } => write!(
                f,
                "{:.0} % of the overlapping structure lands within {:.1} cm of the reference's \
                 surfaces ({:.0} % before the calibration)",
                100.0 * after,
                100.0 * tolerance,
                100.0 * before
            ),
            ReasonKind::Observability { free, weak, spread } => {
                let sigma = format!(
                    "the structure alone, one sigma at the overlap's centre: roll, pitch, yaw \
                     {:.3} {:.3} {:.3} deg; x, y, z {:.1} {:.1} {:.1} mm",
                    deg(spread.rotation[0]),
                    deg(spread.rotation[1]),
                    deg(spread.rotation[2]),
                    1e3 * spread.translation[0],
                    1e3 * spread.translation[1],
                    1e3 * spread.translation[2]
                );
                if !free.is_empty() {
                    write!(
                        f,
                        "the data leave {} unconstrained: the structure in the region of \
                         interest cannot fix them (only ground, one wall, a symmetric target)",
                        axes(free)
                    )
                } else if !weak.is_empty() {
                    write!(f, "the data constrain {} only weakly ({sigma})", axes(weak))
                } else {
                    write!(f, "every direction is constrained ({sigma})")
                }
            }
            ReasonKind::FramesDisagree { ratio, rotation, translation } => write!(
                f,
                "the frames' corrections spread {:.3} deg / {:.1} mm, {ratio:.1} times what one \
                 frame's noise allows{}",
                deg(*rotation),
                1e3 * translation,
                if *rotation > verdict::FRAMES_CHECK.0 || *translation > verdict::FRAMES_CHECK.1 {
                    ": a moving rig or target, a time offset between sensors, or a bad frame"
                } else {
                    ""
                }
            ),
            ReasonKind::FramesLeftOut { frames, of } => {
                write!(f, "{frames} of {of} frames left out (see the notes)")
            }
            ReasonKind::NominalKept { share } => write!(
                f,
                "no stage landed the scans better on the others' than the nominal (it scores \
                 {:.0} %): the nominal is the answer",
                100.0 * share
            ),
            ReasonKind::Contradicted { landing, contradiction } => write!(
                f,
                "{:.1} % of its points stand where another sensor saw through, against {:.1} % \
                 landing on their surfaces: the scans contradict this placement (a wrong \
                 result, or a scene that changed between the sensors' views)",
                100.0 * contradiction,
                100.0 * landing
            ),
            ReasonKind::Rival { source, angle, distance, share, chosen } => write!(
                f,
                "the scans cannot rule out another placement {:.1} deg / {distance:.2} m away \
                 (the {} hypothesis: {:.0} % of the points land, against {:.0} % for the \
                 result): a symmetric scene; check the sensor landed where it sits",
                deg(*angle),
                source.name(),
                100.0 * share,
                100.0 * chosen
            ),
            ReasonKind::WorseThanNominal { share, nominal } => write!(
                f,
                "the result lands the scans worse on the others' than the nominal did ({:.0} % \
                 against {:.0} %): the method slid away",
                100.0 * share,
                100.0 * nominal
            ),
            ReasonKind::FarFromNominal { angle, distance, supported: true } => write!(
                f,
                "the result is {:.1} deg / {distance:.2} m from the nominal, where the global \
                 alignment placed the sensor: the nominal was off",
                deg(*angle)
            ),
            ReasonKind::FarFromNominal { angle, distance, supported: false } => write!(
                f,
                "the result is {:.1} deg / {distance:.2} m from the nominal: the nominal was \
                 wrong, or the result is wrong",
                deg(*angle)
            ),
            ReasonKind::GlobalSkipped(why) => write!(f, "not aligned globally: {why}"),
            ReasonKind::GroundApart(g) => write!(
                f,
                "where it and another sensor see the same ground ({} patches of 2 m), the \
                 grounds lie {:.1} ± {:.1} mm and {:.3} ± {:.3} deg apart (one sigma)",
                g.patches,
                1e3 * g.height,
                1e3 * g.height_sigma,
                deg(g.tilt),
                deg(g.tilt_sigma)
            ),
            ReasonKind::LoopOpen { other, angle, distance } => write!(
                f,
                "registered alone against {other}, from this result, the pair moves {:.2} deg \
                 / {:.1} cm: the two do not agree where they overlap (one of them, or both, is \
                 placed wrongly)",
                deg(*angle),
                1e2 * distance
            ),
            ReasonKind::SamePlace { other, angle, distance } => write!(
                f,
                "this sensor sits where {other} sits ({:.1} mm, {:.3} deg apart): the same \
                 sensor twice, or one sensor's frames taken for several sensors",
                1e3 * distance,
                deg(*angle)
            ),
            ReasonKind::SameScans { other } => {
                write!(f, "a scan of this sensor is, point for point, a scan of {other}")
            }
            ReasonKind::EmptyScans { scans } => {
                write!(f, "{scans} scan(s) without a valid point (every point NaN or zero)")
            }
            ReasonKind::Search(warning) => write!(f, "{warning}"),
            ReasonKind::NotLevelled(why) => write!(f, "not levelled: {why}"),
            ReasonKind::NotConverged { iterations } => {
                write!(f, "JRMPC stopped at its limit of {iterations} iterations before converging")
            }
            ReasonKind::TargetFit { target, fit } if fit.shape == "mesh" => write!(
                f,
                "the mesh ({:.2} m across) fits a reconstructed target with RMS {:.1} mm, {:.0} % \
                 of it within {:.0} mm{}",
                fit.size,
                1e3 * fit.rms,
                1e2 * fit.inlier_share,
                1e2 * fit.size,
                if ReasonKind::fits_badly(target, fit) {
                    "; it fits badly: another shape, or a blurred reconstruction"
                } else {
                    ""
                }
            ),
            ReasonKind::TargetFit { target, fit } => {
                let size = if fit.shape == "sphere" { "diameter" } else { "edge" };
                write!(
                    f,
                    "a {} of {size} {:.3} m fits a reconstructed target with RMS {:.1} mm ({} \
                     given: {:.3} m){}",
                    fit.shape,
                    fit.size,
                    1e3 * fit.rms,
                    target.kind(),
                    target.size().unwrap_or(fit.size),
                    if ReasonKind::fits_badly(target, fit) {
                        "; it fits badly: another shape, or a blurred reconstruction"
                    } else {
                        ""
                    }
                )
            }
            ReasonKind::NoTarget => f.write_str("no target stands out of the reconstruction"),
            ReasonKind::OutsideRegion { given } => write!(
                f,
                "at its start (its nominal, or the global alignment's placement of it) none of \
                 its points lie {}: the others were calibrated without it and its nominal is \
                 kept; give a closer nominal, or a ROI around what it and the reference both see",
                if *given { "in the ROI" } else { "where the other sensors' clouds overlap" }
            ),
            ReasonKind::Methods { agree, differ } => {
                let agree = if agree.is_empty() { "none".into() } else { agree.join(", ") };
                let differ: Vec<String> = differ
                    .iter()
                    .map(|(m, a, d)| format!("{m} by {:.2} deg / {:.1} cm", deg(*a), 1e2 * d))
                    .collect();
                write!(f, "methods that agree with this one: {agree}")?;
                if !differ.is_empty() {
                    write!(f, "; differ: {}", differ.join(", "))?;
                }
                Ok(())
            }
        }
    }
}

impl ReasonKind {
    /// The reason's name in the JSON.
    pub fn name(&self) -> &'static str {
        match self {
            ReasonKind::NothingOverlaps { .. } => "nothingOverlaps",
            ReasonKind::FewPoints { .. } => "fewPoints",
            ReasonKind::Agreement { .. } => "agreement",
            ReasonKind::Observability { .. } => "observability",
            ReasonKind::FramesDisagree { .. } => "framesDisagree",
            ReasonKind::FramesLeftOut { .. } => "framesLeftOut",
            ReasonKind::NominalKept { .. } => "nominalKept",
            ReasonKind::Contradicted { .. } => "contradicted",
            ReasonKind::Rival { .. } => "rival",
            ReasonKind::WorseThanNominal { .. } => "worseThanNominal",
            ReasonKind::FarFromNominal { .. } => "farFromNominal",
            ReasonKind::GlobalSkipped(_) => "globalSkipped",
            ReasonKind::GroundApart { .. } => "groundApart",
            ReasonKind::LoopOpen { .. } => "loopOpen",
            ReasonKind::SamePlace { .. } => "samePlace",
            ReasonKind::SameScans { .. } => "sameScans",
            ReasonKind::EmptyScans { .. } => "emptyScans",
            ReasonKind::Search(_) => "search",
            ReasonKind::NotLevelled(_) => "notLevelled",
            ReasonKind::NotConverged { .. } => "notConverged",
            ReasonKind::TargetFit { .. } => "targetFit",
            ReasonKind::NoTarget => "noTarget",
            ReasonKind::OutsideRegion { .. } => "outsideRegion",
            ReasonKind::Methods { .. } => "methods",
        }
    }
}

impl fmt::Display for crate::calib::GlobalSkip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use crate::calib::GlobalSkip;
        match self {
            GlobalSkip::ReferenceGround(why) => write!(f, "the reference shows no ground ({why})"),
            GlobalSkip::Ground(why) => write!(f, "this sensor shows no ground ({why})"),
            GlobalSkip::NoStructure => {
                f.write_str("no structure above the ground in either scan to overlay")
            }
        }
    }
}

impl fmt::Display for crate::calib::up::NoGround {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use crate::calib::up::NoGround;
        match self {
            NoGround::TooFewPoints { points } => write!(f, "only {points} points"),
            NoGround::NonePlausible { planes } => {
                write!(f, "none of {planes} planes lies below the sensor at a plausible height")
            }
        }
    }
}

impl fmt::Display for crate::layout::Pairing {
    /// `up's frames paired by the nearest timestamp to down's (2 of 3; ...)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            crate::layout::Pairing::Timestamps { sensor, to, paired, of } => {
                write!(f, "{sensor}'s frames paired by the nearest timestamp to {to}'s")?;
                if paired < of {
                    write!(f, " ({paired} of {of}; the others have no scan of {to} near them)")?;
                }
                Ok(())
            }
            crate::layout::Pairing::InOrder { sensor, to, paired } => {
                write!(f, "{sensor}'s frames paired in name order with {to}'s ({paired})")
            }
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
