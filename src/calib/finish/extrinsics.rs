//! The corrected extrinsics: each sensor's chosen corrections averaged over frames, and the
//! precision no finer than what the scans tell apart.

use super::super::average::robust_average;
use super::super::notes::{Note, NoteKind};
use super::super::pairs::PairCorrections;
use super::super::result::SensorResult;
use super::super::views::Views;
use super::super::{CalibError, Precision};
use crate::se3::Pose;

/// Per sensor, the average of `per_pair` (the chosen per-frame corrections), leaving out
/// frames far from the others (said in `skipped`), with the plane adjustment's `precision`.
pub(super) fn average_frames(
    views: &Views,
    per_pair: &[PairCorrections],
    precision: &[Option<Precision>],
    skipped: &mut Vec<Note>,
) -> Result<Vec<SensorResult>, CalibError> {
    let reference_nominal = views.nominals[views.reference];
    let mut results = Vec::with_capacity(views.sensors.len());
    for (s, sensor) in views.sensors.iter().enumerate() {
        let corrections: Vec<Pose> =
            per_pair[s].iter().map(|(_, c)| c * views.levelled[s]).collect();
        let Some((correction, spread, outliers)) = robust_average(&corrections) else {
            return Err(CalibError::FramesFailed { sensor: sensor.clone() });
        };
        for i in outliers {
            let (_, view) = per_pair[s][i].0;
            let d = correction.inverse() * corrections[i];
            let (angle, distance) = (d.rotation.angle(), d.translation.vector.norm());
            let kind = NoteKind::FrameOutlier { angle, distance };
            let frame = Some(views.views[view].frame.clone());
            skipped.push(Note { sensor: sensor.clone(), frame, kind });
        }
        let extrinsic = correction * views.nominals[s];
        results.push(SensorResult {
            name: sensor.clone(),
            correction,
            extrinsic,
            relative: reference_nominal.inverse() * extrinsic,
            spread,
            precision: precision[s],
        });
    }
    Ok(results)
}

/// The precision is never finer than what the scans tell apart: the selection score's paired
/// test around the result (`Scenes::resolve`). A fit's curvature (the plane adjustment's) says
/// how sharply its own objective bends, not how far a change a thousand times below the noise
/// moves the answer (OpenCalib under jitter: 0.2 deg / 2 cm against a claimed 0.01-0.04 deg /
/// 4 mm).
pub(super) fn floor_precision(views: &Views, results: &mut [SensorResult]) {
    let placed: Vec<Pose> = results.iter().map(|x| x.extrinsic).collect();
    let floors: Vec<Option<([f64; 3], [f64; 3])>> = (0..results.len())
        .map(|s| {
            (s != views.reference)
                .then(|| views.scenes.resolve(s, &placed, views.settings.select.z))
        })
        .collect();
    for (result, floor) in results.iter_mut().zip(floors) {
        let Some((rotation, position)) = floor else { continue };
        let mut p = result.precision.unwrap_or_default();
        for i in 0..3 {
            p.rotation[i] = p.rotation[i].max(rotation[i]);
            p.position[i] = p.position[i].max(position[i]);
        }
        result.precision = Some(p);
    }
}
