//! Frame pairs: ICP of each sensor's view onto the reference sensor's view of the same frame —
//! the ICP methods, and `gmm`'s refinement of the JRMPC corrections. [`FramePairs`] holds the
//! pairs and their outcomes; it registers them itself ([`FramePairs::run`], on threads
//! natively) or takes outcomes registered elsewhere ([`FramePairs::record`], the page's pool
//! workers), in pair order either way.
//!
//! Why refine: JRMPC's isotropic Gaussians blend the sensors' different samplings of the same
//! surfaces, and each view is pulled point-to-point toward that blend, which leaves a bias
//! along the surfaces (docs/method.md, "Why refine"). Point-to-plane and GICP remove most of
//! the in-plane force; JRMPC supplies the basin of convergence. The match distance shrinks over
//! stages, so the first stage can still catch what JRMPC left and the last one ignores what
//! does not overlap.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::average::average;
use super::notes::NoteKind;
use super::progress::{Progress, Stage};
use crate::icp::{self, IcpSettings};
use crate::jrmpc::Control;
use crate::plane::Plane;
use crate::se3::Pose;

/// How each frame pair registers. Serialisable, so a worker elsewhere (the page's pool
/// workers) registers a share of the pairs exactly as here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairSettings {
    /// The ICP metric.
    pub metric: icp::Metric,
    /// Maximum correspondence distance (m) of each ICP stage, in order.
    pub match_distances: Vec<f64>,
    /// The ICP settings of every stage (the match distance is taken from the stages).
    pub icp: IcpSettings,
    /// The stages before the last converge at this rotation (rad) and translation (m) instead
    /// of `icp`'s tolerances: they only have to bring the pose within the next stage's reach.
    /// `None`: every stage uses `icp`'s.
    pub early_tolerance: Option<f64>,
    /// A registration that moves a frame's correction further than this from where it started
    /// (rad, m) has slid off (on sparse views, poor normals can drag ICP away); the frame keeps
    /// its starting correction and is reported. JRMPC's errors stay well inside. `None`: no
    /// guard (the ICP methods, which start from the nominal).
    pub max_departure: Option<(f64, f64)>,
}

impl Default for PairSettings {
    /// `gmm`'s refinement of JRMPC's corrections.
    fn default() -> Self {
        Self {
            // GICP measured better than point-to-plane on the full-view rigs (docs/accuracy.md).
            metric: icp::Metric::Gicp,
            match_distances: vec![0.5, 0.2, 0.1, 0.05],
            icp: IcpSettings {
                // Tight: the refinement is the last word on the calibration.
                translation_tolerance: 1e-5,
                rotation_tolerance: 1e-5,
                // About the range noise: matches across edges and onto the other side of a
                // cube stop pulling (twin: median 0.028 -> 0.019 deg).
                robust_scale: Some(0.01),
                ..IcpSettings::default()
            },
            // The early stages need not reach the last stage's precision: on the twin this ends
            // every study as before, with about half the ICP iterations on hard data.
            early_tolerance: Some(1e-3),
            max_departure: Some((2f64.to_radians(), 0.2)),
        }
    }
}

impl PairSettings {
    /// An ICP method: one stage at `icp`'s match distance, no guard.
    pub fn from_nominal(metric: icp::Metric, icp: &IcpSettings) -> Self {
        Self {
            metric,
            match_distances: vec![icp.max_correspondence_distance],
            icp: icp.clone(),
            early_tolerance: None,
            max_departure: None,
        }
    }
}

/// What a frame pair's ICP needs besides the clouds: the settings and the reference's ground
/// (the plane and the band, m, whose points take its normal: ground rings lie too far apart
/// for neighbour normals). What the page sends its pool workers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairIcp {
    pub settings: PairSettings,
    pub ground: Option<(Plane, f64)>,
}

/// One sensor's correction per frame pair `(reference view, sensor view)`.
pub type PairCorrections = Vec<((usize, usize), Pose)>;

/// A frame pair whose registration failed (the frame is left out of the average) or moved
/// beyond the guard (the frame keeps its starting correction): what to note, on which view.
#[derive(Clone, Debug)]
pub struct PairFailure {
    /// Index of the sensor's view.
    pub view: usize,
    pub kind: NoteKind,
}

impl PairFailure {
    /// The frame kept its starting correction (rather than being left out).
    pub fn kept_start(&self) -> bool {
        matches!(self.kind, NoteKind::RefinementDeparted { .. })
    }
}

/// One frame pair: sensor `sensor`'s view `view` onto the reference's view `reference_view`,
/// from the correction `start`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePair {
    pub sensor: usize,
    pub reference_view: usize,
    pub view: usize,
    pub start: Pose,
}

/// The ICP target of reference view `cloud`, with the ground's normals. Build it once per
/// reference view: every sensor's pair of that frame aligns onto it. With `for_verdict` (where
/// the run finishes), it keeps its points' neighbourhoods, which the verdict reads afterwards.
pub fn target(
    cloud: &[[f32; 3]],
    icp: &PairIcp,
    for_verdict: bool,
) -> Result<icp::TargetCloud, icp::IcpError> {
    let (metric, settings) = (icp.settings.metric, &icp.settings.icp);
    let mut target = if for_verdict {
        icp::TargetCloud::with_neighbourhoods(cloud, metric, settings)?
    } else {
        icp::TargetCloud::new(cloud, metric, settings)?
    };
    if let Some((plane, band)) = icp.ground {
        target.set_normals(|p| {
            let p = Vector3::from(p.map(f64::from));
            (plane.distance(&p).abs() <= band).then_some(plane.normal)
        });
    }
    Ok(target)
}

/// Registers `cloud` onto `target` from `start`: one ICP stage per match distance, on one
/// prepared source.
pub fn align(
    target: &icp::TargetCloud,
    cloud: &[[f32; 3]],
    start: &Pose,
    icp: &PairIcp,
) -> Result<Pose, icp::IcpError> {
    let settings = &icp.settings;
    let source = icp::SourceCloud::new(cloud, settings.metric, &settings.icp)?;
    let last = settings.match_distances.len().saturating_sub(1);
    let stages: Vec<IcpSettings> = (settings.match_distances.iter().enumerate())
        .map(|(i, &distance)| {
            let mut stage =
                IcpSettings { max_correspondence_distance: distance, ..settings.icp.clone() };
            if let Some(tolerance) = settings.early_tolerance.filter(|_| i < last) {
                (stage.rotation_tolerance, stage.translation_tolerance) = (tolerance, tolerance);
            }
            stage
        })
        .collect();
    if stages.is_empty() {
        return Ok(*start);
    }
    target.align_stages(&source, start, &stages).map(|a| a.target_from_source)
}

/// The frame pairs of a calibration and their outcomes so far. The pairs may be registered
/// here ([`FramePairs::run`]) or anywhere else and [`FramePairs::record`]ed, in any order:
/// the corrections come out in pair order either way, so the result does not depend on who
/// registered what.
pub struct FramePairs {
    icp: PairIcp,
    pairs: Vec<FramePair>,
    /// Per pair: the registered correction, or why registering failed.
    outcomes: Vec<Option<Result<Pose, String>>>,
    /// The reference's own pairs, which keep the identity.
    reference: (usize, Vec<(usize, usize)>),
    sensors: usize,
    stopped: bool,
    /// Starting corrections set aside before registering (noted with the failures).
    set_aside: Vec<PairFailure>,
    /// Per view, the ICP target built here when a pair first needed it.
    targets: Vec<Option<Result<icp::TargetCloud, icp::IcpError>>>,
}

impl FramePairs {
    /// For each sensor and pair `(reference view, sensor view)` in `pairs`, a frame pair from
    /// its correction in `starts` (identity when `starts[s]` has none: the nominal
    /// pre-alignment); `set_aside` notes the starts the caller replaced.
    pub fn new(
        icp: PairIcp,
        pairs: &[Vec<(usize, usize)>],
        reference: usize,
        starts: &[PairCorrections],
        set_aside: Vec<PairFailure>,
    ) -> Self {
        let frame_pairs: Vec<FramePair> = pairs
            .iter()
            .enumerate()
            .filter(|(s, _)| *s != reference)
            .flat_map(|(sensor, frames)| {
                let starts = &starts[sensor];
                frames.iter().map(move |&(reference_view, view)| FramePair {
                    sensor,
                    reference_view,
                    view,
                    start: starts
                        .iter()
                        .find(|(p, _)| *p == (reference_view, view))
                        .map_or_else(Pose::identity, |(_, c)| *c),
                })
            })
            .collect();
        Self {
            icp,
            outcomes: vec![None; frame_pairs.len()],
            pairs: frame_pairs,
            reference: (reference, pairs[reference].clone()),
            sensors: pairs.len(),
            stopped: false,
            set_aside,
            targets: Vec::new(),
        }
    }

    /// How every pair registers.
    pub fn icp(&self) -> &PairIcp {
        &self.icp
    }

    /// Every pair to register, sensor by sensor, frame by frame.
    pub fn pairs(&self) -> &[FramePair] {
        &self.pairs
    }

    /// Pair `pair`'s outcome: its registered correction, or the registration's error. Out of
    /// range or repeated pairs are ignored (the first outcome stands).
    pub fn record(&mut self, pair: usize, outcome: Result<Pose, String>) {
        if let Some(slot @ None) = self.outcomes.get_mut(pair) {
            *slot = Some(outcome);
        }
    }

    /// Registers the pairs `which` (indices into [`FramePairs::pairs`]) not yet recorded,
    /// here, and records them; `progress` sees every one. With `threads` > 1 (native only)
    /// they run on that many threads, a batch at a time, with the same results; a stop takes
    /// effect after the batch, and no later call registers anything.
    pub fn run(
        &mut self,
        clouds: &[&[[f32; 3]]],
        which: impl IntoIterator<Item = usize>,
        threads: usize,
        progress: &mut impl FnMut(&Progress) -> Control,
    ) {
        let threads = crate::threads_here(threads);
        let todo: Vec<usize> = which
            .into_iter()
            .filter(|&j| self.outcomes.get(j).is_some_and(Option::is_none))
            .collect();
        // Targets are built once per reference view, when a batch first needs it, and shared
        // by every sensor; they are kept for the verdict.
        let mut targets = std::mem::take(&mut self.targets);
        targets.resize_with(clouds.len(), || None);
        for batch in todo.chunks(4 * threads) {
            if self.stopped {
                break;
            }
            let mut needed: Vec<usize> = batch
                .iter()
                .map(|&j| self.pairs[j].reference_view)
                .filter(|&r| targets[r].is_none())
                .collect();
            needed.sort_unstable();
            needed.dedup();
            let icp = &self.icp;
            let built = crate::on_threads(&needed, threads, |&r| target(clouds[r], icp, true));
            for (&r, built) in needed.iter().zip(built) {
                targets[r] = Some(built);
            }
            let pairs = &self.pairs;
            let aligned = crate::on_threads(batch, threads, |&j| {
                let pair = &pairs[j];
                let target = targets[pair.reference_view].as_ref().expect("built for the batch");
                match target {
                    Ok(target) => align(target, clouds[pair.view], &pair.start, icp),
                    Err(e) => Err(e.clone()),
                }
            });
            for (&j, result) in batch.iter().zip(aligned) {
                self.record(j, result.map_err(|e| e.to_string()));
                if self.stopped {
                    continue; // the batch's work is kept; the caller has stopped listening
                }
                let running = self.running();
                let answer = progress(&self.progress(&running));
                if answer == Control::Stop {
                    self.stopped = true;
                }
            }
        }
        self.targets = targets;
    }

    /// The ICP target of reference view `view`, when [`FramePairs::run`] built one.
    pub fn target(&self, view: usize) -> Option<&icp::TargetCloud> {
        self.targets.get(view)?.as_ref()?.as_ref().ok()
    }

    /// Stops: no later [`FramePairs::run`] registers anything.
    pub fn stop(&mut self) {
        self.stopped = true;
    }

    /// The progress after the pairs recorded so far, with `corrections` as the caller shows
    /// them (from [`FramePairs::running`]).
    pub fn progress<'a>(&self, corrections: &'a [Pose]) -> Progress<'a> {
        Progress {
            stage: Stage::FramePairs,
            iteration: self.done(),
            max_iterations: self.pairs.len(),
            mean_sigma: 0.0,
            max_change: 0.0,
            corrections,
        }
    }

    /// Pairs recorded.
    pub fn done(&self) -> usize {
        self.outcomes.iter().filter(|o| o.is_some()).count()
    }

    /// The mean correction per sensor over the pairs recorded so far (identity for none).
    pub fn running(&self) -> Vec<Pose> {
        let (corrections, _) = self.corrections();
        corrections
            .iter()
            .map(|c| {
                average(&c.iter().map(|(_, p)| *p).collect::<Vec<_>>())
                    .map_or_else(Pose::identity, |(m, _)| m)
            })
            .collect()
    }

    /// Per sensor, its recorded pairs' corrections, in pair order (the reference: identities),
    /// and the pairs that failed or moved beyond the guard. Pairs never recorded (after a
    /// stop) are left out.
    pub fn corrections(&self) -> (Vec<PairCorrections>, Vec<PairFailure>) {
        let mut refined: Vec<PairCorrections> = vec![Vec::new(); self.sensors];
        let (r, reference_pairs) = &self.reference;
        refined[*r] = reference_pairs.iter().map(|&pair| (pair, Pose::identity())).collect();
        let mut failures = self.set_aside.clone();
        let settings = &self.icp.settings;
        for (pair, outcome) in self.pairs.iter().zip(&self.outcomes) {
            let views = (pair.reference_view, pair.view);
            match outcome {
                None => {}
                Some(Ok(pose)) => match departure_beyond(&pair.start, pose, settings.max_departure)
                {
                    None => refined[pair.sensor].push((views, *pose)),
                    Some(kind) => {
                        failures.push(PairFailure { view: pair.view, kind });
                        refined[pair.sensor].push((views, pair.start));
                    }
                },
                Some(Err(e)) => failures.push(PairFailure {
                    view: pair.view,
                    kind: NoteKind::PairFailed { metric: settings.metric, error: e.clone() },
                }),
            }
        }
        (refined, failures)
    }
}

/// The note for `end` too far from `start` to be trusted, if it is.
fn departure_beyond(start: &Pose, end: &Pose, limit: Option<(f64, f64)>) -> Option<NoteKind> {
    let limit = limit?;
    let d = start.inverse() * end;
    let (angle, distance) = (d.rotation.angle(), d.translation.vector.norm());
    (angle > limit.0 || distance > limit.1).then_some(NoteKind::RefinementDeparted {
        angle,
        distance,
        limit,
    })
}
