//! The joint plane adjustment of the chosen hypotheses: one motion per sensor on every frame,
//! itself a hypothesis, after which the selection runs again.

use nalgebra::Vector3;

use super::super::Precision;
use super::super::notes::{GroundWindow, Note};
use super::super::planes;
use super::super::select::{self, Hypothesis, Source};
use super::super::views::Views;
use super::hypotheses::Hypotheses;

/// The adjustment's notes, and per sensor its precision where it stands for the chosen (the
/// score cannot tell the two apart); nothing when the method has no plane adjustment.
pub(super) fn adjust_chosen(
    views: &Views,
    clouds: &[&[[f32; 3]]],
    hypotheses: &mut Hypotheses,
) -> (Vec<Note>, Vec<Option<Precision>>) {
    let n = views.sensors.len();
    let mut precision = vec![None; n];
    let mut notes = Vec::new();
    let Some(plane_settings) = &views.stages.planes else { return (notes, precision) };
    // The clouds are pre-aligned: each sensor sits at its levelled nominal.
    let origins: Vec<Vector3<f64>> =
        views.pre_aligned.iter().map(|p| p.translation.vector).collect();
    let ground = views.reference_ground().map(|(plane, _)| plane);
    // The ground's windows are hypotheses (`PlaneSettings::ground_windows`): one cuts what
    // stands on a road, another keeps a steep view's noise whole. The sensors' grounds, patch
    // by patch, tell which the rig's returns call for; without shared ground, the first.
    let windows = &plane_settings.ground_windows;
    let mut tried: Vec<_> = windows
        .iter()
        .map(|&above| {
            let mut adjusted = hypotheses.chosen_frames();
            let adjustments = planes::adjust(
                clouds,
                &origins,
                &views.pairs,
                views.reference,
                &mut adjusted,
                ground.map(|g| (g, above)),
                plane_settings,
            );
            let apart = grounds_apart(views, hypotheses, &adjustments);
            (adjusted, adjustments, apart)
        })
        .collect();
    if tried.is_empty() {
        return (notes, precision);
    }
    let apart: Vec<Option<f64>> = tried.iter().map(|t| t.2).collect();
    // The first of the closest (ties keep the earlier window).
    let keep = match apart.iter().copied().collect::<Option<Vec<f64>>>() {
        Some(all) => (0..all.len()).fold(0, |best, k| if all[k] < all[best] { k } else { best }),
        None => 0,
    };
    let other = (0..apart.len()).filter(|&k| k != keep).filter_map(|k| apart[k]).reduce(f64::min);
    let window = GroundWindow { above: windows[keep], apart: apart[keep], other };
    let (adjusted, adjustments, _) = tried.swap_remove(keep);
    let mut planes_at = vec![None; n];
    for a in &adjustments {
        if a.accepted {
            let s = a.sensor;
            let parent = hypotheses.chosen[s];
            let correction = a.motion * hypotheses.list[s][parent].correction;
            let hypothesis = Hypothesis::new(Source::Planes, correction, Some(parent));
            planes_at[s] = Some((hypotheses.push(s, hypothesis, adjusted[s].clone()), a.precision));
        }
        let kind = a.note(plane_settings.max_departure, window);
        notes.push(Note { sensor: views.sensors[a.sensor].clone(), frame: None, kind });
    }
    if planes_at.iter().any(Option::is_some) {
        hypotheses.choose(views);
        for (s, at_planes) in planes_at.into_iter().enumerate() {
            let Some((h, p)) = at_planes else { continue };
            let chosen = hypotheses.chosen[s];
            let at = |k: usize| hypotheses.list[s][k].correction * views.nominals[s];
            let resolution = views.scenes.resolution(s);
            if h == chosen || views.scenes.apart(s, &at(h), &at(chosen)) <= resolution {
                precision[s] = p;
            }
        }
    }
    (notes, precision)
}

/// How far the sensors' grounds lie apart once `adjustments` are applied to the chosen
/// hypotheses: the root mean square of each non-reference sensor's height against the others,
/// patch by patch (`Scenes::ground_agreement`); `None` where no two sensors share ground.
fn grounds_apart(
    views: &Views,
    hypotheses: &Hypotheses,
    adjustments: &[planes::SensorAdjustment],
) -> Option<f64> {
    let ground = views.ground?;
    let mut placed = select::placed(&hypotheses.list, &hypotheses.chosen, &views.nominals);
    for a in adjustments.iter().filter(|a| a.accepted) {
        placed[a.sensor] = a.motion * placed[a.sensor];
    }
    let heights: Vec<f64> = (0..placed.len())
        .filter(|&s| s != views.reference)
        .filter_map(|s| views.scenes.ground_agreement(s, &placed, &ground))
        .map(|g| g.height)
        .collect();
    (!heights.is_empty())
        .then(|| (heights.iter().map(|h| h * h).sum::<f64>() / heights.len() as f64).sqrt())
}
