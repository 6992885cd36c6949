//! The corrected extrinsics: each sensor's chosen corrections averaged over frames, and the
//! precision no finer than what the scans tell apart.

use super::super::average::robust_average;
use super::super::notes::{Note, NoteKind};
use super::super::pairs::PairCorrections;
use super::super::result::SensorResult;
use super::super::select::GroundAgreement;
use super::super::verdict::MIN_GROUND_PATCHES;
use super::super::views::Views;
use super::super::{CalibError, Precision};
use crate::se3::Pose;
use nalgebra::Vector3;

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
/// 4 mm). Nor finer than the sensors' grounds agree with the result
/// ([`add_ground_disagreement`]). Returns each sensor's ground against the others', patch by
/// patch at the result, for the verdict.
pub(super) fn floor_precision(
    views: &Views,
    results: &mut [SensorResult],
) -> Vec<Option<GroundAgreement>> {
    let placed: Vec<Pose> = results.iter().map(|x| x.extrinsic).collect();
    let floors: Vec<Option<([f64; 3], [f64; 3])>> = (0..results.len())
        .map(|s| {
            (s != views.reference)
                .then(|| views.scenes.resolve(s, &placed, views.settings.select.z))
        })
        .collect();
    // The sensors' grounds at the result, where they share patches: evidence beside the
    // structure the registrations fitted.
    let grounds: Vec<Option<GroundAgreement>> = (0..results.len())
        .map(|s| {
            let ground = views.ground.filter(|_| s != views.reference)?;
            views.scenes.ground_agreement(s, &placed, &ground)
        })
        .collect();
    for (s, (result, floor)) in results.iter_mut().zip(floors).enumerate() {
        let Some((rotation, position)) = floor else { continue };
        let mut p = result.precision.unwrap_or_default();
        for i in 0..3 {
            p.rotation[i] = p.rotation[i].max(rotation[i]);
            p.position[i] = p.position[i].max(position[i]);
        }
        if let (Some(g), Some(ground)) = (grounds[s], views.ground) {
            add_ground_disagreement(&mut p, &g, &ground.normal);
        }
        result.precision = Some(p);
    }
    grounds
}

/// Where the sensors' grounds lie apart beyond what their own noise and the claim allow
/// together, the result and the ground disagree by that much, whichever is wrong (the Livox
/// Mid-100's unit L0 against L1: 0.18 ± 0.05 deg of tilt where the claim was 0.06 deg, and
/// MLCC's answer lies 0.24 deg away in roll): the excess joins the claim in quadrature, the
/// tilt about its axis and the offset along the ground's normal. A claim that already covers
/// what the grounds show keeps its size, so an honest one on a twin stays honest.
fn add_ground_disagreement(p: &mut Precision, g: &GroundAgreement, normal: &Vector3<f64>) {
    if g.patches < MIN_GROUND_PATCHES {
        return;
    }
    // The claim's one sigma along a direction, its axes taken as independent.
    let along = |claim: &[f64; 3], direction: &[f64; 3]| {
        (0..3).map(|i| (claim[i] * direction[i]).powi(2)).sum::<f64>().sqrt()
    };
    let normal: [f64; 3] = (*normal).into();
    let excess = |value: f64, sigma: f64, claim: f64| {
        (value * value - sigma * sigma - claim * claim).max(0.0).sqrt()
    };
    let tilt = excess(g.tilt, g.tilt_sigma, along(&p.rotation, &g.axis));
    let height = excess(g.height, g.height_sigma, along(&p.position, &normal));
    let add = |claim: &mut f64, excess: f64| *claim = claim.hypot(excess);
    for (claim, a) in p.rotation.iter_mut().zip(g.axis) {
        add(claim, tilt * a.abs());
    }
    for (claim, n) in p.position.iter_mut().zip(normal) {
        add(claim, height * n.abs());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grounds(tilt_deg: f64, height: f64, patches: usize) -> GroundAgreement {
        GroundAgreement {
            patches,
            height,
            tilt: tilt_deg.to_radians(),
            height_sigma: 0.001,
            tilt_sigma: 0.01f64.to_radians(),
            axis: [1.0, 0.0, 0.0],
        }
    }

    /// Grounds tilted 0.18 deg about x where the claim is 0.06 deg and the grounds' own noise
    /// 0.01 deg: roll's claim grows to cover it, pitch and yaw keep theirs; 5 mm apart in height
    /// against a 2 mm claim: z grows. Grounds within what the claim and their noise allow, or
    /// too few patches to judge by, change nothing.
    #[test]
    fn grounds_apart_beyond_the_claim_widen_it_about_their_axis() {
        let claim = Precision { rotation: [0.06f64.to_radians(); 3], position: [0.002; 3] };
        let up = Vector3::z();
        let mut p = claim;
        add_ground_disagreement(&mut p, &grounds(0.18, 0.005, 10), &up);
        let roll = p.rotation[0].to_degrees();
        // 0.18^2 - 0.01^2 - 0.06^2 beyond, added to 0.06^2: 0.1797 deg.
        assert!((roll - 0.1797).abs() < 1e-3, "{roll}");
        assert_eq!(p.rotation[1..], claim.rotation[1..]);
        // 5^2 - 1^2 - 2^2 beyond, added to 2^2: 4.899 mm.
        assert!((p.position[2] - 0.004899).abs() < 1e-5, "{:?}", p.position);
        assert_eq!(p.position[..2], claim.position[..2]);
        for within in [grounds(0.05, 0.001, 10), grounds(0.18, 0.005, 2)] {
            let mut p = claim;
            add_ground_disagreement(&mut p, &within, &up);
            assert_eq!(p, claim);
        }
    }
}
