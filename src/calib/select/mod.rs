//! The selection phase: every stage's output is a hypothesis, and one rule decides.
//!
//! Each sensor's hypotheses — the nominal, the global stage's candidates, the levelled start,
//! JRMPC's or `cad`'s result, each refinement, the plane adjustment — are scored on the same
//! scans by one measure ([`Scenes::score`]: how much of the sensor's structure lands on the
//! other sensors' surfaces and theirs on its, within their measured noise). The rule
//! ([`choose`]):
//!
//! 1. a hypothesis scoring below the nominal is never taken, nor one that moves the sensor
//!    further from its nominal position than a tape measure errs (`position_tolerance`; no
//!    limit for a sensor whose nominal is the identity, which says nothing of its place): a
//!    symmetric scene (a road lined alike on both sides) fits a mirrored placement as well as
//!    the right one, and only the nominal's position tells them apart; nor one whose
//!    ground lies apart from the other sensors' beyond what the verdict calls usable
//!    ([`GroundAgreement::beyond`], patch by patch), while another meets it: the grounds are
//!    evidence beside the structure the score weighs (a stacked pair can overlay its
//!    structure upside down, its grounds metres apart);
//! 2. of the rest, those the best does not beat by more than the score's own noise (a paired
//!    comparison over spatial blocks: Student's t at the level of `z` standard errors, its
//!    degrees of freedom the blocks that differ), and those closer to the best than the score
//!    resolves (the voxel the scans were thinned to: there its differences come from the
//!    thinning, not the scans), are tied with it;
//! 3. among the tied, the nominal's family (the nominal and what was refined from it) comes
//!    first: when the scans cannot tell two placements apart, the user's guess stands; else the
//!    best's family;
//! 4. within the family, the latest stage: a refinement the scans cannot tell from its start is
//!    still the better-founded estimate. In the nominal's family, though, only a move from the
//!    nominal that the scans support: one closer than the score resolves, or one that lands
//!    better on the structure the sensor shares with the others at both places
//!    ([`Scenes::score_shared`]). A move that only brings more of the scans into overlap (a
//!    slide along a corridor's walls, where solid-state units see little else) is no evidence
//!    against the user's guess: the nominal stands.
//!
//! So a result never scores worse than its nominal, and when nothing beats the nominal the
//! nominal is the answer.

mod ground;
mod score;
mod sight;
mod surface;
pub use surface::Surface;

use serde::{Deserialize, Serialize};

pub use ground::GroundAgreement;
pub use score::{CONTRADICTION_WEIGHT, SensorScore};
pub use score::{FrameScans, Scenes};

use crate::calib::verdict::USABLE_WITHIN;
use crate::plane::Plane;
use crate::se3::Pose;

/// The selection's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectSettings {
    /// Voxel edge (m) the scans are thinned to, grown while a scan keeps more than
    /// `max_points`.
    pub voxel: f64,
    pub max_points: usize,
    /// Neighbours whose spread gives a point its normal, thickness and reach.
    pub neighbours: usize,
    /// A neighbourhood is a surface when its second spread (m) reaches this: one scan ring is
    /// a line, which has no normal.
    pub min_extent: f64,
    /// Thickness floor (m): below any LiDAR's range noise, so it binds only on voxel
    /// centroids of very flat surfaces.
    pub min_noise: f64,
    /// A neighbourhood thicker than this (m) is no surface (foliage, a fence seen edge on).
    pub max_noise: f64,
    /// Query points per scan.
    pub samples: usize,
    /// Frames scored, spread over the reference's.
    pub frames: usize,
    /// The farthest (m) a point may be from the other scan's nearest point to land on it.
    pub max_gate: f64,
    /// Edge (m) of the blocks the paired comparison treats as independent.
    pub block: f64,
    /// Standard errors by which one hypothesis must beat another to count as better.
    pub z: f64,
    /// The farthest (m) a hypothesis may move a sensor from its nominal position: what a tape
    /// measure or a drawing gets wrong at worst (±1 m per axis is 1.7 m).
    pub position_tolerance: f64,
    /// Two placements are compared on the structure both share when that is at least this
    /// share of the larger one's overlap; else on the whole scans.
    pub shared_overlap: f64,
}

impl Default for SelectSettings {
    fn default() -> Self {
        Self {
            voxel: 0.1,
            max_points: 20_000,
            neighbours: 10,
            min_extent: 0.02,
            min_noise: 0.01,
            max_noise: 0.1,
            samples: 3000,
            frames: 2,
            max_gate: 1.0,
            block: 2.0,
            // One-sided 97.7 %: a convention, not a value fitted to any rig.
            z: 2.0,
            position_tolerance: 2.0,
            // Most of what either end overlaps: a convention, as `z`.
            shared_overlap: 0.5,
        }
    }
}

/// Where a hypothesis came from, in pipeline order (but [`Source::RefinedOnScene`]): later
/// stages started from earlier ones, and stand where the score cannot tell the two apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", tag = "stage")]
pub enum Source {
    /// The nominal as given.
    Nominal,
    /// The global stage's candidate of this rank (0: its best overlay).
    Global { rank: usize },
    /// The start levelled onto the reference's ground, and searched from above when on.
    Levelled,
    /// ICP on the selection's whole scans, started from the chosen hypothesis, where the
    /// registrations saw a region (a target's, or the user's). Ordered before every stage it
    /// may start from: on the thinned scans it is coarser than they are (`stacked` twin:
    /// 35 mm against 0.4 mm), so where the score cannot tell them apart they stand.
    RefinedOnScene,
    /// JRMPC's joint registration.
    Jrmpc,
    /// `cad`'s registration onto the target's model.
    Cad,
    /// The frame pairs' ICP started from the nominal.
    RefinedFromNominal,
    /// The frame pairs' ICP started from the chosen start.
    RefinedFromStart,
    /// The frame pairs' ICP started from JRMPC's or `cad`'s result.
    Refined,
    /// The joint plane adjustment of the chosen refinement.
    Planes,
}

impl Source {
    /// The stage's name in the JSON and the text.
    pub fn name(&self) -> &'static str {
        match self {
            Source::Nominal => "nominal",
            Source::Global { .. } => "global",
            Source::Levelled => "levelled",
            Source::Jrmpc => "jrmpc",
            Source::Cad => "cad",
            Source::RefinedOnScene => "refinedOnScene",
            Source::RefinedFromNominal => "refinedFromNominal",
            Source::RefinedFromStart => "refinedFromStart",
            Source::Refined => "refined",
            Source::Planes => "planes",
        }
    }
}

/// One placement of a sensor, scored.
#[derive(Clone, Debug, PartialEq)]
pub struct Hypothesis {
    pub source: Source,
    /// On top of the sensor's nominal: `correction * T_vehicle_sensor_nominal`.
    pub correction: Pose,
    /// The hypothesis it was refined from (an index into the same list); `None` for a root
    /// (the nominal, a global candidate).
    pub parent: Option<usize>,
    pub score: SensorScore,
    /// It keeps the sensor within the position tolerance of its nominal position.
    pub plausible: bool,
    /// How far (m, root mean square over the sensor's scored points) it places the sensor's
    /// points from where the chosen hypothesis does.
    pub apart: f64,
    /// How its ground meets the other sensors' where they see the same patches; `None`
    /// without a reference ground or shared patches.
    pub ground: Option<GroundAgreement>,
}

impl Hypothesis {
    /// A hypothesis not scored yet.
    pub fn new(source: Source, correction: Pose, parent: Option<usize>) -> Self {
        let score = SensorScore::default();
        Self { source, correction, parent, score, plausible: true, apart: 0.0, ground: None }
    }
}

/// One sensor's hypotheses and the one chosen.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorSelection {
    pub sensor: String,
    pub hypotheses: Vec<Hypothesis>,
    /// Index of the chosen hypothesis.
    pub chosen: usize,
    /// The finest motion (m) the score resolves for this sensor ([`Scenes::resolution`]).
    pub resolution: f64,
    /// How far (m) a start may lie from a placement and still be pulled into it by the
    /// refinement (its first match distance): a rival must lie further.
    pub basin: f64,
}

impl SensorSelection {
    pub fn chosen(&self) -> &Hypothesis {
        &self.hypotheses[self.chosen]
    }

    /// The nominal's hypothesis (always the first).
    pub fn nominal(&self) -> &Hypothesis {
        &self.hypotheses[0]
    }

    /// The best-scoring hypothesis of another family than the chosen one's that the chosen
    /// does not beat, beyond the refinement's basin: a placement elsewhere the scans cannot
    /// rule out.
    pub fn rival(&self, z: f64) -> Option<&Hypothesis> {
        let family = root(&self.hypotheses, self.chosen);
        let chosen = &self.chosen().score;
        (0..self.hypotheses.len())
            .filter(|&h| root(&self.hypotheses, h) != family && self.hypotheses[h].plausible)
            .filter(|&h| self.hypotheses[h].apart > self.resolution.max(self.basin))
            .filter(|&h| !chosen.beats(&self.hypotheses[h].score, z))
            .max_by(|&a, &b| {
                let (a, b) = (&self.hypotheses[a].score, &self.hypotheses[b].score);
                a.value().total_cmp(&b.value())
            })
            .map(|h| &self.hypotheses[h])
    }
}

/// The hypothesis the rule picks (see the module's doc); `hypotheses[0]` is the nominal,
/// `same(a, b)` says two hypotheses are one placement to the score, and `better(h, 0)` that `h`
/// lands better than the nominal on what both placements see.
pub fn choose(
    hypotheses: &[Hypothesis],
    z: f64,
    same: impl Fn(usize, usize) -> bool,
    better: impl Fn(usize, usize) -> bool,
) -> usize {
    let Some(nominal) = hypotheses.first() else { return 0 };
    let value = |h: usize| hypotheses[h].score.value();
    // The grounds are evidence beside the structure: a placement whose ground the verdict
    // would fail is not taken while one that meets the others' ground is on offer.
    let grounded = |h: usize| !hypotheses[h].ground.is_some_and(|g| g.beyond(USABLE_WITHIN, z));
    let any_grounded = (1..hypotheses.len()).any(|h| hypotheses[h].plausible && grounded(h));
    let allowed =
        |h: &usize| *h == 0 || (hypotheses[*h].plausible && (grounded(*h) || !any_grounded));
    let best = (0..hypotheses.len())
        .filter(allowed)
        .max_by(|&a, &b| value(a).total_cmp(&value(b)))
        .unwrap_or(0);
    let tied: Vec<usize> = (0..hypotheses.len())
        .filter(allowed)
        .filter(|&h| value(h) >= nominal.score.value())
        .filter(|&h| {
            h == best || same(best, h) || !hypotheses[best].score.beats(&hypotheses[h].score, z)
        })
        .collect();
    let family =
        if tied.iter().any(|&h| root(hypotheses, h) == 0) { 0 } else { root(hypotheses, best) };
    // The nominal's family: a move the score resolves must land better on what both places
    // see. A global candidate is a point of the search's grid, no guess of the user's: its
    // refinement needs no more than to tie it.
    let supported = |h: usize| family != 0 || h == 0 || same(0, h) || better(h, 0);
    let mut members: Vec<usize> =
        tied.into_iter().filter(|&h| root(hypotheses, h) == family).collect();
    members.sort_by(|&a, &b| {
        let key = |h: usize| (hypotheses[h].source, value(h));
        let ((sa, va), (sb, vb)) = (key(a), key(b));
        sb.cmp(&sa).then(vb.total_cmp(&va)).then(a.cmp(&b))
    });
    // Another family always holds its best; in the nominal's, nothing supported leaves the
    // nominal.
    members.into_iter().find(|&h| supported(h)).unwrap_or(0)
}

/// What every hypothesis is scored against: the scans, each sensor's nominal
/// `T_vehicle_sensor`, the reference (which keeps its nominal) and its ground (vehicle frame),
/// where it has one.
pub(crate) struct Scoring<'a> {
    pub scenes: &'a Scenes,
    pub nominals: &'a [Pose],
    pub reference: usize,
    pub ground: Option<&'a Plane>,
}

/// Chooses each non-reference sensor's hypothesis by [`choose`], each scored with the other
/// sensors at their chosen ones (`chosen[s]`, updated): two passes, so that a sensor first
/// scored against another's wrong placement is scored again against its chosen one. Every
/// hypothesis's score is set, and its ground's agreement with the others'.
pub(crate) fn choose_all(
    on: &Scoring,
    hypotheses: &mut [Vec<Hypothesis>],
    chosen: &mut [usize],
    settings: &SelectSettings,
    threads: usize,
) {
    let Scoring { scenes, nominals, reference: r, ground } = *on;
    for _pass in 0..2 {
        for s in (0..hypotheses.len()).filter(|&s| s != r) {
            let poses = placed(hypotheses, chosen, nominals);
            let candidates: Vec<usize> = (0..hypotheses[s].len()).collect();
            let scores = crate::on_threads(&candidates, crate::threads_here(threads), |&h| {
                let mut at = poses.clone();
                at[s] = placed_at(hypotheses, nominals, s, h);
                (scenes.score(s, &at), ground.and_then(|g| scenes.ground_agreement(s, &at, g)))
            });
            for (h, (score, ground)) in hypotheses[s].iter_mut().zip(scores) {
                h.score = score;
                h.ground = ground;
            }
            let plausible = within_tolerance(&hypotheses[s], &nominals[s], settings);
            for (h, plausible) in hypotheses[s].iter_mut().zip(plausible) {
                h.plausible = plausible;
            }
            let at: Vec<Pose> = hypotheses[s].iter().map(|h| h.correction * nominals[s]).collect();
            let resolution = scenes.resolution(s);
            let same = |a: usize, b: usize| scenes.apart(s, &at[a], &at[b]) <= resolution;
            let placed = |h: usize| {
                let mut all = poses.clone();
                all[s] = at[h];
                all
            };
            let own = &hypotheses[s];
            let better = |h: usize, other: usize| {
                let [mine, theirs] = scenes.score_shared(s, &placed(h), &placed(other));
                let overlap = |x: &SensorScore| x.overlapping.iter().sum::<f64>();
                let larger = overlap(&own[h].score).max(overlap(&own[other].score));
                // Placements that share little of what each sees: the whole scans judge them.
                if mine.total.iter().sum::<f64>() >= settings.shared_overlap * larger {
                    mine.beats(&theirs, settings.z)
                } else {
                    own[h].score.beats(&own[other].score, settings.z)
                }
            };
            chosen[s] = choose(own, settings.z, same, better);
            for (h, pose) in hypotheses[s].iter_mut().zip(&at) {
                h.apart = scenes.apart(s, pose, &at[chosen[s]]);
            }
        }
    }
}

/// Each sensor at its chosen hypothesis (`T_vehicle_sensor`): `hypotheses[s][chosen[s]]` on
/// top of `nominals[s]`; a sensor with none at its nominal.
pub(crate) fn placed(
    hypotheses: &[Vec<Hypothesis>],
    chosen: &[usize],
    nominals: &[Pose],
) -> Vec<Pose> {
    (0..nominals.len()).map(|s| placed_at(hypotheses, nominals, s, chosen[s])).collect()
}

/// Sensor `s` at its hypothesis `h` (`T_vehicle_sensor`); at its nominal where it has none.
fn placed_at(hypotheses: &[Vec<Hypothesis>], nominals: &[Pose], s: usize, h: usize) -> Pose {
    let h = hypotheses.get(s).and_then(|list| list.get(h));
    h.map_or_else(Pose::identity, |h| h.correction) * nominals[s]
}

/// Per hypothesis, whether it keeps the sensor within the position tolerance of its nominal
/// position (all, for a nominal that is the identity: no position given).
pub fn within_tolerance(
    hypotheses: &[Hypothesis],
    nominal: &Pose,
    settings: &SelectSettings,
) -> Vec<bool> {
    let given = *nominal != Pose::identity();
    let at = nominal.translation.vector;
    hypotheses
        .iter()
        .map(|h| {
            let moved = ((h.correction * nominal).translation.vector - at).norm();
            !given || moved <= settings.position_tolerance
        })
        .collect()
}

/// The root of hypothesis `h`'s family: the nominal or the global candidate it descends from.
pub(crate) fn root(hypotheses: &[Hypothesis], mut h: usize) -> usize {
    // Parents precede their children, so the walk ends.
    while let Some(p) = hypotheses[h].parent.filter(|&p| p < h) {
        h = p;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hypothesis(source: Source, parent: Option<usize>, blocks: &[f64]) -> Hypothesis {
        let agreeing = [blocks.iter().sum(), 0.0];
        let blocks = blocks.iter().map(|&b| [b, 0.0]).collect();
        let score = SensorScore {
            agreeing,
            overlapping: agreeing,
            contradicting: [0.0; 2],
            total: [100.0, 0.0],
            blocks,
        };
        Hypothesis {
            source,
            correction: Pose::identity(),
            parent,
            score,
            plausible: true,
            apart: 1.0,
            ground: None,
        }
    }

    /// A move judged on the hypotheses' own scores.
    fn beats(h: &[Hypothesis]) -> impl Fn(usize, usize) -> bool + '_ {
        |child, parent| h[child].score.beats(&h[parent].score, 2.0)
    }

    /// Blocks scoring `level` each, with block-to-block variation whose pattern `seed` sets.
    fn blocks(level: f64, seed: usize) -> Vec<f64> {
        (0..20).map(|b| level + 0.05 * ((b * 7 + seed * 3) % 5) as f64).collect()
    }

    #[test]
    fn a_clearly_better_hypothesis_is_chosen_and_never_one_below_the_nominal() {
        let h = [
            hypothesis(Source::Nominal, None, &blocks(1.0, 1)),
            hypothesis(Source::Global { rank: 0 }, None, &blocks(3.0, 2)),
            hypothesis(Source::Jrmpc, Some(1), &blocks(2.0, 3)),
            hypothesis(Source::Refined, Some(2), &blocks(3.01, 4)),
            hypothesis(Source::Planes, Some(3), &blocks(0.5, 5)),
        ];
        // The refinement ties the global candidate and is later; the plane adjustment scores
        // below the nominal.
        assert_eq!(choose(&h, 2.0, |_, _| false, beats(&h)), 3);
        // Out of the position tolerance, the refinement gives way to the rest.
        let mut far = h.to_vec();
        far[3].plausible = false;
        assert_eq!(choose(&far, 2.0, |_, _| false, beats(&far)), 1);
    }

    #[test]
    fn when_the_scans_cannot_tell_the_nominal_stands() {
        let h = [
            hypothesis(Source::Nominal, None, &blocks(2.0, 6)),
            hypothesis(Source::Global { rank: 0 }, None, &blocks(2.005, 7)),
            hypothesis(Source::Refined, Some(1), &blocks(2.006, 8)),
        ];
        assert_eq!(choose(&h, 2.0, |_, _| false, beats(&h)), 0);
        // A refinement of the nominal that ties is taken over the nominal itself where the
        // score cannot tell the two places apart; a move beyond that which lands no better
        // on what both see (here: the whole scans) leaves the nominal standing.
        let mut with = h.to_vec();
        with.push(hypothesis(Source::RefinedFromNominal, Some(0), &blocks(2.004, 9)));
        let close = |a: usize, b: usize| a.min(b) == 0 && a.max(b) == 3;
        assert_eq!(choose(&with, 2.0, close, beats(&with)), 3);
        assert_eq!(choose(&with, 2.0, |_, _| false, beats(&with)), 0);
        // A move that lands better is taken.
        with[3] = hypothesis(Source::RefinedFromNominal, Some(0), &blocks(2.5, 9));
        assert_eq!(choose(&with, 2.0, |_, _| false, beats(&with)), 3);
    }

    #[test]
    fn a_placement_whose_ground_lies_apart_is_not_taken_while_another_meets_it() {
        let apart = |height: f64| GroundAgreement {
            patches: 20,
            height,
            tilt: 0.0,
            height_sigma: 0.005,
            tilt_sigma: 0.001,
            axis: [0.0; 3],
        };
        let mut h = vec![
            hypothesis(Source::Nominal, None, &blocks(1.0, 13)),
            hypothesis(Source::Global { rank: 0 }, None, &blocks(3.0, 14)),
            hypothesis(Source::Global { rank: 1 }, None, &blocks(2.0, 15)),
        ];
        // The best overlay stands a metre off the others' ground; the second meets it.
        h[1].ground = Some(apart(1.0));
        h[2].ground = Some(apart(0.004));
        assert_eq!(choose(&h, 2.0, |_, _| false, beats(&h)), 2);
        // Within what the verdict calls usable (10 cm), or when no placement meets the ground
        // either, the grounds do not decide.
        h[1].ground = Some(apart(0.09));
        assert_eq!(choose(&h, 2.0, |_, _| false, beats(&h)), 1);
        h[1].ground = Some(apart(1.0));
        h[2].ground = Some(apart(0.8));
        assert_eq!(choose(&h, 2.0, |_, _| false, beats(&h)), 1);
    }

    #[test]
    fn a_rival_elsewhere_is_named() {
        let h = vec![
            hypothesis(Source::Nominal, None, &blocks(1.0, 10)),
            hypothesis(Source::Global { rank: 0 }, None, &blocks(3.0, 11)),
            hypothesis(Source::Global { rank: 1 }, None, &blocks(2.99, 12)),
        ];
        let chosen = choose(&h, 2.0, |_, _| false, beats(&h));
        assert_eq!(chosen, 1);
        let selection = SensorSelection {
            sensor: "s".into(),
            hypotheses: h,
            chosen,
            resolution: 0.1,
            basin: 0.5,
        };
        assert_eq!(selection.rival(2.0).map(|r| r.source), Some(Source::Global { rank: 1 }));
    }
}
