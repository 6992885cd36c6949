//! The last stages of a calibration, once its registrations are done: the joint plane
//! adjustment, the average over frames, the corrected extrinsics and the reconstruction.

use nalgebra::Vector3;

use super::CalibError;
use super::average::robust_average;
use super::evidence::{ReferenceSurface, sensor_evidence};
use super::notes::{Note, NoteKind};
use super::pairs::FramePairs;
use super::planes;
use super::reconstruction::reconstruct;
use super::result::{Calibration, SensorResult};
use super::verdict::{self, Level, SensorInputs, Verdict};
use super::views::{Views, jrmpc_per_pair};
use crate::jrmpc::Registration;
use crate::se3::Pose;

/// The calibration from `views`, JRMPC's `registration` (the methods that run it) and the
/// frame pairs as far as they were registered.
pub(super) fn finish(
    views: Views,
    registration: Option<Registration>,
    pairs: Option<FramePairs>,
) -> Result<Calibration, CalibError> {
    let reference_ground = views.reference_ground();
    let Views {
        settings,
        stages,
        sensors,
        reference: r,
        nominals,
        levelling,
        global,
        levelled,
        pre_aligned,
        views,
        mut skipped,
        pairs: frame_pairs,
        ground,
        placements,
        same_scans,
        roi,
    } = views;
    let name = |view: usize| (sensors[views[view].sensor].clone(), views[view].frame.clone());
    let mut kept_jrmpc = Vec::new();

    // The per-frame corrections: the frame pairs' where they ran, else JRMPC's.
    let mut per_pair = match (&pairs, &registration) {
        (Some(pairs), _) => {
            let (per_pair, failures) = pairs.corrections();
            for failure in failures {
                let (sensor, frame) = name(failure.view);
                let kept = failure.kept_start();
                let note = Note { sensor, frame: Some(frame), kind: failure.kind };
                if kept { kept_jrmpc.push(note) } else { skipped.push(note) }
            }
            per_pair
        }
        (None, Some(registration)) => jrmpc_per_pair(&frame_pairs, registration),
        (None, None) => return Err(CalibError::InvalidSetting("no registration to finish")),
    };

    // The joint plane adjustment: one motion per sensor on every frame.
    let clouds: Vec<&[[f32; 3]]> = views.iter().map(|v| v.cloud.points.as_slice()).collect();
    let mut precision = vec![None; sensors.len()];
    let mut plane_adjustment = Vec::new();
    if let Some(plane_settings) = &stages.planes {
        // The clouds are pre-aligned: each sensor sits at its levelled nominal.
        let origins: Vec<Vector3<f64>> = pre_aligned.iter().map(|p| p.translation.vector).collect();
        let ground = reference_ground.map(|(plane, _)| plane);
        let adjustments = planes::adjust(
            &clouds,
            &origins,
            &frame_pairs,
            r,
            &mut per_pair,
            ground,
            plane_settings,
        );
        for a in &adjustments {
            if a.accepted {
                precision[a.sensor] = a.precision;
            }
            let kind = a.note(plane_settings.max_departure);
            plane_adjustment.push(Note { sensor: sensors[a.sensor].clone(), frame: None, kind });
        }
    }

    // Average over frames, leaving out frames far from the others.
    let reference_nominal = nominals[r];
    let mut results = Vec::with_capacity(sensors.len());
    for (s, sensor) in sensors.iter().enumerate() {
        let corrections: Vec<Pose> = per_pair[s].iter().map(|(_, c)| c * levelled[s]).collect();
        let Some((correction, spread, outliers)) = robust_average(&corrections) else {
            return Err(CalibError::FramesFailed { sensor: sensor.clone() });
        };
        for i in outliers {
            let (_, view) = per_pair[s][i].0;
            let d = correction.inverse() * corrections[i];
            let (angle, distance) = (d.rotation.angle(), d.translation.vector.norm());
            let kind = NoteKind::FrameOutlier { angle, distance };
            skipped.push(Note { sensor: sensor.clone(), frame: Some(name(view).1), kind });
        }
        let extrinsic = correction * nominals[s];
        results.push(SensorResult {
            name: sensor.clone(),
            correction,
            extrinsic,
            relative: reference_nominal.inverse() * extrinsic,
            spread,
            precision: precision[s],
        });
    }

    // The reconstruction and its plausibility.
    let (mut reconstruction, iterations, converged, cancelled, history) = match registration {
        Some(reg) => {
            let reference_views: Vec<usize> = frame_pairs[r].iter().map(|&(v, _)| v).collect();
            let reconstruction = reconstruct(&reg, &reference_views, ground, &settings.target);
            (reconstruction, reg.iterations, reg.converged, reg.cancelled, reg.history)
        }
        None => (Default::default(), 0, true, false, Vec::new()),
    };
    reconstruction.placements = placements;
    // The verdict, from evidence measured on the same views.
    let mut surfaces: Vec<Option<ReferenceSurface>> = clouds.iter().map(|_| None).collect();
    for &(view, _) in &frame_pairs[r] {
        // The frame pairs' ICP target of this view, where it was built here, has searched
        // the same neighbourhoods already.
        let target = pairs.as_ref().and_then(|p| p.target(view));
        let shared =
            target.and_then(|t| ReferenceSurface::of_target(t, clouds[view], ground.as_ref()));
        surfaces[view] =
            Some(shared.unwrap_or_else(|| ReferenceSurface::new(clouds[view], ground.as_ref())));
    }
    let count = |notes: &[Note], sensor: &str, kinds: &dyn Fn(&NoteKind) -> bool| {
        notes.iter().filter(|n| n.sensor == sensor && kinds(&n.kind)).count()
    };
    let mut sensor_verdicts = Vec::with_capacity(results.len());
    for (s, result) in results.iter().enumerate() {
        let name = &result.name;
        let evidence = (s != r).then(|| {
            let before = levelled[s].inverse();
            let after = result.correction * before;
            let pairs = &frame_pairs[s];
            sensor_evidence(name, pairs, &clouds, &surfaces, &before, &after, ground.as_ref())
        });
        let others: Vec<&SensorResult> = results.iter().filter(|o| o.name != *name).collect();
        let level = levelling.get(s);
        let mut v = verdict::judge_sensor(
            SensorInputs {
                result,
                evidence,
                frames: result.spread.frames,
                left_out: count(&skipped, name, &|k| {
                    matches!(k, NoteKind::FrameOutlier { .. } | NoteKind::PairFailed { .. })
                }),
                rejected: count(&kept_jrmpc, name, &|_| true),
                empty: count(&skipped, name, &|k| matches!(k, NoteKind::NoValidPoints)),
                same_scans: same_scans.iter().find(|(a, _)| a == name).map(|(_, b)| b.clone()),
                warning: level.and_then(|l| l.warning),
                not_levelled: level.and_then(|l| l.skipped.clone()),
                global: global.get(s).filter(|_| s != r),
            },
            &others,
        );
        verdict::judge_frames(&mut v, (result.spread.rpy, result.spread.xyz), result.spread.frames);
        sensor_verdicts.push(v);
    }
    let reasons = verdict::judge_reconstruction(
        &settings.target,
        &reconstruction.fits,
        !reconstruction.means.is_empty(),
        (iterations > 0).then_some((converged, iterations)),
    );
    let level = sensor_verdicts
        .iter()
        .map(|v| v.level)
        .chain(reasons.iter().map(|r| r.level))
        .max()
        .unwrap_or(Level::Good);
    let verdict = Verdict { level, reasons, sensors: sensor_verdicts };
    Ok(Calibration {
        method: stages.method,
        reference: sensors[r].clone(),
        sensors: results,
        reconstruction,
        iterations,
        converged,
        cancelled,
        exact: stages.jrmpc && settings.jrmpc.exact,
        skipped,
        kept_jrmpc,
        plane_adjustment,
        levelling,
        global,
        roi,
        history,
        verdict,
    })
}
