//! Per-frame ICP of each sensor's view onto the reference sensor's view of the same frame:
//! the ICP baselines, and `gmm`'s refinement of the JRMPC corrections. A [`Refinement`] holds
//! the frame pairs and their outcomes; it registers them itself ([`Refinement::run`], on
//! threads natively) or takes outcomes registered elsewhere ([`Refinement::record`], the
//! page's pool workers), in pair order either way.
//!
//! Why refine: JRMPC's isotropic Gaussians blend the sensors' different samplings of the same
//! surfaces, and each view is pulled point-to-point toward that blend, which leaves a bias
//! along the surfaces (README, "Why refine"). Point-to-plane and GICP remove most of the
//! in-plane force; JRMPC supplies the basin of convergence. The match distance shrinks over
//! stages, so the first stage can still catch what JRMPC left and the last one ignores what
//! does not overlap.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::average::average;
use super::level::Plane;
use super::{Progress, Stage};
use crate::icp::{self, IcpSettings};
use crate::jrmpc::Control;
use crate::se3::Pose;

/// The refinement's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RefineSettings {
    /// The ICP variant that refines.
    pub method: icp::Method,
    /// Maximum correspondence distance (m) of each stage, in order.
    pub match_distances: Vec<f64>,
    /// The ICP settings of every stage (the match distance is taken from the stages).
    pub icp: IcpSettings,
    /// The stages before the last converge at this rotation (rad) and translation (m) instead
    /// of `icp`'s tolerances: they only have to bring the pose within the next stage's reach.
    /// `None`: every stage uses `icp`'s.
    pub early_tolerance: Option<f64>,
    /// A refinement that moves a frame's correction further than this from where it started
    /// (rad, m) has slid off (on sparse views, poor normals can drag ICP away); the
    /// frame keeps its starting correction and is reported. JRMPC's errors stay well inside.
    pub max_departure: (f64, f64),
}

impl Default for RefineSettings {
    fn default() -> Self {
        Self {
            // GICP measured better than point-to-plane on the full-view rigs (README).
            method: icp::Method::Gicp,
            match_distances: vec![0.5, 0.2, 0.1, 0.05],
            icp: IcpSettings {
                // Tight: the refinement is the last word on the calibration.
                translation_tolerance: 1e-5,
                rotation_tolerance: 1e-5,
                // About the range noise: matches across edges and onto the other side of a
                // cube stop pulling (twin, README: median 0.028 -> 0.019 deg).
                robust_scale: Some(0.01),
                ..IcpSettings::default()
            },
            // The early stages need not reach the last stage's precision: on the twin this ends
            // every study as before (README), with about half the ICP iterations on hard data.
            early_tolerance: Some(1e-3),
            max_departure: (2f64.to_radians(), 0.2),
        }
    }
}

/// One sensor's correction per frame pair `(reference view, sensor view)`.
pub type FrameCorrections = Vec<((usize, usize), Pose)>;

/// A frame whose registration failed (left out of the average) or whose refinement was
/// rejected (the starting correction kept).
pub struct Failure {
    /// Index of the sensor's view.
    pub view: usize,
    pub reason: String,
    pub kept_start: bool,
}

/// How the frames are registered. Owned and serialisable, so a worker elsewhere (the page's
/// shard workers) can register a share of the pairs exactly as here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub method: icp::Method,
    pub settings: IcpSettings,
    /// One ICP stage per match distance (m), in order.
    pub match_distances: Vec<f64>,
    /// The tolerance (rad and m) of every stage but the last, if not `settings`'.
    pub early_tolerance: Option<f64>,
    /// Rotation (rad) and translation (m) beyond which a result is rejected, if any.
    pub max_departure: Option<(f64, f64)>,
    /// The reference's ground plane and the band (m) around it whose points take its normal.
    pub ground: Option<(Plane, f64)>,
}

/// One frame pair: sensor `sensor`'s view `view` onto the reference's view `reference_view`,
/// from the correction `start`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Job {
    pub sensor: usize,
    pub reference_view: usize,
    pub view: usize,
    pub start: Pose,
}

/// The ICP target of reference view `cloud`, with the plan's ground normals. Build it once per
/// reference view: every sensor's pair of that frame aligns onto it.
pub fn target(cloud: &[[f32; 3]], plan: &Plan) -> Result<icp::Target, icp::IcpError> {
    let mut target = icp::Target::new(cloud, plan.method, &plan.settings)?;
    if let Some((plane, band)) = plan.ground {
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
    target: &icp::Target,
    cloud: &[[f32; 3]],
    start: &Pose,
    plan: &Plan,
) -> Result<Pose, icp::IcpError> {
    let source = icp::Source::new(cloud, plan.method, &plan.settings)?;
    let last = plan.match_distances.len().saturating_sub(1);
    plan.match_distances.iter().enumerate().try_fold(*start, |pose, (i, &distance)| {
        let mut stage =
            IcpSettings { max_correspondence_distance: distance, ..plan.settings.clone() };
        if let Some(tolerance) = plan.early_tolerance.filter(|_| i < last) {
            (stage.rotation_tolerance, stage.translation_tolerance) = (tolerance, tolerance);
        }
        target.align_prepared(&source, &pose, &stage).map(|a| a.target_from_source)
    })
}

/// The frame pairs of a calibration and their outcomes so far. The pairs may be registered
/// here ([`Refinement::run`]) or anywhere else and [`Refinement::record`]ed, in any order:
/// the corrections come out in pair order either way, so the result does not depend on who
/// registered what.
pub struct Refinement {
    plan: Plan,
    jobs: Vec<Job>,
    /// Per job: the registered correction, or why registering failed.
    outcomes: Vec<Option<Result<Pose, String>>>,
    /// The reference's own pairs, which keep the identity.
    reference: (usize, Vec<(usize, usize)>),
    sensors: usize,
    stopped: bool,
}

impl Refinement {
    /// For each sensor and frame pair `(reference view, sensor view)`, a job from the current
    /// correction (identity when `starts[s]` has none, i.e. the nominal pre-alignment).
    pub fn new(
        plan: Plan,
        pairs: &[Vec<(usize, usize)>],
        reference: usize,
        starts: &[FrameCorrections],
    ) -> Self {
        let jobs: Vec<Job> = pairs
            .iter()
            .enumerate()
            .filter(|(s, _)| *s != reference)
            .flat_map(|(sensor, frames)| {
                let starts = &starts[sensor];
                frames.iter().map(move |&(reference_view, view)| Job {
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
            plan,
            outcomes: vec![None; jobs.len()],
            jobs,
            reference: (reference, pairs[reference].clone()),
            sensors: pairs.len(),
            stopped: false,
        }
    }

    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Every pair to register, sensor by sensor, frame by frame.
    pub fn jobs(&self) -> &[Job] {
        &self.jobs
    }

    /// Job `job`'s outcome: its registered correction, or the registration's error. Out of
    /// range or repeated jobs are ignored (the first outcome stands).
    pub fn record(&mut self, job: usize, outcome: Result<Pose, String>) {
        if let Some(slot @ None) = self.outcomes.get_mut(job) {
            *slot = Some(outcome);
        }
    }

    /// Registers the jobs `jobs` (indices into [`Refinement::jobs`]) not yet recorded, here,
    /// and records them; `progress` sees every one. With `threads` > 1 (native only) they run
    /// on that many threads, a batch at a time, with the same results; a stop takes effect
    /// after the batch, and no later call registers anything.
    pub fn run(
        &mut self,
        clouds: &[&[[f32; 3]]],
        jobs: impl IntoIterator<Item = usize>,
        threads: usize,
        progress: &mut impl FnMut(&Progress) -> Control,
    ) {
        let threads = crate::threads_here(threads);
        let todo: Vec<usize> = jobs
            .into_iter()
            .filter(|&j| self.outcomes.get(j).is_some_and(Option::is_none))
            .collect();
        // Targets are built once per reference view, when a batch first needs it, and shared
        // by every sensor.
        let mut targets: Vec<Option<Result<icp::Target, icp::IcpError>>> =
            (0..clouds.len()).map(|_| None).collect();
        for batch in todo.chunks(4 * threads) {
            if self.stopped {
                return;
            }
            let mut needed: Vec<usize> = batch
                .iter()
                .map(|&j| self.jobs[j].reference_view)
                .filter(|&r| targets[r].is_none())
                .collect();
            needed.sort_unstable();
            needed.dedup();
            let plan = &self.plan;
            let built = on_threads(&needed, threads, |&r| target(clouds[r], plan));
            for (&r, built) in needed.iter().zip(built) {
                targets[r] = Some(built);
            }
            let jobs = &self.jobs;
            let aligned = on_threads(batch, threads, |&j| {
                let job = &jobs[j];
                let target = targets[job.reference_view].as_ref().expect("built for the batch");
                match target {
                    Ok(target) => align(target, clouds[job.view], &job.start, plan),
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
    }

    /// Stops: no later [`Refinement::run`] registers anything.
    pub fn stop(&mut self) {
        self.stopped = true;
    }

    /// The progress after the pairs recorded so far, with `corrections` as the caller shows
    /// them (from [`Refinement::running`]).
    pub fn progress<'a>(&self, corrections: &'a [Pose]) -> Progress<'a> {
        Progress {
            stage: Stage::FramePairs,
            iteration: self.done(),
            max_iterations: self.jobs.len(),
            mean_sigma: 0.0,
            max_change: 0.0,
            corrections,
        }
    }

    /// Jobs recorded.
    pub fn done(&self) -> usize {
        self.outcomes.iter().filter(|o| o.is_some()).count()
    }

    /// The mean correction per sensor over the frames recorded so far (identity for none).
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
    /// and the frames that failed or were rejected. Jobs never recorded (after a stop) are
    /// left out.
    pub fn corrections(&self) -> (Vec<FrameCorrections>, Vec<Failure>) {
        let mut refined: Vec<FrameCorrections> = vec![Vec::new(); self.sensors];
        let (r, reference_pairs) = &self.reference;
        refined[*r] = reference_pairs.iter().map(|&pair| (pair, Pose::identity())).collect();
        let mut failures = Vec::new();
        for (job, outcome) in self.jobs.iter().zip(&self.outcomes) {
            let pair = (job.reference_view, job.view);
            match outcome {
                None => {}
                Some(Ok(pose)) => match departure_beyond(&job.start, pose, self.plan.max_departure)
                {
                    None => refined[job.sensor].push((pair, *pose)),
                    Some(reason) => {
                        failures.push(Failure { view: job.view, reason, kept_start: true });
                        refined[job.sensor].push((pair, job.start));
                    }
                },
                Some(Err(e)) => failures.push(Failure {
                    view: job.view,
                    reason: format!("{} failed: {e}", self.plan.method.name()),
                    kept_start: false,
                }),
            }
        }
        (refined, failures)
    }
}

/// `f` of every item, in order, on up to `threads` threads (contiguous slices).
fn on_threads<T: Sync, R: Send>(items: &[T], threads: usize, f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    if threads <= 1 || items.len() <= 1 {
        return items.iter().map(f).collect();
    }
    let per = items.len().div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(per)
            .map(|chunk| scope.spawn(move || chunk.iter().map(f).collect::<Vec<R>>()))
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a refinement thread panicked")).collect()
    })
}

/// Why `end` is too far from `start` to be trusted, if it is.
fn departure_beyond(start: &Pose, end: &Pose, limit: Option<(f64, f64)>) -> Option<String> {
    let (angle, distance) = limit?;
    let d = start.inverse() * end;
    let (a, t) = (d.rotation.angle(), d.translation.vector.norm());
    (a > angle || t > distance).then(|| {
        format!(
            "refinement moved {:.2} deg / {:.3} m from the JRMPC correction; kept that instead",
            a.to_degrees(),
            t
        )
    })
}
