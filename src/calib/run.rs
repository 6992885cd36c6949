//! A calibration run as a state machine over its methods and each method's stages. A driver
//! asks for the current [`Stage`] ([`Run::stage`]), does its work where it likes — native threads
//! ([`Run::drive`]) or the page's Web Workers (`wasm::CalibrationSession`) — and calls
//! [`Run::advance`]. With several methods (`compare all`) the run moves on to the next method
//! once one is done; a method that fails leaves its error as its outcome and the others still
//! run. So the control flow of a calibration exists once, here, whoever drives it.

use std::borrow::Cow;

use super::finish::finish;
use super::global::{GlobalAlignment, GlobalSettings, GlobalStage};
use super::left_out::LeftOut;
use super::pairs::FramePairs;
use super::progress::{Progress, Stage};
use super::result::Calibration;
use super::settings::{Method, Settings, Stages};
use super::views::Views;
use super::{CalibError, Rig};
use crate::jrmpc::{CentredViews, Control, Em, Registration, Shards};
use crate::se3::Pose;

/// One method's calibration, or why it failed.
pub type MethodOutcome = (Method, Result<Calibration, CalibError>);

pub struct Run<'r> {
    rig: Cow<'r, Rig>,
    settings: Settings,
    methods: Vec<Method>,
    /// The method under way: its index in `methods`, its views and its state.
    current: Option<(usize, Views, State)>,
    /// The method whose views wait for the global stage under way, and the stage.
    aligning: Option<(usize, GlobalStage)>,
    /// A step the run takes itself when the driver next advances.
    pending: Option<Pending>,
    /// The methods that asked for a global stage and found nothing to align.
    nothing_to_align: Vec<usize>,
    /// The sensors the method under way calibrates without.
    left_out: LeftOut,
    /// The last global stage's settings and alignments: a later method asking for the same
    /// stage (`gmm`, then `cad`) takes them instead of aligning again.
    aligned: Option<(GlobalSettings, Vec<GlobalAlignment>)>,
    outcomes: Vec<MethodOutcome>,
    cancelled: bool,
}

/// The run's own steps between the drivers' stages: one each, reported as it begins.
enum Pending {
    /// Method `index`'s views, to prepare from the global stage's alignments (none when it ran
    /// none), in [`Stage::Views`].
    Views(usize, Vec<GlobalAlignment>),
    /// Method `index`'s result, to make from its views and stages, in [`Stage::Finish`]; with
    /// the corrections its last stage left, for progress.
    Finish(usize, Box<Finishing>),
}

struct Finishing {
    views: Views,
    registration: Option<Registration>,
    pairs: Option<FramePairs>,
    corrections: Vec<Pose>,
}

enum State {
    /// EM under way; the views' centred points until a driver takes them for its shards.
    Em(Em, Option<CentredViews>),
    /// The frame pairs, registered as far as they are; JRMPC's result for the GMM methods.
    Pairs(Option<Registration>, Box<FramePairs>),
    /// `cad`'s registration, once run.
    Cad(Option<Result<Registration, CalibError>>),
}

impl<'r> Run<'r> {
    /// A run of `methods` (each with `settings`, its method replaced) on `rig`; the first
    /// method's views are prepared.
    pub fn new(rig: Cow<'r, Rig>, settings: &Settings, methods: &[Method]) -> Self {
        let mut run = Self {
            rig,
            settings: settings.clone(),
            methods: methods.to_vec(),
            current: None,
            aligning: None,
            pending: None,
            nothing_to_align: Vec::new(),
            left_out: LeftOut::default(),
            aligned: None,
            outcomes: Vec::with_capacity(methods.len()),
            cancelled: false,
        };
        run.start(0);
        run
    }

    /// The stage the current method needs next; `None` once every method has its outcome.
    pub fn stage(&self) -> Option<Stage> {
        if self.aligning.is_some() {
            return Some(Stage::Global);
        }
        match &self.pending {
            Some(Pending::Views(..)) => return Some(Stage::Views),
            Some(Pending::Finish(..)) => return Some(Stage::Finish),
            None => {}
        }
        match &self.current {
            Some((_, _, State::Em(..))) => Some(Stage::Jrmpc),
            Some((_, _, State::Pairs(..))) => Some(Stage::FramePairs),
            Some((_, _, State::Cad(..))) => Some(Stage::Cad),
            None => None,
        }
    }

    /// The method under way and its index among the run's methods.
    pub fn method(&self) -> Option<(usize, Method)> {
        self.index().map(|i| (i, self.methods[i]))
    }

    /// The stages method `index` goes through ([`Stages::plan`]), less a global stage it will
    /// not run: one an earlier method runs with the same settings (taken from it), or one
    /// that found nothing to align (known once the method started).
    pub fn plan(&self, index: usize) -> Vec<Stage> {
        let stages = |i: usize| Stages::of(self.methods[i], &self.settings);
        let of = stages(index);
        let mut plan = of.plan();
        let taken = (0..index).any(|j| stages(j).global == of.global);
        if taken || self.nothing_to_align.contains(&index) {
            plan.retain(|s| *s != Stage::Global);
        }
        plan
    }

    /// The index of the method under way.
    fn index(&self) -> Option<usize> {
        let pending = self.pending.as_ref().map(|p| match p {
            Pending::Views(i, _) | Pending::Finish(i, _) => *i,
        });
        let aligning = self.aligning.as_ref().map(|(i, _)| *i);
        pending.or(aligning).or(self.current.as_ref().map(|(i, _, _)| *i))
    }

    /// The global stage, in [`Stage::Global`].
    pub fn global_stage(&mut self) -> Option<&mut GlobalStage> {
        self.aligning.as_mut().map(|(_, stage)| stage)
    }

    pub fn methods(&self) -> &[Method] {
        &self.methods
    }

    /// The method under way's views.
    pub fn views(&self) -> Option<&Views> {
        self.current.as_ref().map(|(_, views, _)| views)
    }

    /// EM, in [`Stage::Jrmpc`].
    pub fn em(&mut self) -> Option<&mut Em> {
        match &mut self.current {
            Some((_, _, State::Em(em, _))) => Some(em),
            _ => None,
        }
    }

    /// The views' centred points for EM's shards, in [`Stage::Jrmpc`] (until taken).
    pub fn em_points(&self) -> Option<&CentredViews> {
        match &self.current {
            Some((_, _, State::Em(_, points))) => points.as_ref(),
            _ => None,
        }
    }

    /// The frame pairs, in [`Stage::FramePairs`].
    pub fn frame_pairs(&mut self) -> Option<&mut FramePairs> {
        match &mut self.current {
            Some((_, _, State::Pairs(_, pairs))) => Some(pairs),
            _ => None,
        }
    }

    /// Registers the frame pairs `which` here (see [`FramePairs::run`]); `progress` sees the
    /// corrections as the caller does, levelling included.
    pub fn register_pairs(
        &mut self,
        which: impl IntoIterator<Item = usize>,
        threads: usize,
        progress: &mut impl FnMut(&Progress) -> Control,
    ) {
        let Some((_, views, State::Pairs(_, pairs))) = &mut self.current else { return };
        let left_out = &self.left_out;
        pairs.run(&views.clouds(), which, threads, &mut |p: &Progress| {
            let corrections = left_out.corrections(views.levelled(p.corrections));
            progress(&Progress { corrections: &corrections, ..*p })
        });
    }

    /// Records frame pair `pair`'s outcome, registered elsewhere, and returns what the progress
    /// callback would see.
    pub fn record_pair<R>(
        &mut self,
        pair: usize,
        outcome: Result<Pose, String>,
        then: impl FnOnce(&Progress) -> R,
    ) -> Option<R> {
        let Some((_, views, State::Pairs(_, pairs))) = &mut self.current else { return None };
        pairs.record(pair, outcome);
        let corrections = self.left_out.corrections(views.levelled(&pairs.running()));
        Some(then(&pairs.progress(&corrections)))
    }

    /// Runs `cad`'s registration here, in [`Stage::Cad`]; `progress` sees each iteration (the
    /// corrections as the caller sees them) and may stop it.
    pub fn register_cad(&mut self, progress: &mut impl FnMut(&Progress) -> Control) {
        let Some((_, views, State::Cad(outcome))) = &mut self.current else { return };
        let max_iterations = views.stages().cad.as_ref().map_or(0, |c| c.max_iterations);
        let sensors = self.rig.sensors().len();
        let reg = super::cad_registration::register_cad(views, |it| {
            let corrections = vec![Pose::identity(); sensors];
            progress(&Progress {
                stage: Stage::Cad,
                iteration: it.iteration,
                max_iterations,
                mean_sigma: it.sigma,
                max_change: it.max_change,
                corrections: &corrections,
            })
        });
        *outcome = Some(reg);
    }

    /// What the progress callback sees in the global stage: the sensors aligned so far, and
    /// their motions as corrections.
    pub fn global_progress<R>(&self, then: impl FnOnce(&Progress) -> R) -> Option<R> {
        let (_, stage) = self.aligning.as_ref()?;
        let (aligned, total) = stage.aligned();
        Some(then(&Progress {
            stage: Stage::Global,
            iteration: aligned,
            max_iterations: total,
            mean_sigma: 0.0,
            max_change: 0.0,
            corrections: &stage.applied(),
        }))
    }

    /// What the progress callback sees of the current stage as it stands: the sensors
    /// aligned, EM's latest iteration, the frame pairs recorded, or the run's own step begun.
    pub fn progress<R>(&self, then: impl FnOnce(&Progress) -> R) -> Option<R> {
        match self.stage()? {
            Stage::Global => self.global_progress(then),
            Stage::Views | Stage::Finish => self.step_progress(then),
            Stage::Jrmpc => self.em_progress(then),
            Stage::FramePairs => {
                let Some((_, views, State::Pairs(_, pairs))) = &self.current else { return None };
                let corrections = self.left_out.corrections(views.levelled(&pairs.running()));
                Some(then(&pairs.progress(&corrections)))
            }
            Stage::Cad => {
                let Some((_, views, _)) = &self.current else { return None };
                let max_iterations = views.stages().cad.as_ref().map_or(0, |c| c.max_iterations);
                let corrections = vec![Pose::identity(); self.rig.sensors().len()];
                Some(then(&Progress {
                    stage: Stage::Cad,
                    iteration: 0,
                    max_iterations,
                    mean_sigma: 0.0,
                    max_change: 0.0,
                    corrections: &corrections,
                }))
            }
        }
    }

    /// What the progress callback sees as the run's own step begins, in [`Stage::Views`] and
    /// [`Stage::Finish`]: none of one done, with the corrections as they stand.
    pub fn step_progress<R>(&self, then: impl FnOnce(&Progress) -> R) -> Option<R> {
        let (stage, corrections) = match self.pending.as_ref()? {
            Pending::Views(_, alignments) => {
                (Stage::Views, alignments.iter().map(|a| a.applied).collect::<Vec<_>>())
            }
            Pending::Finish(_, f) => (Stage::Finish, f.corrections.clone()),
        };
        // Identity for a method without a global stage, or a result without corrections.
        let sensors = self.rig.sensors().len();
        let corrections = if corrections.len() == sensors {
            corrections
        } else {
            vec![Pose::identity(); sensors]
        };
        Some(then(&Progress {
            stage,
            iteration: 0,
            max_iterations: 1,
            mean_sigma: 0.0,
            max_change: 0.0,
            corrections: &corrections,
        }))
    }

    /// What the progress callback sees after EM's latest iteration.
    pub fn em_progress<R>(&self, then: impl FnOnce(&Progress) -> R) -> Option<R> {
        let Some((_, views, State::Em(em, _))) = &self.current else { return None };
        let latest = em.latest();
        let corrections = self.left_out.corrections(views.jrmpc_corrections(&latest.poses));
        Some(then(&Progress {
            stage: Stage::Jrmpc,
            iteration: latest.iteration,
            max_iterations: views.settings.jrmpc.max_iterations,
            mean_sigma: latest.mean_sigma,
            max_change: latest.max_change,
            corrections: &corrections,
        }))
    }

    /// Ends the current stage (EM even if unfinished; the frame pairs as far as registered)
    /// and moves on: to the frame pairs, to the method's result, to the next method.
    pub fn advance(&mut self) {
        match self.pending.take() {
            Some(Pending::Views(index, alignments)) => return self.begin(index, alignments),
            Some(Pending::Finish(index, f)) => {
                let outcome = finish(f.views, f.registration, f.pairs);
                let outcome = outcome.map(|c| self.left_out.put_back(&self.rig, c));
                return self.done(index, outcome);
            }
            None => {}
        }
        if let Some((index, stage)) = self.aligning.take() {
            let alignments = self.keep_alignments(stage);
            self.pending = Some(Pending::Views(index, alignments));
            return;
        }
        let Some((index, views, state)) = self.current.take() else { return };
        match state {
            State::Em(em, _) => {
                let corrections = views.jrmpc_corrections(&em.latest().poses);
                let registration = em.into_registration();
                match views.frame_pairs(Some(&registration)) {
                    Some(pairs) => {
                        self.current =
                            Some((index, views, State::Pairs(Some(registration), Box::new(pairs))))
                    }
                    None => self.finishing(index, views, Some(registration), None, corrections),
                }
            }
            State::Pairs(registration, pairs) => {
                let corrections = views.levelled(&pairs.running());
                self.finishing(index, views, registration, Some(*pairs), corrections)
            }
            State::Cad(outcome) => {
                match outcome
                    .unwrap_or_else(|| Err(CalibError::StageFailed("cad did not run".into())))
                {
                    Ok(reg) => self.finishing(index, views, Some(reg), None, Vec::new()),
                    Err(e) => self.done(index, Err(e)),
                }
            }
        }
    }

    /// Method `index`'s result is made at the next advance.
    fn finishing(
        &mut self,
        index: usize,
        views: Views,
        registration: Option<Registration>,
        pairs: Option<FramePairs>,
        corrections: Vec<Pose>,
    ) {
        let corrections = self.left_out.corrections(corrections);
        let f = Finishing { views, registration, pairs, corrections };
        self.pending = Some(Pending::Finish(index, Box::new(f)));
    }

    /// Stops the current stage after its current step; no later method starts.
    pub fn cancel(&mut self) {
        self.cancelled = true;
        match &mut self.current {
            Some((_, _, State::Em(em, _))) => em.cancel(),
            Some((_, _, State::Pairs(_, pairs))) => pairs.stop(),
            Some((_, _, State::Cad(_))) | None => {}
        }
    }

    /// Ends the current method with `error` (its work failed elsewhere, say a worker crashed)
    /// and moves on to the next.
    pub fn fail(&mut self, error: CalibError) {
        if let Some(index) = self.index() {
            (self.pending, self.aligning, self.current) = (None, None, None);
            self.done(index, Err(error));
        }
    }

    /// Every method's outcome, in the run's order (once [`Run::stage`] is `None`; methods never
    /// started, after a cancel, are left out).
    pub fn into_outcomes(mut self) -> Vec<MethodOutcome> {
        if self.outcomes.len() > 1 {
            let mut ran: Vec<&mut Calibration> =
                self.outcomes.iter_mut().filter_map(|(_, o)| o.as_mut().ok()).collect();
            super::judge::compare_methods(&mut ran);
        }
        self.outcomes
    }

    /// Runs every stage of every method here: EM's shards and the frame pairs on `threads`
    /// threads (native; one in wasm32). `progress` sees the method and its progress, and may
    /// stop the run.
    pub fn drive(
        &mut self,
        threads: usize,
        progress: &mut impl FnMut(Method, &Progress) -> Control,
    ) {
        while let Some((_, method)) = self.method() {
            let progress = &mut |p: &Progress| progress(method, p);
            match self.stage() {
                Some(Stage::Global) => self.drive_global(threads, progress),
                Some(Stage::Jrmpc) => self.drive_em(threads, progress),
                Some(Stage::FramePairs) => {
                    let count = self.frame_pairs().map_or(0, |p| p.pairs().len());
                    self.register_pairs(0..count, threads, progress);
                }
                Some(Stage::Views | Stage::Finish) => {
                    if self.progress(|p| progress(p)) == Some(Control::Stop) {
                        self.cancel();
                    }
                }
                Some(Stage::Cad) => {
                    let mut cancel = false;
                    self.register_cad(&mut |p: &Progress| {
                        let control = progress(p);
                        cancel |= control == Control::Stop;
                        control
                    });
                    if cancel {
                        self.cancel();
                    }
                }
                None => return,
            }
            self.advance();
        }
    }

    /// Aligns the pending sensors as many at a time as there are threads; `progress` sees the
    /// stage begin and each batch end.
    fn drive_global(&mut self, threads: usize, progress: &mut impl FnMut(&Progress) -> Control) {
        let batch = crate::threads_here(threads);
        let mut control = self.global_progress(|p| progress(p));
        while control != Some(Control::Stop) {
            let Some(stage) = self.global_stage() else { return };
            let pending = stage.pending();
            if pending.is_empty() {
                return;
            }
            stage.align(&pending[..batch.min(pending.len())], threads);
            control = self.global_progress(|p| progress(p));
        }
        // The rest are aligned as the stage ends, and the method stops at its first stage.
        self.cancel();
    }

    fn drive_em(&mut self, threads: usize, progress: &mut impl FnMut(&Progress) -> Control) {
        let Some((_, _, State::Em(_, points))) = &mut self.current else { return };
        let mut shards = Shards::new(points.take().unwrap_or_default(), threads);
        while let Some(em) = self.em().filter(|em| !em.finished()) {
            shards.iterate(em);
            if self.em_progress(|p| progress(p)) == Some(Control::Stop) {
                self.cancel();
            }
        }
    }

    /// Records method `index`'s outcome and starts the next method, unless cancelled.
    fn done(&mut self, index: usize, outcome: Result<Calibration, CalibError>) {
        self.outcomes.push((self.methods[index], outcome));
        if !self.cancelled {
            self.start(index + 1);
        }
    }

    /// Prepares method `index` (and, if it fails at once, the ones after it): its global
    /// stage, when it asks for one that has not run yet, else its views' step.
    fn start(&mut self, index: usize) {
        let Some(&method) = self.methods.get(index) else { return };
        let settings = &self.settings;
        let wanted = Stages::of(method, settings).global;
        let alignments = match (&wanted, &self.aligned) {
            (None, _) => Vec::new(),
            (Some(wanted), Some((settings, alignments))) if settings == wanted => {
                alignments.clone()
            }
            (Some(_), _) => match Views::global_stage(&self.rig, method, settings) {
                // Nothing to align (the reference shows no ground): no stage to drive.
                Ok(Some(stage)) if stage.pending().is_empty() => {
                    self.nothing_to_align.push(index);
                    self.keep_alignments(stage)
                }
                Ok(Some(stage)) => return self.aligning = Some((index, stage)),
                Ok(None) => {
                    self.nothing_to_align.push(index);
                    Vec::new()
                }
                Err(e) => return self.done(index, Err(e)),
            },
        };
        self.pending = Some(Pending::Views(index, alignments));
    }

    /// The global stage's alignments, kept for later methods too.
    fn keep_alignments(&mut self, stage: GlobalStage) -> Vec<GlobalAlignment> {
        let settings = stage.settings().clone();
        let alignments = stage.into_alignments();
        self.aligned = Some((settings, alignments.clone()));
        alignments
    }

    /// Prepares method `index`'s views, its global stage's `alignments` found (empty when it
    /// has none), and its first stage.
    fn begin(&mut self, index: usize, alignments: Vec<GlobalAlignment>) {
        let method = self.methods[index];
        self.left_out = LeftOut::default();
        let views = loop {
            let (rig, kept) = self.left_out.rig(&self.rig, &alignments);
            match Views::with_global(&rig, method, &self.settings, kept) {
                // A sensor none of whose points lie in the region at its start is left out,
                // and the others calibrated; its verdict says so.
                Err(CalibError::OutsideOverlap(name) | CalibError::NoPointsInRoi(name))
                    if self.left_out.may_leave(&self.rig, &name) =>
                {
                    self.left_out.leave(&self.rig, &name, &alignments)
                }
                views => break views,
            }
        };
        let started = views.and_then(|views| {
            if views.stages().cad.is_some() {
                return Ok((views, Some(State::Cad(None))));
            }
            if views.stages().jrmpc {
                let (em, points) = views.start_jrmpc()?;
                return Ok((views, Some(State::Em(em, Some(points)))));
            }
            let pairs = views.frame_pairs(None);
            Ok((views, pairs.map(|p| State::Pairs(None, Box::new(p)))))
        });
        match started {
            Ok((views, Some(state))) => {
                self.current = Some((index, views, state));
                // Cancelled during the global stage: its first stage stops at once.
                if self.cancelled {
                    self.cancel();
                }
            }
            // No stage to run (a method without registrations cannot be configured today).
            Ok((views, None)) => self.finishing(index, views, None, None, Vec::new()),
            Err(e) => self.done(index, Err(e)),
        }
    }
}
