//! One result shape for programs: what `gmmcalib calibrate --json` writes and what the wasm
//! `calibrate` returns (docs/api.md). camelCase keys; matrices as 16 numbers, row-major; m and
//! rad. Notes carry their kind and their sentence.
//!
//! A `*Report` type here exists only where the JSON differs from the domain type: poses as 16
//! numbers with xyz / rpy beside them, notes and reasons with their sentences and named values,
//! the mixture's means flat, the EM history as columns, the global stage's candidates without
//! the motion each implies (their yaw and shift say it). Everything else serializes itself
//! (`ShapeFit`, `Spread`, `Precision`, `SensorEvidence`, `BevAlignment`, `RoiSource`, `Level`).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::calib::{
    Calibration, Level, Note, Precision, Reason, ReasonKind, SensorEvidence, SensorResult, Spread,
    Verdict,
};
use crate::se3::{to_row_major, xyz_rpy};

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Report {
    /// How far to trust the result, and why: read it first.
    pub verdict: VerdictReport,
    #[cfg_attr(feature = "ts", ts(type = "MethodName"))]
    pub method: &'static str,
    pub reference: String,
    pub iterations: usize,
    pub converged: bool,
    pub cancelled: bool,
    /// JRMPC ran with its exact E-step (`--exact`).
    pub exact: bool,
    pub sensors: Vec<SensorReport>,
    pub reconstruction: ReconstructionReport,
    /// Views left out.
    pub skipped: Vec<NoteReport>,
    /// Per non-reference sensor, every stage's hypothesis, scored on the whole scans, and the
    /// one chosen (docs/method.md, "Selection").
    pub selection: Vec<SelectionReport>,
    /// `gmm`'s plane adjustment per non-reference sensor (frame `all`): the motion applied, or
    /// why the refinement was kept; empty when it is off.
    pub plane_adjustment: Vec<NoteReport>,
    /// Per sensor, the ground found and the levelling applied before cropping (`gmm`; empty
    /// when levelling is off).
    pub levelling: Vec<LevellingReport>,
    /// Per sensor, the global alignment from the nominal (`gmm`; empty when off).
    pub global: Vec<GlobalReport>,
    /// The region cropped to (m, vehicle frame): the given one, else around the targets found,
    /// else where the clouds overlap.
    pub roi: RoiReport,
    pub history: HistoryReport,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct RoiReport {
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// `source`: `"given"`, `"targets"` (around the `found` objects of the target's shape
    /// found standing in the reference's scans) or `"overlap"` (the clouds' overlap).
    #[serde(flatten)]
    pub source: crate::calib::region::RoiSource,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct LevellingReport {
    pub sensor: String,
    /// The ground plane `[nx, ny, nz, d]` (`n . p + d = 0`, m) in the nominal vehicle frame;
    /// null when none was found.
    pub ground: Option<[f64; 4]>,
    /// Ground points found (all frames).
    pub inliers: usize,
    /// The motion applied to the pre-aligned points (levelling, then the bird's-eye search),
    /// row-major.
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub motion: [f64; 16],
    /// Why no levelling was applied, if none was.
    pub note: Option<String>,
    /// The bird's-eye search's yaw and shift, included in `motion`.
    pub bev: Option<crate::calib::BevAlignment>,
    /// What to check, if anything: a bird's-eye search that found nothing to overlay, little
    /// overlap, or its best at the edge of its range.
    pub warning: Option<String>,
    /// `nothingToOverlay`, `lowOverlap` or `atEdge`, with `warning`.
    pub warning_kind: Option<&'static str>,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct SensorReport {
    pub name: String,
    /// `C_ref_s`, row-major.
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub correction: [f64; 16],
    /// Corrected `T_vehicle_sensor`, row-major.
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub extrinsic: [f64; 16],
    /// `T_ref_s`, row-major.
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub relative: [f64; 16],
    /// Translation (m) of the corrected extrinsic.
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw (rad) of the corrected extrinsic.
    pub rpy: [f64; 3],
    /// Per-axis spread of the per-frame corrections (m, rad) over `frames` frames.
    pub spread: Spread,
    /// One sigma: rotation about the vehicle's x, y, z axes (rad), and the sensor's position
    /// (m); null where no plane adjustment or selection measured it.
    pub precision: Option<Precision>,
}

/// The reconstructed target: the mixture in the vehicle frame (where the reference sensor sees
/// it, by the mean of the reference views' poses).
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct ReconstructionReport {
    /// Component means, flat: x, y, z, x, y, z, ... (m).
    pub means: Vec<f64>,
    /// Component standard deviations (m).
    pub sigmas: Vec<f64>,
    pub priors: Vec<f64>,
    /// The target's shape fitted to each target off the ground, largest first.
    pub fits: Vec<crate::targets::ShapeFit>,
    /// Where a CAD-model target was found in the reference's data before registration, best
    /// first (empty for the other targets).
    pub placements: Vec<PlacementReport>,
}

/// One placed copy of a CAD-model target.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct PlacementReport {
    /// `T_vehicle_model`, row-major 4x4, and as xyz (m) and roll, pitch, yaw (rad).
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub pose: [f64; 16],
    pub xyz: [f64; 3],
    pub rpy: [f64; 3],
    /// The reference's points fitted, the share within the tolerance, their RMS distance (m).
    pub points: usize,
    pub inliers: f64,
    pub rms: f64,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct NoteReport {
    pub sensor: String,
    /// The frame, or `all` for a note on every frame of the sensor.
    pub frame: String,
    /// The note's kind (`tooFewPoints`, `frameOutlier`, `planesApplied`, ...).
    pub kind: &'static str,
    /// The note in words.
    pub reason: String,
}

/// Per EM iteration: mean sigma (m) and the largest transform change (rad or m).
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct HistoryReport {
    pub mean_sigma: Vec<f64>,
    pub max_change: Vec<f64>,
    /// Gaussian terms the E-step evaluated.
    pub terms: Vec<u64>,
}

impl From<&Calibration> for Report {
    fn from(c: &Calibration) -> Self {
        let t = &c.reconstruction;
        Report {
            verdict: VerdictReport::from(&c.verdict),
            method: c.method.name(),
            reference: c.reference.clone(),
            iterations: c.iterations,
            converged: c.converged,
            cancelled: c.cancelled,
            exact: c.exact,
            sensors: c.sensors.iter().map(SensorReport::from).collect(),
            reconstruction: ReconstructionReport {
                means: t.means.iter().flatten().copied().collect(),
                sigmas: t.sigmas.clone(),
                priors: t.priors.clone(),
                fits: t.fits.to_vec(),
                placements: t
                    .placements
                    .iter()
                    .map(|p| {
                        let (xyz, rpy) = xyz_rpy(&p.pose);
                        PlacementReport {
                            pose: to_row_major(&p.pose),
                            xyz,
                            rpy,
                            points: p.points,
                            inliers: p.inliers,
                            rms: p.rms,
                        }
                    })
                    .collect(),
            },
            skipped: notes(&c.skipped),
            selection: c.selection.iter().map(SelectionReport::from).collect(),
            plane_adjustment: notes(&c.plane_adjustment),
            levelling: c
                .levelling
                .iter()
                .map(|l| LevellingReport {
                    sensor: l.sensor.clone(),
                    ground: l.ground.map(|g| [g.normal.x, g.normal.y, g.normal.z, g.offset]),
                    inliers: l.inliers,
                    motion: to_row_major(&l.motion),
                    note: l.skipped.as_ref().map(ToString::to_string),
                    bev: l.bev,
                    warning: l.warning.as_ref().map(ToString::to_string),
                    warning_kind: l.warning.as_ref().map(|w| w.name()),
                })
                .collect(),
            global: c
                .sensors
                .iter()
                .zip(&c.global)
                .map(|(s, g)| GlobalReport {
                    sensor: s.name.clone(),
                    motion: to_row_major(&g.applied),
                    ground_tilt: g.ground.map(|x| x.tilt),
                    ground_height: g.ground.map(|x| x.height),
                    grounds_tried: g.grounds_tried,
                    overlay: g.overlay.as_ref().map(|o| OverlayReport {
                        best: candidate(&o.best),
                        runners_up: o.runners_up.iter().map(candidate).collect(),
                        ambiguity: o.ambiguity(),
                    }),
                    skipped: g.skipped.map(|why| why.to_string()),
                })
                .collect(),
            roi: RoiReport { min: c.roi.min, max: c.roi.max, source: c.roi_source },
            history: HistoryReport {
                mean_sigma: c.history.iter().map(|h| h.mean_sigma).collect(),
                max_change: c.history.iter().map(|h| h.max_change).collect(),
                terms: c.history.iter().map(|h| h.terms).collect(),
            },
        }
    }
}

impl From<&SensorResult> for SensorReport {
    fn from(s: &SensorResult) -> Self {
        let (xyz, rpy) = xyz_rpy(&s.extrinsic);
        SensorReport {
            name: s.name.clone(),
            correction: to_row_major(&s.correction),
            extrinsic: to_row_major(&s.extrinsic),
            relative: to_row_major(&s.relative),
            xyz,
            rpy,
            spread: s.spread,
            precision: s.precision,
        }
    }
}

fn notes(notes: &[Note]) -> Vec<NoteReport> {
    notes
        .iter()
        .map(|n| NoteReport {
            sensor: n.sensor.clone(),
            frame: n.frame.clone().unwrap_or_else(|| "all".into()),
            kind: n.kind.name(),
            reason: n.kind.to_string(),
        })
        .collect()
}

/// `good`, `check` or `failed`, with the reasons (heaviest first) and each sensor's own.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct VerdictReport {
    pub level: Level,
    /// Calibration-wide reasons.
    pub reasons: Vec<ReasonReport>,
    pub sensors: BTreeMap<String, SensorVerdictReport>,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct SensorVerdictReport {
    pub level: Level,
    pub reasons: Vec<ReasonReport>,
    /// The measurements (none for the reference sensor).
    pub evidence: Option<SensorEvidence>,
}

/// One reason: its kind, the level it sets, the sentence, and its numbers (rad, m, shares).
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct ReasonReport {
    pub kind: &'static str,
    pub level: Level,
    pub text: String,
    pub values: BTreeMap<&'static str, Value>,
}

/// A reason's value: a number, a name, or a list of names.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum Value {
    Number(f64),
    Text(String),
    Names(Vec<&'static str>),
}

impl From<&Verdict> for VerdictReport {
    fn from(v: &Verdict) -> Self {
        VerdictReport {
            level: v.level,
            reasons: v.reasons.iter().map(ReasonReport::from).collect(),
            sensors: v
                .sensors
                .iter()
                .map(|s| {
                    let report = SensorVerdictReport {
                        level: s.level,
                        reasons: s.reasons.iter().map(ReasonReport::from).collect(),
                        evidence: s.evidence.clone(),
                    };
                    (s.sensor.clone(), report)
                })
                .collect(),
        }
    }
}

impl From<&Reason> for ReasonReport {
    fn from(r: &Reason) -> Self {
        use Value::{Names, Number, Text};
        let values: Vec<(&'static str, Value)> = match &r.kind {
            ReasonKind::NothingOverlaps { overlap, overlapping, neighbour } => {
                let mut v = vec![
                    ("overlap", Number(*overlap)),
                    ("overlapping", Number(*overlapping as f64)),
                ];
                if let Some((other, share)) = neighbour {
                    v.push(("neighbour", Text(other.clone())));
                    v.push(("neighbourOverlap", Number(*share)));
                }
                v
            }
            ReasonKind::FewPoints { overlapping } => {
                vec![("overlapping", Number(*overlapping as f64))]
            }
            ReasonKind::Agreement { after, before, tolerance } => vec![
                ("after", Number(*after)),
                ("before", Number(*before)),
                ("tolerance", Number(*tolerance)),
            ],
            ReasonKind::Observability { free, weak, spread } => vec![
                ("free", Names(free.iter().map(|a| a.name()).collect())),
                ("weak", Names(weak.iter().map(|a| a.name()).collect())),
                ("spreadRoll", Number(spread.rotation[0])),
                ("spreadPitch", Number(spread.rotation[1])),
                ("spreadYaw", Number(spread.rotation[2])),
                ("spreadX", Number(spread.translation[0])),
                ("spreadY", Number(spread.translation[1])),
                ("spreadZ", Number(spread.translation[2])),
            ],
            ReasonKind::FramesDisagree { ratio, rotation, translation } => vec![
                ("ratio", Number(*ratio)),
                ("rotation", Number(*rotation)),
                ("translation", Number(*translation)),
            ],
            ReasonKind::FramesLeftOut { frames, of } => {
                vec![("frames", Number(*frames as f64)), ("of", Number(*of as f64))]
            }
            ReasonKind::NominalKept { share } => vec![("share", Number(*share))],
            ReasonKind::Contradicted { landing, contradiction } => {
                vec![("landing", Number(*landing)), ("contradiction", Number(*contradiction))]
            }
            ReasonKind::Rival { source, angle, distance, share, chosen } => vec![
                ("stage", Text(source.name().into())),
                ("angle", Number(*angle)),
                ("distance", Number(*distance)),
                ("share", Number(*share)),
                ("chosen", Number(*chosen)),
            ],
            ReasonKind::WorseThanNominal { share, nominal } => {
                vec![("share", Number(*share)), ("nominal", Number(*nominal))]
            }
            ReasonKind::FarFromNominal { angle, distance, supported } => vec![
                ("angle", Number(*angle)),
                ("distance", Number(*distance)),
                ("supported", Number(f64::from(u8::from(*supported)))),
            ],
            ReasonKind::GlobalSkipped(_) => vec![],
            ReasonKind::GroundApart(g) => vec![
                ("patches", Number(g.patches as f64)),
                ("height", Number(g.height)),
                ("tilt", Number(g.tilt)),
                ("heightSigma", Number(g.height_sigma)),
                ("tiltSigma", Number(g.tilt_sigma)),
            ],
            ReasonKind::LoopOpen { other, angle, distance } => vec![
                ("other", Text(other.clone())),
                ("angle", Number(*angle)),
                ("distance", Number(*distance)),
            ],
            ReasonKind::SamePlace { other, angle, distance } => vec![
                ("other", Text(other.clone())),
                ("angle", Number(*angle)),
                ("distance", Number(*distance)),
            ],
            ReasonKind::SameScans { other } => vec![("other", Text(other.clone()))],
            ReasonKind::EmptyScans { scans } => vec![("scans", Number(*scans as f64))],
            ReasonKind::Search(w) => vec![("warning", Text(w.name().into()))],
            ReasonKind::NotLevelled(_) => vec![],
            ReasonKind::NotConverged { iterations } => {
                vec![("iterations", Number(*iterations as f64))]
            }
            ReasonKind::TargetFit { target, fit } => vec![
                ("shape", Text(fit.shape.into())),
                ("size", Number(fit.size)),
                ("expected", Number(target.size().unwrap_or(fit.size))),
                ("rms", Number(fit.rms)),
                ("fitsBadly", Number(f64::from(u8::from(ReasonKind::fits_badly(target, fit))))),
            ],
            ReasonKind::NoTarget => vec![],
            ReasonKind::OutsideRegion { given } => {
                vec![("given", Number(f64::from(u8::from(*given))))]
            }
            ReasonKind::Methods { agree, differ } => vec![
                ("agree", Names(agree.clone())),
                ("differ", Names(differ.iter().map(|(m, _, _)| *m).collect())),
            ],
        };
        ReasonReport {
            kind: r.kind.name(),
            level: r.level,
            text: r.kind.to_string(),
            values: values.into_iter().collect(),
        }
    }
}

/// One sensor's global alignment.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct GlobalReport {
    pub sensor: String,
    /// The motion applied on top of the nominal, row-major.
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub motion: [f64; 16],
    /// The ground found in the sensor's frame: its angle from the nominal's up (rad) and the
    /// sensor's height above it (m).
    pub ground_tilt: Option<f64>,
    pub ground_height: Option<f64>,
    pub grounds_tried: usize,
    /// The overlay from above: the best placement, the distinct runners-up, and the best
    /// runner-up's score over the best's.
    pub overlay: Option<OverlayReport>,
    /// Why it was not applied, if it was not.
    pub skipped: Option<String>,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct OverlayReport {
    pub best: CandidateReport,
    pub runners_up: Vec<CandidateReport>,
    pub ambiguity: f64,
}

/// A placement from above: yaw (rad) about the ground normal, shift (m), score (0..1).
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
pub struct CandidateReport {
    pub yaw: f64,
    pub shift: [f64; 3],
    pub score: f64,
}

fn candidate(c: &crate::calib::correlate::Candidate) -> CandidateReport {
    CandidateReport { yaw: c.yaw, shift: c.shift.into(), score: c.score }
}

/// One sensor's selection: every stage's hypothesis and the one chosen.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SelectionReport {
    pub sensor: String,
    /// Index of the chosen hypothesis.
    pub chosen: usize,
    pub hypotheses: Vec<HypothesisReport>,
}

/// One hypothesis: the stage it came from, its correction on top of the nominal (row-major)
/// and how it scored.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct HypothesisReport {
    /// `nominal`, `global`, `levelled`, `jrmpc`, `cad`, `refinedFromNominal`,
    /// `refinedFromStart`, `refined`, `refinedOnScene` or `planes`.
    pub stage: &'static str,
    /// A global candidate's rank (0: the global stage's best overlay).
    pub rank: Option<usize>,
    /// The hypothesis it was refined from.
    pub parent: Option<usize>,
    #[cfg_attr(feature = "ts", ts(type = "Matrix4"))]
    pub correction: [f64; 16],
    /// The selection's score: `landing` less three times `contradiction`
    /// (`select::CONTRADICTION_WEIGHT`; -3..1).
    pub score: f64,
    /// Share of the points compared that land on another sensor's surfaces (0..1).
    pub landing: f64,
    /// Share of the points compared that stand where another sensor saw through (0..1).
    pub contradiction: f64,
    /// Share of the points compared with another sensor's surface beside them (0..1).
    pub overlap: f64,
    /// How its ground meets the other sensors' where they see the same patches; absent
    /// without a reference ground or shared patches.
    pub ground: Option<GroundReport>,
}

/// Two sensors' grounds compared patch by patch: the patches both see, the offset (m) and
/// angle (rad) between the grounds, and one sigma of each.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct GroundReport {
    pub patches: usize,
    pub height: f64,
    pub tilt: f64,
    pub height_sigma: f64,
    pub tilt_sigma: f64,
}

impl From<&crate::calib::GroundAgreement> for GroundReport {
    fn from(g: &crate::calib::GroundAgreement) -> Self {
        let (patches, height, tilt) = (g.patches, g.height, g.tilt);
        Self { patches, height, tilt, height_sigma: g.height_sigma, tilt_sigma: g.tilt_sigma }
    }
}

impl From<&crate::calib::SensorSelection> for SelectionReport {
    fn from(s: &crate::calib::SensorSelection) -> Self {
        let hypotheses = s
            .hypotheses
            .iter()
            .map(|h| HypothesisReport {
                stage: h.source.name(),
                rank: match h.source {
                    crate::calib::Source::Global { rank } => Some(rank),
                    _ => None,
                },
                parent: h.parent,
                correction: to_row_major(&h.correction),
                score: h.score.value(),
                landing: h.score.landing(),
                contradiction: h.score.contradiction(),
                overlap: h.score.overlap(),
                ground: h.ground.as_ref().map(GroundReport::from),
            })
            .collect();
        Self { sensor: s.sensor.clone(), chosen: s.chosen, hypotheses }
    }
}
