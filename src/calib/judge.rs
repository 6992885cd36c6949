//! Judging a calibration: the verdict on each sensor drawn from its result, the evidence
//! measured after the calibration, the selection and the loops; the verdict on the
//! reconstruction; and, after a comparison, which methods agree. The levels and what they
//! promise are `verdict`'s; this module applies them.

use super::evidence::{Agreement, SensorEvidence};
use super::global::GlobalAlignment;
use super::loops::{self, LoopGap};
use super::notes::{BevWarning, LevellingSkipped};
use super::planes::Precision;
use super::result::{Calibration, SensorResult};
use super::select::{GroundAgreement, SensorSelection, Source};
use super::verdict::*;
use crate::targets::{ShapeFit, Target};

/// What the verdict on one sensor is drawn from.
pub(super) struct SensorInputs<'a> {
    pub result: &'a SensorResult,
    pub evidence: Option<SensorEvidence>,
    pub frames: usize,
    pub left_out: usize,
    /// The selection among the stages' hypotheses, and the `z` it decided with.
    pub selection: Option<&'a SensorSelection>,
    /// Its ground against the others', patch by patch.
    pub ground: Option<GroundAgreement>,
    /// Each other sensor but the reference it overlaps, registered to it alone from the
    /// result: the other's name, the gap and the other's precision.
    pub loops: Vec<(String, &'a LoopGap, Option<&'a Precision>)>,
    pub z: f64,
    pub empty: usize,
    pub same_scans: Option<String>,
    pub warning: Option<BevWarning>,
    pub not_levelled: Option<LevellingSkipped>,
    pub global: Option<&'a GlobalAlignment>,
    /// The other non-reference sensor whose scans this one overlaps most, and the share of
    /// its points overlapping them: a chain's next link, when the reference is not one.
    pub neighbour: Option<(String, f64)>,
}

/// Judges one sensor among `others`, each with the share of this sensor's points beside its
/// surfaces at the result.
pub(super) fn judge_sensor(inputs: SensorInputs, others: &[(&SensorResult, f64)]) -> SensorVerdict {
    let mut reasons = Vec::new();
    let mut say = |level: Level, kind: ReasonKind| reasons.push(Reason { level, kind });
    let result = inputs.result;
    if let Some(other) = inputs.same_scans {
        say(Level::Failed, ReasonKind::SameScans { other });
    }
    for &(other, shared) in others {
        let d = other.extrinsic.inverse() * result.extrinsic;
        let (angle, distance) = (d.rotation.angle(), d.translation.vector.norm());
        if distance < SAME_PLACE.0 && angle < SAME_PLACE.1 && shared >= SAME_VIEW {
            let other = other.name.clone();
            say(Level::Failed, ReasonKind::SamePlace { other, angle, distance });
        }
    }
    if let Some(e) = &inputs.evidence {
        judge_evidence(e, inputs.neighbour, &mut say);
    }
    if inputs.empty > 0 {
        say(Level::Check, ReasonKind::EmptyScans { scans: inputs.empty });
    }
    if inputs.left_out > 0 {
        let of = inputs.frames + inputs.left_out;
        let level = if 2 * inputs.left_out >= of { Level::Check } else { Level::Good };
        say(level, ReasonKind::FramesLeftOut { frames: inputs.left_out, of });
    }
    if let Some(selection) = inputs.selection {
        judge_selection(selection, inputs.z, &mut say);
    }
    if let Some(g) = inputs.ground.filter(|g| g.patches >= MIN_GROUND_PATCHES) {
        // `good` needs the grounds within its promise as measured; `failed` needs them beyond
        // `check`'s by more than the selection's test allows for chance, so that a right result
        // whose few patches scatter is not thrown away.
        let level = if g.beyond(USABLE_WITHIN, inputs.z) {
            Level::Failed
        } else if g.beyond(GOOD_WITHIN, 0.0) {
            Level::Check
        } else {
            Level::Good
        };
        say(level, ReasonKind::GroundApart(g));
    }
    for (other, gap, theirs) in &inputs.loops {
        let own = result.precision.as_ref();
        if loops::is_open(gap, [own, *theirs], METHODS_AGREE, LOOP_SIGMAS) {
            let (angle, distance) = (gap.angle(), gap.distance());
            say(Level::Check, ReasonKind::LoopOpen { other: other.clone(), angle, distance });
        }
    }
    if let Some(w) = inputs.warning {
        say(Level::Check, ReasonKind::Search(w));
    }
    if let Some(skipped) = inputs.not_levelled {
        say(Level::Good, ReasonKind::NotLevelled(skipped));
    }
    let mut supported = false;
    if let Some(g) = inputs.global {
        if let Some(why) = g.skipped {
            say(Level::Good, ReasonKind::GlobalSkipped(why));
        }
        if let Some(overlay) = &g.overlay {
            let ambiguity = overlay.ambiguity();
            supported = overlay.best.score >= SUPPORTED_OVERLAY && ambiguity <= AMBIGUOUS;
        }
    }
    let moved = &result.correction;
    let (angle, distance) = (moved.rotation.angle(), moved.translation.vector.norm());
    if angle > FAR_FROM_NOMINAL.0 || distance > FAR_FROM_NOMINAL.1 {
        let level = if supported { Level::Good } else { Level::Check };
        say(level, ReasonKind::FarFromNominal { angle, distance, supported });
    }
    reasons.sort_by_key(|r| std::cmp::Reverse(r.level));
    SensorVerdict {
        sensor: result.name.clone(),
        level: reasons.iter().map(|r| r.level).max().unwrap_or(Level::Good),
        reasons,
        evidence: inputs.evidence,
    }
}

/// What the selection says: the nominal kept, a placement the scans contradict, a rival
/// placement the scans cannot rule out, a method's own result worse than its nominal.
fn judge_selection(selection: &SensorSelection, z: f64, say: &mut impl FnMut(Level, ReasonKind)) {
    let chosen = selection.chosen();
    let nominal = selection.nominal();
    if chosen.source == Source::Nominal && selection.hypotheses.len() > 1 {
        say(Level::Check, ReasonKind::NominalKept { share: nominal.score.value() });
    }
    // Below zero the free space outweighs the landing: right placements put one point in
    // another's free space per ten landing or fewer, chance overlays one per two to four.
    if chosen.score.value() < 0.0 {
        let (landing, contradiction) = (chosen.score.landing(), chosen.score.contradiction());
        say(Level::Failed, ReasonKind::Contradicted { landing, contradiction });
    }
    if nominal.score.beats(&chosen.score, z) {
        let (share, nominal) = (chosen.score.value(), nominal.score.value());
        say(Level::Failed, ReasonKind::WorseThanNominal { share, nominal });
    }
    if let Some(rival) = selection.rival(z) {
        let d = chosen.correction.inverse() * rival.correction;
        let (angle, distance) = (d.rotation.angle(), d.translation.vector.norm());
        let (share, chosen) = (rival.score.value(), chosen.score.value());
        // Another placement the scans cannot rule out, beyond the refinement's reach: the result
        // may be that far off.
        say(
            Level::Failed,
            ReasonKind::Rival { source: rival.source, angle, distance, share, chosen },
        );
    }
}

/// The reasons the measurements give.
fn judge_evidence(
    e: &SensorEvidence,
    neighbour: Option<(String, f64)>,
    say: &mut impl FnMut(Level, ReasonKind),
) {
    let a: &Agreement = &e.after;
    // Nothing to stand on: neither a share of the scan nor points enough to judge. A unit that
    // overlaps its reference in a strip (a Mid-100's, a few degrees) shares little of its scan
    // by design; enough points in that strip are judged like any overlap.
    if a.overlap() < MIN_OVERLAP && a.overlapping < MIN_OVERLAPPING {
        // A neighbour whose overlap would have passed names the reference to choose.
        let neighbour = neighbour.filter(|(_, share)| *share >= MIN_OVERLAP);
        let (overlap, overlapping) = (a.overlap(), a.overlapping);
        let kind = ReasonKind::NothingOverlaps { overlap, overlapping, neighbour };
        say(Level::Failed, kind);
        return;
    }
    if a.overlapping < MIN_OVERLAPPING {
        say(Level::Check, ReasonKind::FewPoints { overlapping: a.overlapping });
        return;
    }
    // The structure fixes yaw and the shift; the ground agrees after any levelling.
    let (after, before) = if a.structure[1] >= MIN_OVERLAPPING {
        (a.structure_share(), e.before.structure_share())
    } else {
        (a.share(), e.before.share())
    };
    let level = match after {
        s if s < FAILED_AGREEMENT => Level::Failed,
        s if s < GOOD_AGREEMENT => Level::Check,
        _ => Level::Good,
    };
    say(level, ReasonKind::Agreement { after, before, tolerance: a.tolerance });
    let o = &e.observability;
    let axes = |rotation: f64, translation: f64| -> Vec<Axis> {
        Axis::ALL
            .into_iter()
            .filter(|axis| match axis.index() {
                i @ 0..3 => o.rotation[i] > rotation,
                i => o.translation[i - 3] > translation,
            })
            .collect()
    };
    let free = axes(FREE_ROTATION, FREE_TRANSLATION);
    let weak: Vec<Axis> =
        axes(WEAK_ROTATION, WEAK_TRANSLATION).into_iter().filter(|x| !free.contains(x)).collect();
    let level = if !free.is_empty() {
        Level::Failed
    } else if !weak.is_empty() {
        Level::Check
    } else {
        Level::Good
    };
    say(level, ReasonKind::Observability { free, weak, spread: *o });
}

/// Adds the consistency of the frames: their spread (per axis, rad and m) against what one
/// frame's data allow.
pub(super) fn judge_frames(
    verdict: &mut SensorVerdict,
    spread: ([f64; 3], [f64; 3]),
    frames: usize,
) {
    let Some(e) = &verdict.evidence else { return };
    if frames < 3 {
        return;
    }
    let f = &e.frame_observability;
    let rotation = spread.0.iter().copied().fold(0.0, f64::max);
    let translation = spread.1.iter().copied().fold(0.0, f64::max);
    let expected_r = f.rotation.iter().copied().fold(0.0, f64::max).max(1e-9);
    let expected_t = f.translation.iter().copied().fold(0.0, f64::max).max(1e-9);
    let ratio = (rotation / expected_r).max(translation / expected_t);
    let beyond = |(r, t): (f64, f64)| rotation > r || translation > t;
    let level = if beyond(FRAMES_FAILED) {
        Level::Failed
    } else if beyond(FRAMES_CHECK) {
        Level::Check
    } else {
        Level::Good
    };
    let kind = ReasonKind::FramesDisagree { ratio, rotation, translation };
    verdict.reasons.push(Reason { level, kind });
    verdict.reasons.sort_by_key(|r| std::cmp::Reverse(r.level));
    verdict.level = verdict.level.max(level);
}

/// The calibration-wide reasons: the reconstruction's fit, JRMPC's convergence.
pub(super) fn judge_reconstruction(
    target: &Target,
    fits: &[ShapeFit],
    reconstructed: bool,
    converged: Option<(bool, usize)>,
) -> Vec<Reason> {
    let mut reasons = Vec::new();
    // A target shape was given and none stands out: the region holds no such target (a road
    // scene with the default cube), so the registration had nothing it was told to expect.
    if reconstructed && fits.is_empty() {
        let level = if target.size().is_some() { Level::Check } else { Level::Good };
        reasons.push(Reason { level, kind: ReasonKind::NoTarget });
    }
    // Every target found fits badly: blurred, the views did not come together on any. One
    // half-seen target among sharp ones says nothing of the calibration.
    let blurred = !fits.is_empty() && fits.iter().all(|f| ReasonKind::fits_badly(target, f));
    for fit in fits {
        let level =
            if blurred && ReasonKind::fits_badly(target, fit) { Level::Check } else { Level::Good };
        reasons.push(Reason {
            level,
            kind: ReasonKind::TargetFit { target: target.clone(), fit: *fit },
        });
    }
    if let Some((false, iterations)) = converged {
        reasons.push(Reason { level: Level::Good, kind: ReasonKind::NotConverged { iterations } });
    }
    reasons
}

/// After a comparison: adds to each calibration's verdict which of the other methods agree
/// with it (information: the baselines are known to be worse, so their disagreement does not
/// lower a level).
pub(super) fn compare_methods(calibrations: &mut [&mut Calibration]) {
    let extrinsics: Vec<(&'static str, Vec<(String, crate::se3::Pose)>)> = calibrations
        .iter()
        .map(|c| {
            (c.method.name(), c.sensors.iter().map(|s| (s.name.clone(), s.extrinsic)).collect())
        })
        .collect();
    for (i, c) in calibrations.iter_mut().enumerate() {
        let (mut agree, mut differ) = (Vec::new(), Vec::new());
        for (_, (name, other)) in extrinsics.iter().enumerate().filter(|(j, _)| *j != i) {
            let (mut angle, mut distance) = (0.0f64, 0.0f64);
            for (sensor, pose) in &extrinsics[i].1 {
                if let Some((_, theirs)) = other.iter().find(|(s, _)| s == sensor) {
                    let d = pose.inverse() * theirs;
                    angle = angle.max(d.rotation.angle());
                    distance = distance.max(d.translation.vector.norm());
                }
            }
            if angle <= METHODS_AGREE.0 && distance <= METHODS_AGREE.1 {
                agree.push(*name);
            } else {
                differ.push((*name, angle, distance));
            }
        }
        let kind = ReasonKind::Methods { agree, differ };
        c.verdict.reasons.push(Reason { level: Level::Good, kind });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::evidence::Observability;

    /// Evidence on a sensor: `overlapping` of `points` beside the reference's surfaces, 80 %
    /// of them agreeing, every direction pinned to 0.01 deg / 1 mm.
    fn evidence(points: usize, overlapping: usize) -> SensorEvidence {
        let agreeing = overlapping * 4 / 5;
        let after = Agreement {
            points,
            overlapping,
            agreeing,
            structure: [points, overlapping, agreeing],
            radius: 0.3,
            tolerance: 0.03,
        };
        let pinned = Observability { rotation: [1e-4; 3], translation: [1e-3; 3] };
        SensorEvidence {
            sensor: "unit".into(),
            before: after,
            after,
            observability: pinned,
            frame_observability: pinned,
            noise: 0.01,
        }
    }

    /// The reasons said, each as its level and whether it is `NothingOverlaps`, `FewPoints`.
    fn levels(e: &SensorEvidence) -> Vec<(Level, &'static str)> {
        let mut said = Vec::new();
        judge_evidence(e, None, &mut |level, kind| {
            let name = match kind {
                ReasonKind::NothingOverlaps { .. } => "nothing",
                ReasonKind::FewPoints { .. } => "few",
                _ => "other",
            };
            said.push((level, name));
        });
        said
    }

    #[test]
    fn a_strip_of_overlap_with_points_enough_is_judged_not_failed() {
        // 4 % of the scan, 800 points: a narrow unit's strip, agreeing.
        let strip = levels(&evidence(20_000, 800));
        assert!(strip.iter().all(|(level, _)| *level == Level::Good), "{strip:?}");
        // 4 % and 100 points: nothing to stand on.
        let none = levels(&evidence(2_500, 100));
        assert_eq!(none, vec![(Level::Failed, "nothing")]);
        // A quarter of the scan but 100 points: too few to judge.
        let few = levels(&evidence(400, 100));
        assert_eq!(few, vec![(Level::Check, "few")]);
    }
}
