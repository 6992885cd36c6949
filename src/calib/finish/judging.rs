//! The verdict, from evidence measured on the same views after the calibration: each
//! sensor's agreement with the reference's surfaces, its ground against the others', the
//! loops between the other sensors, and the reconstruction's plausibility.

use nalgebra::Vector3;

use super::super::evidence::{ReferenceSurface, sensor_evidence};
use super::super::judge::{self, SensorInputs};
use super::super::loops;
use super::super::notes::{Note, NoteKind};
use super::super::pairs::FramePairs;
use super::super::result::{Reconstruction, SensorResult};
use super::super::select::{GroundAgreement, SensorSelection};
use super::super::verdict::{Level, Verdict};
use super::super::views::Views;
use crate::se3::Pose;

/// What the calibration is judged on besides the views: the frame pairs (their ICP and fixed
/// clouds), what was left out, the selection, each sensor's ground against the others' at the
/// result, the reconstruction, and EM's `(converged, iterations)` where it ran.
pub(super) struct Judged<'a> {
    pub(super) pairs: Option<&'a FramePairs>,
    pub(super) skipped: &'a [Note],
    pub(super) selection: &'a [SensorSelection],
    pub(super) grounds: &'a [Option<GroundAgreement>],
    pub(super) reconstruction: &'a Reconstruction,
    pub(super) em: Option<(bool, usize)>,
}

/// The verdict on `results`, whose precision the loops then widen.
pub(super) fn judge(
    views: &Views,
    clouds: &[&[[f32; 3]]],
    results: &mut [SensorResult],
    on: Judged,
) -> Verdict {
    let (r, ground, frame_pairs) = (views.reference, views.ground, &views.pairs);
    let scenes = &views.scenes;
    let z = views.settings.select.z;
    let mut surfaces: Vec<Option<ReferenceSurface>> = clouds.iter().map(|_| None).collect();
    for &(view, _) in &frame_pairs[r] {
        // The frame pairs' ICP fixed cloud of this view, where it was built here, has searched
        // the same neighbourhoods already.
        let target = on.pairs.and_then(|p| p.fixed_cloud(view));
        let shared =
            target.and_then(|t| ReferenceSurface::of_target(t, clouds[view], ground.as_ref()));
        surfaces[view] =
            Some(shared.unwrap_or_else(|| ReferenceSurface::new(clouds[view], ground.as_ref())));
    }
    let count = |notes: &[Note], sensor: &str, kinds: &dyn Fn(&NoteKind) -> bool| {
        notes.iter().filter(|n| n.sensor == sensor && kinds(&n.kind)).count()
    };
    let placed: Vec<Pose> = results.iter().map(|r| r.extrinsic).collect();
    // Each pair of the other sensors registered to each other alone, from the result.
    let loops = match on.pairs {
        Some(p) => {
            let after: Vec<Pose> = (results.iter().zip(&views.levelled))
                .map(|(x, l)| x.correction * l.inverse())
                .collect();
            let origins: Vec<Vector3<f64>> = (after.iter().zip(&views.pre_aligned))
                .map(|(a, p)| (a * p).translation.vector)
                .collect();
            let overlap = |a: usize, b: usize| scenes.overlap_with(a, b, &placed);
            let better = |a: usize, b: usize, motion: &Pose| {
                let mut moved = placed.clone();
                moved[b] = motion * placed[b];
                let [at, moved] = scenes.score_with(b, a, &placed, &moved);
                moved.beats(&at, z)
            };
            loops::gaps(
                clouds,
                frame_pairs,
                r,
                &after,
                &origins,
                p.icp(),
                overlap,
                super::super::verdict::MIN_OVERLAP,
                better,
            )
        }
        None => Vec::new(),
    };
    let mut sensor_verdicts = Vec::with_capacity(results.len());
    for (s, result) in results.iter().enumerate() {
        let name = &result.name;
        let evidence = (s != r).then(|| {
            let before = views.levelled[s].inverse();
            let after = result.correction * before;
            let pairs = &frame_pairs[s];
            sensor_evidence(name, pairs, clouds, &surfaces, &before, &after, ground.as_ref())
        });
        // The share of this sensor's points beside each other sensor's surfaces.
        let shares: Vec<f64> = (0..results.len())
            .map(|o| if o == s { 0.0 } else { scenes.overlap_with(s, o, &placed) })
            .collect();
        let others: Vec<(&SensorResult, f64)> = (results.iter().enumerate())
            .filter(|&(o, _)| o != s)
            .map(|(o, other)| (other, shares[o]))
            .collect();
        let level = views.levelling.get(s);
        let mut v = judge::judge_sensor(
            SensorInputs {
                result,
                evidence,
                frames: result.spread.frames,
                left_out: count(on.skipped, name, &|k| {
                    matches!(k, NoteKind::FrameOutlier { .. } | NoteKind::PairFailed { .. })
                }),
                selection: on.selection.iter().find(|x| x.sensor == *name),
                ground: on.grounds[s],
                loops: (loops.iter())
                    .filter(|g| g.a == s || g.b == s)
                    .map(|g| {
                        let other = if g.a == s { g.b } else { g.a };
                        (results[other].name.clone(), g, results[other].precision.as_ref())
                    })
                    .collect(),
                z,
                empty: count(on.skipped, name, &|k| matches!(k, NoteKind::NoValidPoints)),
                same_scans: (views.same_scans.iter())
                    .find(|(a, _)| a == name)
                    .map(|(_, b)| b.clone()),
                warning: level.and_then(|l| l.warning),
                not_levelled: level.and_then(|l| l.skipped.clone()),
                global: views.global.get(s).filter(|_| s != r),
                neighbour: (s != r)
                    .then(|| {
                        (0..results.len())
                            .filter(|&o| o != s && o != r)
                            .map(|o| (o, shares[o]))
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
        &views.settings.target,
        &on.reconstruction.fits,
        !on.reconstruction.means.is_empty(),
        on.em,
    );
    let level = sensor_verdicts
        .iter()
        .map(|v| v.level)
        .chain(reasons.iter().map(|r| r.level))
        .max()
        .unwrap_or(Level::Good);
    Verdict { level, reasons, sensors: sensor_verdicts }
}
