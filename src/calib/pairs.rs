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

/// A frame pair whose registration failed (the frame is left out of the average): what to
/// note, on which view.
#[derive(Clone, Debug)]
pub struct PairFailure {
    /// Index of the sensor's view.
    pub view: usize,
    pub kind: NoteKind,
}

/// Where a frame pair's ICP starts: each start gives the selection its own hypothesis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairStart {
    /// JRMPC's or `cad`'s correction of the frame.
    Registration,
    /// The chosen start (the pre-alignment: levelled, searched, globally aligned).
    Start,
    /// The nominal as given (the pre-alignment undone).
    Nominal,
}

impl PairStart {
    fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// One frame pair: sensor `sensor`'s view `view` onto the reference's view `reference_view`,
/// from the correction `start`, standing for the starts `origins` (a bit per [`PairStart`]:
/// starts that coincide register once).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePair {
    pub sensor: usize,
    pub reference_view: usize,
    pub view: usize,
    pub start: Pose,
    origins: u8,
}

impl FramePair {
    /// This pair stands for `origin`'s start.
    pub fn starts_from(&self, origin: PairStart) -> bool {
        self.origins & origin.bit() != 0
    }
}

/// The ICP fixed cloud of reference view `cloud`, with the ground's normals. Build it once per
/// reference view: every sensor's pair of that frame aligns onto it. With `for_verdict` (where
/// the run finishes), it keeps its points' neighbourhoods, which the verdict reads afterwards.
pub fn fixed_cloud(
    cloud: &[[f32; 3]],
    icp: &PairIcp,
    for_verdict: bool,
) -> Result<icp::FixedCloud, icp::IcpError> {
    let (metric, settings) = (icp.settings.metric, &icp.settings.icp);
    let mut target = if for_verdict {
        icp::FixedCloud::with_neighbourhoods(cloud, metric, settings)?
    } else {
        icp::FixedCloud::new(cloud, metric, settings)?
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
    target: &icp::FixedCloud,
    cloud: &[[f32; 3]],
    start: &Pose,
    icp: &PairIcp,
) -> Result<Pose, icp::IcpError> {
    let settings = &icp.settings;
    let source = icp::MovingCloud::new(cloud, settings.metric, &settings.icp)?;
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
    /// The reference's index and every sensor's `(reference view, view)` pairs, in frame
    /// order; the reference's keep the identity.
    reference: usize,
    frames: Vec<Vec<(usize, usize)>>,
    stopped: bool,
    /// The starts registered from, the first the one progress follows.
    origins: Vec<PairStart>,
    /// Per view, the ICP fixed cloud built here when a pair first needed it.
    targets: Vec<Option<Result<icp::FixedCloud, icp::IcpError>>>,
}

impl FramePairs {
    /// For each start `(origin, corrections)` in `starts`, each sensor and pair `(reference
    /// view, sensor view)` in `pairs`: a frame pair from that pair's correction in
    /// `corrections[s]` (identity where it has none: the pre-alignment). A start equal to an
    /// earlier origin's for the same pair registers once and stands for both.
    pub fn new(
        icp: PairIcp,
        pairs: &[Vec<(usize, usize)>],
        reference: usize,
        starts: &[(PairStart, Vec<PairCorrections>)],
    ) -> Self {
        let mut frame_pairs: Vec<FramePair> = Vec::new();
        for (sensor, frames) in pairs.iter().enumerate().filter(|(s, _)| *s != reference) {
            let first = frame_pairs.len();
            for (origin, corrections) in starts {
                for &(reference_view, view) in frames {
                    let start = corrections
                        .get(sensor)
                        .and_then(|c| c.iter().find(|(p, _)| *p == (reference_view, view)))
                        .map_or_else(Pose::identity, |(_, c)| *c);
                    let same = frame_pairs[first..].iter_mut().find(|p| {
                        p.view == view && p.reference_view == reference_view && p.start == start
                    });
                    match same {
                        Some(pair) => pair.origins |= origin.bit(),
                        None => frame_pairs.push(FramePair {
                            sensor,
                            reference_view,
                            view,
                            start,
                            origins: origin.bit(),
                        }),
                    }
                }
            }
        }
        Self {
            icp,
            outcomes: vec![None; frame_pairs.len()],
            pairs: frame_pairs,
            reference,
            frames: pairs.to_vec(),
            stopped: false,
            origins: starts.iter().map(|(o, _)| *o).collect(),
            targets: Vec::new(),
        }
    }

    /// The starts registered from, in the order given.
    pub fn origins(&self) -> &[PairStart] {
        &self.origins
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
            let built = crate::on_threads(&needed, threads, |&r| fixed_cloud(clouds[r], icp, true));
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

    /// The ICP fixed cloud of reference view `view`, when [`FramePairs::run`] built one.
    pub fn fixed_cloud(&self, view: usize) -> Option<&icp::FixedCloud> {
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

    /// The mean correction per sensor over the pairs recorded so far from the first start
    /// (identity for none).
    pub fn running(&self) -> Vec<Pose> {
        let first = self.origins.first().copied().unwrap_or(PairStart::Start);
        let (corrections, _) = self.corrections(first);
        corrections
            .iter()
            .map(|c| {
                average(&c.iter().map(|(_, p)| *p).collect::<Vec<_>>())
                    .map_or_else(Pose::identity, |(m, _)| m)
            })
            .collect()
    }

    /// Per sensor, the corrections of its pairs registered from `origin`, in pair order (the
    /// reference: identities), and the pairs that failed. Pairs never recorded (after a stop)
    /// are left out.
    pub fn corrections(&self, origin: PairStart) -> (Vec<PairCorrections>, Vec<PairFailure>) {
        let mut refined: Vec<PairCorrections> = vec![Vec::new(); self.frames.len()];
        let r = self.reference;
        refined[r] = self.frames[r].iter().map(|&pair| (pair, Pose::identity())).collect();
        let mut failures = Vec::new();
        let metric = self.icp.settings.metric;
        for (s, frames) in self.frames.iter().enumerate().filter(|(s, _)| *s != r) {
            for &key in frames {
                let found = self.pairs.iter().zip(&self.outcomes).find(|(p, _)| {
                    p.sensor == s && (p.reference_view, p.view) == key && p.starts_from(origin)
                });
                match found {
                    None | Some((_, None)) => {}
                    Some((_, Some(Ok(pose)))) => refined[s].push((key, *pose)),
                    Some((_, Some(Err(e)))) => failures.push(PairFailure {
                        view: key.1,
                        kind: NoteKind::PairFailed { metric, error: e.clone() },
                    }),
                }
            }
        }
        (refined, failures)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Starts that coincide register once and stand for every origin; the others register
    /// apart, and each origin's corrections come from its own pairs.
    #[test]
    fn coinciding_starts_register_once() {
        let icp = PairIcp { settings: PairSettings::default(), ground: None };
        let pairs = vec![vec![(0, 0), (2, 2)], vec![(0, 1), (2, 3)]];
        let turned = Pose::new(nalgebra::Vector3::new(0.0, 0.0, 1.0), nalgebra::Vector3::zeros());
        let registration = vec![Vec::new(), vec![((0, 1), turned), ((2, 3), Pose::identity())]];
        let starts = [
            (PairStart::Registration, registration),
            (PairStart::Start, Vec::new()),
            (PairStart::Nominal, Vec::new()),
        ];
        let mut frame_pairs = FramePairs::new(icp, &pairs, 0, &starts);
        // Frame 1 from JRMPC's turn; frame 2's JRMPC start is the identity, as the others'.
        assert_eq!(frame_pairs.pairs().len(), 3);
        for j in 0..3 {
            let moved =
                Pose::new(nalgebra::Vector3::new(j as f64, 0.0, 0.0), nalgebra::Vector3::zeros());
            frame_pairs.record(j, Ok(moved));
        }
        let of = |origin| -> Vec<f64> {
            frame_pairs.corrections(origin).0[1].iter().map(|(_, c)| c.translation.x).collect()
        };
        assert_eq!(of(PairStart::Registration), vec![0.0, 1.0]);
        assert_eq!(of(PairStart::Start), vec![2.0, 1.0]);
        assert_eq!(of(PairStart::Nominal), vec![2.0, 1.0]);
    }
}
