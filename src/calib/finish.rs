//! The last stages of a calibration, once its registrations are done: the joint plane
//! adjustment, the average over frames, the corrected extrinsics and the reconstruction.

use nalgebra::Vector3;

use super::CalibError;
use super::average::{average, robust_average};
use super::evidence::{ReferenceSurface, sensor_evidence};
use super::judge::{self, SensorInputs};
use super::loops;
use super::notes::{Note, NoteKind};
use super::pairs::{FramePairs, PairCorrections, PairFailure, PairStart};
use super::planes;
use super::reconstruction::reconstruct;
use super::result::{Calibration, SensorResult};
use super::select::{self, Hypothesis, SensorSelection, Source};
use super::verdict::{Level, Verdict};
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
    let constant = |s: usize, c: Pose| views.per_pair(|_| c).swap_remove(s);
    // Per sensor, each hypothesis's per-frame corrections (of the pre-aligned views): the
    // start's hypotheses hold one correction on every frame.
    let mut frames: Vec<Vec<PairCorrections>> = (0..views.sensors.len())
        .map(|s| {
            let undo = views.levelled[s].inverse();
            views.hypotheses[s].iter().map(|h| constant(s, h.correction * undo)).collect()
        })
        .collect();
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
        roi_source,
        scenes,
        mut hypotheses,
        start,
    } = views;
    let name = |view: usize| (sensors[views[view].sensor].clone(), views[view].frame.clone());
    if registration.is_none() && pairs.is_none() {
        return Err(CalibError::InvalidSetting("no registration to finish"));
    }

    // Each later stage's hypotheses: the registration's, then each start's refinement.
    let mut add = |s: usize, source: Source, parent: usize, per_frame: PairCorrections| {
        let (mean, _) = average(&per_frame.iter().map(|(_, c)| *c).collect::<Vec<_>>())?;
        let correction = mean * levelled[s];
        hypotheses[s].push(Hypothesis::new(source, correction, Some(parent)));
        frames[s].push(per_frame);
        Some(hypotheses[s].len() - 1)
    };
    let mut registered = vec![None; sensors.len()];
    if let Some(reg) = &registration {
        let source = if stages.cad.is_some() { Source::Cad } else { Source::Jrmpc };
        for (s, per_frame) in jrmpc_per_pair(&frame_pairs, reg).into_iter().enumerate() {
            if s != r {
                registered[s] = add(s, source, start[s], per_frame);
            }
        }
    }
    // Per sensor, the frames each refinement failed to register: (hypothesis, failures).
    let mut failed: Vec<Vec<(usize, Vec<PairFailure>)>> = vec![Vec::new(); sensors.len()];
    if let Some(pairs) = &pairs {
        for &origin in pairs.origins() {
            let (per_pair, failures) = pairs.corrections(origin);
            for (s, per_frame) in per_pair.into_iter().enumerate().filter(|(s, _)| *s != r) {
                let (source, parent) = match origin {
                    PairStart::Registration => match registered[s] {
                        Some(j) => (Source::Refined, j),
                        None => continue,
                    },
                    PairStart::Start => (Source::RefinedFromStart, start[s]),
                    PairStart::Nominal => (Source::RefinedFromNominal, 0),
                };
                if let Some(h) = add(s, source, parent, per_frame) {
                    let own = failures.iter().filter(|f| views[f.view].sensor == s);
                    failed[s].push((h, own.cloned().collect()));
                }
            }
        }
    }

    // The selection: one hypothesis per sensor, on the whole scans. The paper's methods keep
    // their own result as published; their scores still reach the verdict.
    let mut chosen: Vec<usize> = hypotheses.iter().map(|h| h.len() - 1).collect();
    // A paper method whose own stage registered no frame of a sensor has no result to keep.
    if !stages.select {
        for s in (0..sensors.len()).filter(|&s| s != r) {
            let own = hypotheses[s].last().map(|h| h.source);
            if matches!(
                own,
                None | Some(Source::Nominal | Source::Global { .. } | Source::Levelled)
            ) {
                return Err(CalibError::FramesFailed { sensor: sensors[s].clone() });
            }
        }
    }
    let choose = |hypotheses: &mut Vec<Vec<Hypothesis>>, chosen: &mut Vec<usize>| {
        let mut picked = chosen.clone();
        select::choose_all(
            &scenes,
            &nominals,
            r,
            hypotheses,
            &mut picked,
            &settings.select,
            settings.jrmpc.threads,
        );
        if stages.select {
            *chosen = picked;
        }
    };
    choose(&mut hypotheses, &mut chosen);
    let mut per_pair: Vec<PairCorrections> =
        (0..sensors.len()).map(|s| frames[s][chosen[s]].clone()).collect();

    // The joint plane adjustment of the chosen: one motion per sensor on every frame, itself
    // a hypothesis.
    let clouds: Vec<&[[f32; 3]]> = views.iter().map(|v| v.cloud.points.as_slice()).collect();
    let mut precision = vec![None; sensors.len()];
    let mut plane_adjustment = Vec::new();
    if let Some(plane_settings) = &stages.planes {
        // The clouds are pre-aligned: each sensor sits at its levelled nominal.
        let origins: Vec<Vector3<f64>> = pre_aligned.iter().map(|p| p.translation.vector).collect();
        let ground = reference_ground.map(|(plane, _)| plane);
        let mut adjusted = per_pair.clone();
        let adjustments = planes::adjust(
            &clouds,
            &origins,
            &frame_pairs,
            r,
            &mut adjusted,
            ground,
            plane_settings,
        );
        let mut planes_at = vec![None; sensors.len()];
        for a in &adjustments {
            if a.accepted {
                let s = a.sensor;
                let parent = chosen[s];
                let correction = a.motion * hypotheses[s][parent].correction;
                hypotheses[s].push(Hypothesis::new(Source::Planes, correction, Some(parent)));
                frames[s].push(adjusted[s].clone());
                planes_at[s] = Some((hypotheses[s].len() - 1, a.precision));
            }
            let kind = a.note(plane_settings.max_departure);
            plane_adjustment.push(Note { sensor: sensors[a.sensor].clone(), frame: None, kind });
        }
        if planes_at.iter().any(Option::is_some) {
            if !stages.select {
                chosen = hypotheses.iter().map(|h| h.len() - 1).collect();
            }
            choose(&mut hypotheses, &mut chosen);
            for s in 0..sensors.len() {
                per_pair[s] = frames[s][chosen[s]].clone();
                // The plane adjustment's precision stands for the chosen when the score cannot
                // tell the two apart.
                if let Some((h, p)) = planes_at[s] {
                    let at = |k: usize| hypotheses[s][k].correction * nominals[s];
                    let resolution = scenes.resolution(s);
                    if h == chosen[s] || scenes.apart(s, &at(h), &at(chosen[s])) <= resolution {
                        precision[s] = p;
                    }
                }
            }
        }
    }
    // The frames the chosen refinement failed to register are left out, and said so.
    for (s, list) in failed.iter().enumerate() {
        let mut h = chosen[s];
        // A plane adjustment's frames are its parent's.
        if hypotheses[s][h].source == Source::Planes {
            h = hypotheses[s][h].parent.unwrap_or(h);
        }
        for failure in list.iter().filter(|(k, _)| *k == h).flat_map(|(_, f)| f) {
            let (sensor, frame) = name(failure.view);
            skipped.push(Note { sensor, frame: Some(frame), kind: failure.kind.clone() });
        }
    }
    let selection: Vec<SensorSelection> = (0..sensors.len())
        .filter(|&s| s != r)
        .map(|s| SensorSelection {
            sensor: sensors[s].clone(),
            hypotheses: std::mem::take(&mut hypotheses[s]),
            chosen: chosen[s],
            resolution: scenes.resolution(s),
            basin: settings.refine.match_distances.first().copied().unwrap_or(0.0),
        })
        .collect();
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

    // The precision is never finer than what the scans tell apart: the selection score's
    // paired test around the result (`Scenes::resolve`). A fit's curvature (the plane
    // adjustment's) says how sharply its own objective bends, not how far a change a
    // thousand times below the noise moves the answer (OpenCalib under jitter: 0.2 deg / 2 cm
    // against a claimed 0.01-0.04 deg / 4 mm).
    let placed: Vec<Pose> = results.iter().map(|x| x.extrinsic).collect();
    let floors: Vec<Option<([f64; 3], [f64; 3])>> = (0..results.len())
        .map(|s| (s != r).then(|| scenes.resolve(s, &placed, settings.select.z)))
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
        // The frame pairs' ICP fixed cloud of this view, where it was built here, has searched
        // the same neighbourhoods already.
        let target = pairs.as_ref().and_then(|p| p.fixed_cloud(view));
        let shared =
            target.and_then(|t| ReferenceSurface::of_target(t, clouds[view], ground.as_ref()));
        surfaces[view] =
            Some(shared.unwrap_or_else(|| ReferenceSurface::new(clouds[view], ground.as_ref())));
    }
    let count = |notes: &[Note], sensor: &str, kinds: &dyn Fn(&NoteKind) -> bool| {
        notes.iter().filter(|n| n.sensor == sensor && kinds(&n.kind)).count()
    };
    // Each sensor's ground against the others', patch by patch, at the result.
    let placed: Vec<Pose> = results.iter().map(|r| r.extrinsic).collect();
    let grounds: Vec<_> = (0..results.len())
        .map(|s| ground.filter(|_| s != r).and_then(|g| scenes.ground_agreement(s, &placed, &g)))
        .collect();
    // Each pair of the other sensors registered to each other alone, from the result.
    let loops = match &pairs {
        Some(p) => {
            let after: Vec<Pose> =
                results.iter().zip(&levelled).map(|(x, l)| x.correction * l.inverse()).collect();
            let origins: Vec<Vector3<f64>> =
                (after.iter().zip(&pre_aligned)).map(|(a, p)| (a * p).translation.vector).collect();
            let overlap = |a: usize, b: usize| scenes.overlap_with(a, b, &placed);
            let better = |a: usize, b: usize, motion: &Pose| {
                let mut moved = placed.clone();
                moved[b] = motion * placed[b];
                let [at, moved] = scenes.score_with(b, a, &placed, &moved);
                moved.beats(&at, settings.select.z)
            };
            loops::gaps(
                &clouds,
                &frame_pairs,
                r,
                &after,
                &origins,
                p.icp(),
                overlap,
                super::verdict::MIN_OVERLAP,
                better,
            )
        }
        None => Vec::new(),
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
        let mut v = judge::judge_sensor(
            SensorInputs {
                result,
                evidence,
                frames: result.spread.frames,
                left_out: count(&skipped, name, &|k| {
                    matches!(k, NoteKind::FrameOutlier { .. } | NoteKind::PairFailed { .. })
                }),
                selection: selection.iter().find(|x| x.sensor == *name),
                ground: grounds[s],
                loops: (loops.iter())
                    .filter(|g| g.a == s || g.b == s)
                    .map(|g| {
                        let other = if g.a == s { g.b } else { g.a };
                        (results[other].name.clone(), g, results[other].precision.as_ref())
                    })
                    .collect(),
                z: settings.select.z,
                empty: count(&skipped, name, &|k| matches!(k, NoteKind::NoValidPoints)),
                same_scans: same_scans.iter().find(|(a, _)| a == name).map(|(_, b)| b.clone()),
                warning: level.and_then(|l| l.warning),
                not_levelled: level.and_then(|l| l.skipped.clone()),
                global: global.get(s).filter(|_| s != r),
                neighbour: (s != r)
                    .then(|| {
                        (0..results.len())
                            .filter(|&o| o != s && o != r)
                            .map(|o| (o, scenes.overlap_with(s, o, &placed)))
                            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
                    })
                    .flatten()
                    .map(|(o, share)| (results[o].name.clone(), share)),
            },
            &others,
        );
        judge::judge_frames(&mut v, (result.spread.rpy, result.spread.xyz), result.spread.frames);
        sensor_verdicts.push(v);
    }
    // Judged open against the precision the scans gave, the loops then widen it.
    let mut precision: Vec<_> = results.iter().map(|x| x.precision).collect();
    loops::widen(&mut precision, &loops);
    for (result, p) in results.iter_mut().zip(precision) {
        result.precision = p;
    }
    let reasons = judge::judge_reconstruction(
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
