//! Every stage's output as a hypothesis per sensor, and the selection among them.

use super::super::CalibError;
use super::super::average::average;
use super::super::notes::Note;
use super::super::pairs::{FramePairs, PairCorrections, PairFailure, PairStart};
use super::super::select::{self, Hypothesis, SensorSelection, Source};
use super::super::views::{Views, jrmpc_per_pair};
use crate::jrmpc::Registration;
use crate::se3::Pose;

/// Per sensor, the hypotheses so far, each with its per-frame corrections (of the pre-aligned
/// views), the frames each refinement failed to register, and the one chosen.
pub(super) struct Hypotheses {
    pub(super) list: Vec<Vec<Hypothesis>>,
    /// Per sensor and hypothesis, the per-frame corrections: the start's hypotheses hold one
    /// correction on every frame.
    frames: Vec<Vec<PairCorrections>>,
    /// Per sensor, the frames each refinement failed to register: (hypothesis, failures).
    failed: Vec<Vec<(usize, Vec<PairFailure>)>>,
    pub(super) chosen: Vec<usize>,
}

impl Hypotheses {
    /// The starts' hypotheses `views` holds, then the registration's, then each start's
    /// refinement; the last of each sensor chosen for now.
    pub(super) fn gather(
        views: &mut Views,
        registration: Option<&Registration>,
        pairs: Option<&FramePairs>,
    ) -> Self {
        let list = std::mem::take(&mut views.hypotheses);
        let frames = (0..views.sensors.len())
            .map(|s| {
                let undo = views.levelled[s].inverse();
                let constant = |c: Pose| views.pairs[s].iter().map(|&pair| (pair, c)).collect();
                list[s].iter().map(|h| constant(h.correction * undo)).collect()
            })
            .collect();
        let mut all =
            Self { list, frames, failed: vec![Vec::new(); views.sensors.len()], chosen: vec![] };
        let r = views.reference;
        let mut registered = vec![None; views.sensors.len()];
        if let Some(reg) = registration {
            let source = if views.stages.cad.is_some() { Source::Cad } else { Source::Jrmpc };
            for (s, per_frame) in jrmpc_per_pair(&views.pairs, reg).into_iter().enumerate() {
                if s != r {
                    registered[s] = all.add(views, s, source, views.start[s], per_frame);
                }
            }
        }
        if let Some(pairs) = pairs {
            for &origin in pairs.origins() {
                let (per_pair, failures) = pairs.corrections(origin);
                for (s, per_frame) in per_pair.into_iter().enumerate().filter(|(s, _)| *s != r) {
                    let (source, parent) = match origin {
                        PairStart::Registration => match registered[s] {
                            Some(j) => (Source::Refined, j),
                            None => continue,
                        },
                        PairStart::Start => (Source::RefinedFromStart, views.start[s]),
                        PairStart::Nominal => (Source::RefinedFromNominal, 0),
                    };
                    if let Some(h) = all.add(views, s, source, parent, per_frame) {
                        let own = failures.iter().filter(|f| views.views[f.view].sensor == s);
                        all.failed[s].push((h, own.cloned().collect()));
                    }
                }
            }
        }
        all.chosen = all.list.iter().map(|h| h.len() - 1).collect();
        all
    }

    /// Adds sensor `s`'s hypothesis of `per_frame` corrections (their mean), refined from
    /// `parent`; its index, or `None` when the frames do not average.
    pub(super) fn add(
        &mut self,
        views: &Views,
        s: usize,
        source: Source,
        parent: usize,
        per_frame: PairCorrections,
    ) -> Option<usize> {
        let (mean, _) = average(&per_frame.iter().map(|(_, c)| *c).collect::<Vec<_>>())?;
        let correction = mean * views.levelled[s];
        Some(self.push(s, Hypothesis::new(source, correction, Some(parent)), per_frame))
    }

    /// Adds sensor `s`'s `hypothesis` with its per-frame corrections; its index.
    pub(super) fn push(
        &mut self,
        s: usize,
        hypothesis: Hypothesis,
        per_frame: PairCorrections,
    ) -> usize {
        self.list[s].push(hypothesis);
        self.frames[s].push(per_frame);
        self.list[s].len() - 1
    }

    /// A paper method keeps its own result as published: an error where its own stage
    /// registered no frame of a sensor, so there is no result to keep.
    pub(super) fn check_own_results(&self, views: &Views) -> Result<(), CalibError> {
        if views.stages.select {
            return Ok(());
        }
        for s in (0..views.sensors.len()).filter(|&s| s != views.reference) {
            let own = self.list[s].last().map(|h| h.source);
            if matches!(
                own,
                None | Some(Source::Nominal | Source::Global { .. } | Source::Levelled)
            ) {
                return Err(CalibError::FramesFailed { sensor: views.sensors[s].clone() });
            }
        }
        Ok(())
    }

    /// The selection: one hypothesis per sensor, scored on the whole scans. The paper's
    /// methods keep their own (the last); their scores still reach the verdict.
    pub(super) fn choose(&mut self, views: &Views) {
        if !views.stages.select {
            self.chosen = self.list.iter().map(|h| h.len() - 1).collect();
        }
        let mut picked = self.chosen.clone();
        let on = select::Scoring {
            scenes: &views.scenes,
            nominals: &views.nominals,
            reference: views.reference,
            ground: views.ground.as_ref(),
        };
        select::choose_all(
            &on,
            &mut self.list,
            &mut picked,
            &views.settings.select,
            views.settings.jrmpc.threads,
        );
        if views.stages.select {
            self.chosen = picked;
        }
    }

    /// Per sensor, the chosen hypothesis's per-frame corrections.
    pub(super) fn chosen_frames(&self) -> Vec<PairCorrections> {
        (0..self.list.len()).map(|s| self.frames[s][self.chosen[s]].clone()).collect()
    }

    /// The frames the chosen refinement failed to register, as notes (a plane adjustment's
    /// frames are its parent's).
    pub(super) fn failures_left_out(&self, views: &Views) -> Vec<Note> {
        let mut notes = Vec::new();
        for (s, list) in self.failed.iter().enumerate() {
            let mut h = self.chosen[s];
            if self.list[s][h].source == Source::Planes {
                h = self.list[s][h].parent.unwrap_or(h);
            }
            for failure in list.iter().filter(|(k, _)| *k == h).flat_map(|(_, f)| f) {
                let view = &views.views[failure.view];
                notes.push(Note {
                    sensor: views.sensors[view.sensor].clone(),
                    frame: Some(view.frame.clone()),
                    kind: failure.kind.clone(),
                });
            }
        }
        notes
    }

    /// Per non-reference sensor, its hypotheses, scored, and the one chosen.
    pub(super) fn into_selection(self, views: &Views) -> Vec<SensorSelection> {
        let chosen = self.chosen;
        (self.list.into_iter().enumerate())
            .filter(|&(s, _)| s != views.reference)
            .map(|(s, hypotheses)| SensorSelection {
                sensor: views.sensors[s].clone(),
                hypotheses,
                chosen: chosen[s],
                resolution: views.scenes.resolution(s),
                basin: views.settings.refine.match_distances.first().copied().unwrap_or(0.0),
            })
            .collect()
    }
}
