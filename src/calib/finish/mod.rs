//! The last stages of a calibration, once its registrations are done, as phases: every
//! stage's output gathered as a hypothesis, the selection, the joint plane adjustment, the
//! average over frames, the reconstruction, and the verdict.

mod adjust;
mod extrinsics;
mod hypotheses;
mod judging;
mod scene;

use super::CalibError;
use super::pairs::FramePairs;
use super::reconstruction::reconstruct;
use super::result::Calibration;
use super::views::Views;
use crate::jrmpc::Registration;

use hypotheses::Hypotheses;
use judging::Judged;

/// The calibration from `views`, JRMPC's `registration` (the methods that run it) and the
/// frame pairs as far as they were registered.
pub(super) fn finish(
    mut views: Views,
    registration: Option<Registration>,
    pairs: Option<FramePairs>,
) -> Result<Calibration, CalibError> {
    if registration.is_none() && pairs.is_none() {
        return Err(CalibError::InvalidSetting("no registration to finish"));
    }
    // 1. Every stage's output a hypothesis: the starts', the registration's, the refinements'.
    let mut hypotheses = Hypotheses::gather(&mut views, registration.as_ref(), pairs.as_ref());
    // 2. The selection: one hypothesis per sensor, on the whole scans.
    hypotheses.check_own_results(&views)?;
    hypotheses.choose(&views);
    // 2b. Where the registrations saw a region, the chosen refined on the whole scans, and
    // chosen again.
    if scene::refine_on_scene(&views, &mut hypotheses) {
        hypotheses.choose(&views);
    }
    // 3. The joint plane adjustment of the chosen, one more hypothesis, chosen again.
    let clouds: Vec<&[[f32; 3]]> = views.views.iter().map(|v| v.cloud.points.as_slice()).collect();
    let (plane_adjustment, precision) = adjust::adjust_chosen(&views, &clouds, &mut hypotheses);
    // 4. The frames the chosen refinement failed to register are left out, and said so.
    let mut skipped = std::mem::take(&mut views.skipped);
    skipped.extend(hypotheses.failures_left_out(&views));
    let per_pair = hypotheses.chosen_frames();
    let selection = hypotheses.into_selection(&views);
    // 5. The extrinsics: averaged over frames, their precision floored by the scans.
    let mut results = extrinsics::average_frames(&views, &per_pair, &precision, &mut skipped)?;
    let grounds = extrinsics::floor_precision(&views, &mut results);
    // 6. The reconstruction.
    let (mut reconstruction, iterations, converged, cancelled, history) = match registration {
        Some(reg) => {
            let reference_views: Vec<usize> =
                views.pairs[views.reference].iter().map(|&(v, _)| v).collect();
            let target = &views.settings.target;
            let reconstruction = reconstruct(&reg, &reference_views, views.ground, target);
            (reconstruction, reg.iterations, reg.converged, reg.cancelled, reg.history)
        }
        None => (Default::default(), 0, true, false, Vec::new()),
    };
    reconstruction.placements = std::mem::take(&mut views.placements);
    // 7. The verdict, from evidence measured on the same views.
    let judged = Judged {
        pairs: pairs.as_ref(),
        skipped: &skipped,
        selection: &selection,
        grounds: &grounds,
        reconstruction: &reconstruction,
        em: (iterations > 0).then_some((converged, iterations)),
    };
    let verdict = judging::judge(&views, &clouds, &mut results, judged);
    let Views { settings, stages, sensors, reference, levelling, global, roi, roi_source, .. } =
        views;
    Ok(Calibration {
        method: stages.method,
        reference: sensors[reference].clone(),
        sensors: results,
        reconstruction,
        iterations,
        converged,
        cancelled,
        exact: stages.jrmpc && settings.jrmpc.exact,
        skipped,
        selection,
        plane_adjustment,
        levelling,
        global,
        roi,
        roi_source,
        history,
        verdict,
    })
}
