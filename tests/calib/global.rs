//! The global initial alignment end to end: twin rigs with a sensor pitched 45 deg
//! and one upside down, from tape-measure nominals (any yaw, +-45 deg of roll and pitch, metres
//! off); and the real OpenCalib road rig (`tests/fixtures/opencalib`), from its own guess and
//! from random wrong starts.

use std::borrow::Cow;
use std::f64::consts::PI;

use gmmcalib::calib::{self, Rig, Scan, Source, Stage, verdict::Level};
use gmmcalib::eval;
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::{Pose, pose_from_xyz_rpy};
use gmmcalib::targets::Target;
use gmmcalib::twin::{Lidar, Miscalibration, Model, Preset, SensorSpec, Twin, expected_correction};
use nalgebra::{Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use crate::common::opencalib_scene;

const D: f64 = PI / 180.0;

/// A tape-measure nominal: roll and pitch off by up to 45 deg, yaw by anything (about the sensor,
/// vehicle axes), position by up to 1 m per axis (a tape measure's error).
fn far_start(truth: &Pose, rng: &mut Pcg64) -> Pose {
    let rpy = [45.0 * D, 45.0 * D, 180.0 * D].map(|a| rng.random_range(-a..=a));
    let xyz = [1.0, 1.0, 1.0].map(|t| rng.random_range(-t..=t));
    let delta = UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    Pose::from_parts(
        Translation3::from(truth.translation.vector + Vector3::from(xyz)),
        delta * truth.rotation,
    )
}

/// The paper preset's front_left, a side sensor pitched 45 deg down looking left, and an
/// upside-down sensor with a symmetric field of view.
fn tilted_rig() -> Preset {
    let mut preset = Preset::paper();
    let lidar = preset.sensors[0].lidar.clone();
    preset.sensors.truncate(1);
    preset.sensors.push(SensorSpec {
        name: "side_pitched".into(),
        mount: pose_from_xyz_rpy([1.8, 0.9, 1.9], [0.0, 45.0 * D, 90.0 * D]),
        lidar,
    });
    preset.sensors.push(SensorSpec {
        name: "upside_down".into(),
        mount: pose_from_xyz_rpy([2.0, -0.5, 1.7], [180.0 * D, 0.0, 30.0 * D]),
        lidar: Lidar::uniform(64, -22.5 * D, 22.5 * D, 2048, 50.0, 0.01),
    });
    preset
}

#[test]
fn twin_rig_with_steep_and_upside_down_sensors_calibrates_from_tape_measure_nominals() {
    let preset = tilted_rig();
    let scans: Vec<Scan> = preset
        .simulate(3, 11)
        .into_iter()
        .map(|v| Scan { sensor: v.sensor, frame: v.frame, points: v.cloud.points, source: None })
        .collect();
    let mut rng = Pcg64::seed_from_u64(3);
    for start in 0..3 {
        let nominal: Vec<(String, Pose)> = preset
            .sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                (s.name.clone(), if i == 0 { s.mount } else { far_start(&s.mount, &mut rng) })
            })
            .collect();
        let rig = Rig {
            scans: scans.clone(),
            nominal: nominal.clone(),
            roi: Some(preset.roi),
            reference: Some(preset.sensors[0].name.clone()),
        };
        let result =
            calib::calibrate(&rig, calib::Method::Gmm, &calib::Settings::default(), |_| {
                Control::Continue
            })
            .expect("calibration");
        for (i, truth) in preset.sensors.iter().enumerate().skip(1) {
            let global = &result.global[i];
            assert_eq!(global.skipped, None, "start {start} {}", truth.name);
            let overlay = global.overlay.as_ref().unwrap();
            assert!(
                overlay.best.score > 0.5 && overlay.ambiguity() < 0.9,
                "start {start}: {overlay:?}"
            );
            let error = result.sensors[i].correction.inverse()
                * expected_correction(&truth.mount, &nominal[i].1);
            let (deg, m) = (error.rotation.angle() / D, error.translation.vector.norm());
            assert!(
                deg < 0.1 && m < 0.01,
                "start {start} {}: {deg:.3} deg {:.1} mm",
                truth.name,
                m * 1e3
            );
        }
        // Without the global stage the same start is lost.
        let local = calib::Settings { align_globally: Some(false), ..Default::default() };
        let today = calib::calibrate(&rig, calib::Method::Gmm, &local, |_| Control::Continue);
        let lost = today.map_or(true, |r| {
            let e = r.sensors[1].correction.inverse()
                * expected_correction(&preset.sensors[1].mount, &nominal[1].1);
            e.rotation.angle() > 1.0 * D
        });
        assert!(lost, "start {start}");
    }
}

fn targetless() -> calib::Settings {
    calib::Settings { target: Target::None, ..Default::default() }
}

/// Rotation (deg) and translation (mm) between two extrinsics.
fn apart(a: &Pose, b: &Pose) -> (f64, f64) {
    let d = a.inverse() * b;
    (d.rotation.angle() / D, d.translation.vector.norm() * 1e3)
}

#[test]
fn opencalib_scenes_calibrate_from_their_own_guess_and_agree() {
    let calibrate = |scene| {
        let result =
            calib::calibrate(&opencalib_scene(scene), calib::Method::Gmm, &targetless(), |_| {
                Control::Continue
            })
            .expect("calibration");
        // Good or check, never failed: 0002's right LiDAR is `check` since its ground lies
        // 13 mm from the reference's where both see it (median of 50 patches), evidence the
        // registration did not optimise; OpenCalib's own answers for the two scenes differ by
        // 0.21 deg / 5.5 cm, so no reference here tells that result wrong or right.
        println!("OpenCalib {scene}: {:?}", result.verdict.level);
        assert_ne!(result.verdict.level, Level::Failed, "{scene}: {:?}", result.verdict);
        result
    };
    let (first, second) = (calibrate("0001"), calibrate("0002"));
    for (a, b) in first.sensors.iter().zip(&second.sensors).skip(1) {
        let (deg, mm) = apart(&a.extrinsic, &b.extrinsic);
        println!("OpenCalib {}: scenes 0001 and 0002 differ by {deg:.3} deg / {mm:.1} mm", a.name);
        // The rig did not change in the minutes between the scenes. Measured 0.20 deg / 17 mm
        // (left), 0.21 deg / 13 mm (right): short of the 0.1 deg / 1 cm aimed at. One frame of
        // 9k side points, 45 deg from level, on a road; the same scene calibrated with other
        // seeds scatters by 0.1-0.25 deg (docs/accuracy.md, "OpenCalib's road rig").
        assert!(deg < 0.3 && mm < 30.0, "{}: {deg} deg {mm} mm", a.name);
    }
}

#[test]
fn opencalib_from_random_wrong_starts_ends_at_the_same_extrinsic() {
    let rig = opencalib_scene("0001");
    let settings = targetless();
    let own = calib::calibrate(&rig, calib::Method::Gmm, &settings, |_| Control::Continue)
        .expect("own guess");
    let mut rng = Pcg64::seed_from_u64(19);
    let mut worst = (0.0f64, 0.0f64);
    for start in 0..6 {
        // A wrong start about the calibrated extrinsic, in the ranges of the issue.
        let nominal: Vec<(String, Pose)> = own
            .sensors
            .iter()
            .map(|s| {
                let wrong = if s.name == own.reference {
                    s.extrinsic
                } else {
                    far_start(&s.extrinsic, &mut rng)
                };
                (s.name.clone(), wrong)
            })
            .collect();
        let wrong = Rig { nominal, ..rig.clone() };
        let result = calib::calibrate(&wrong, calib::Method::Gmm, &settings, |_| Control::Continue)
            .expect("start");
        for (a, b) in own.sensors.iter().zip(&result.sensors).skip(1) {
            let (deg, mm) = apart(&a.extrinsic, &b.extrinsic);
            worst = (worst.0.max(deg), worst.1.max(mm));
            // As far apart as the same start with other seeds (0.1-0.25 deg, 2 cm): the road
            // scene holds these directions loosely, whatever the start.
            assert!(deg < 0.3 && mm < 30.0, "start {start} {}: {deg:.3} deg {mm:.1} mm", a.name);
        }
    }
    println!(
        "OpenCalib 0001 from 6 random wrong starts: worst {:.3} deg / {:.1} mm",
        worst.0, worst.1
    );
}

/// The global stage driven as the page drives it: its sensors aligned one by one, one "in
/// another worker" (its job run on its own, then recorded) and out of order, and natively on
/// two threads. Every way gives `calibrate`'s calibration, to the last bit.
#[test]
fn the_global_stage_gives_the_same_calibration_however_its_sensors_are_shared() {
    let rig = opencalib_scene("0001");
    let settings = targetless();
    let one_thread = calib::calibrate(&rig, calib::Method::Gmm, &settings, |_| Control::Continue)
        .expect("calibrate");
    let expected = format!("{one_thread:?}");

    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &[calib::Method::Gmm]);
    assert_eq!(run.stage(), Some(calib::Stage::Global));
    // The progress counts the sensors aligned; each one's correction is its alignment's motion.
    let progress = |run: &calib::Run| {
        run.global_progress(|p| (p.stage, p.iteration, p.max_iterations, p.corrections.to_vec()))
    };
    let identity = Pose::identity();
    assert_eq!(progress(&run), Some((Stage::Global, 0, 2, vec![identity; 3])));
    let stage = run.global_stage().expect("the global stage");
    assert_eq!(stage.pending(), [1, 2]);
    assert!(stage.job(0).is_none(), "the reference is not aligned");
    let elsewhere = stage.job(2).expect("a pending sensor's job").run();
    let moved = elsewhere.applied;
    assert_ne!(moved, identity, "OpenCalib's far-off start is moved");
    stage.record(2, elsewhere);
    assert_eq!(stage.pending(), [1]);
    assert!(stage.job(2).is_none(), "a recorded sensor is done");
    assert_eq!(progress(&run), Some((Stage::Global, 1, 2, vec![identity, identity, moved])));
    let stage = run.global_stage().expect("the global stage");
    stage.align(&[1], 1);
    assert!(stage.pending().is_empty());
    assert_eq!(progress(&run).map(|(_, done, _, _)| done), Some(2));
    run.advance();
    assert!(progress(&run).is_none(), "no global progress after the stage");
    assert_ne!(run.stage(), Some(calib::Stage::Global));
    run.drive(1, &mut |_, _| Control::Continue);
    let (_, shared) = run.into_outcomes().pop().expect("an outcome");
    assert_eq!(format!("{:?}", shared.expect("shared")), expected);

    let threaded = calib::Settings {
        jrmpc: gmmcalib::jrmpc::EmSettings { threads: 2, ..settings.jrmpc.clone() },
        ..settings
    };
    let two = calib::calibrate(&rig, calib::Method::Gmm, &threaded, |_| Control::Continue)
        .expect("two threads");
    assert_eq!(format!("{two:?}"), expected);
}

/// `drive` reports the global stage as it begins and after each sensor aligned (two at a time
/// on two threads), before EM's iterations.
#[test]
fn driving_reports_the_global_stage_sensor_by_sensor() {
    let rig = opencalib_scene("0001");
    for (threads, expected) in [(1, vec![0, 1, 2]), (2, vec![0, 2])] {
        let mut run = calib::Run::new(Cow::Borrowed(&rig), &targetless(), &[calib::Method::Gmm]);
        let mut seen = Vec::new();
        run.drive(threads, &mut |_, p| {
            seen.push((p.stage, p.iteration, p.max_iterations));
            Control::Continue
        });
        let global: Vec<usize> =
            seen.iter().filter(|(s, _, _)| *s == Stage::Global).map(|&(_, i, _)| i).collect();
        assert_eq!(global, expected, "{threads} threads");
        assert!(seen.iter().take(global.len()).all(|&(s, _, n)| s == Stage::Global && n == 2));
        assert_ne!(seen[global.len()].0, Stage::Global);
        assert!(run.into_outcomes()[0].1.is_ok());
    }
}

/// The moving car's sweeps from a tape-measure nominal (the study's seed 5, start 0). The global
/// stage's best overlay lies in the right basin, but on a ground its own RANSAC draw found 2 deg
/// off, so it scores no better than the nominal (155 deg away) until levelled. Every root is
/// levelled before the selection judges it: the run starts from that candidate and lands.
#[test]
fn a_global_candidate_is_judged_as_its_levelling_leaves_it() {
    let model = Model::by_name("moving").expect("the zoo's moving car");
    let draw = Miscalibration {
        angle: [45.0 * D, 45.0 * D, 180.0 * D],
        translation: [1.0; 3],
        seed: Some(5000),
    };
    let twin = Twin::new(&model, 5, 5, &draw);
    let settings = calib::Settings { target: model.target(), ..Default::default() };
    let result =
        calib::calibrate(&twin.rig(), calib::Method::Gmm, &settings, |_| Control::Continue)
            .expect("calibration");
    let errors = eval::sensor_errors(&twin, &result);
    let error = errors[0].as_ref().expect("the bumper's result").error;
    let (deg, m) = (error.rotation.angle() / D, error.translation.vector.norm());
    assert!(deg < 0.1 && m < 0.01, "{deg:.3} deg {:.1} mm", m * 1e3);
    assert_eq!(result.verdict.level, Level::Good, "{:?}", result.verdict);
    // The run's start: the levelled global candidate, where the roots' own scores kept the
    // nominal.
    let selection = &result.selection[0];
    let hypotheses = &selection.hypotheses;
    let nominal = hypotheses[0].score.value();
    let levelled_candidate = hypotheses.iter().find(|h| {
        h.source == Source::Levelled
            && h.parent.is_some_and(|p| hypotheses[p].source == Source::Global { rank: 0 })
    });
    let levelled_candidate = levelled_candidate.expect("global #1 levelled");
    let global = hypotheses.iter().find(|h| h.source == Source::Global { rank: 0 }).unwrap();
    assert!(
        levelled_candidate.score.value() > nominal + 0.1 && global.score.value() < nominal + 0.02,
        "nominal {nominal:.3}, global #1 {:.3}, levelled {:.3}",
        global.score.value(),
        levelled_candidate.score.value()
    );
}

/// The `mid100` study's trial `start` of `seed` (the study's draw), calibrated with
/// `runners_up` global candidates besides the best: the result, and the `left` unit's error.
fn mid100_left(seed: u64, start: u64, runners_up: usize) -> (calib::Calibration, Pose) {
    let model = Model::by_name("mid100").expect("the zoo's Mid-100");
    let draw = Miscalibration {
        angle: [45.0 * D, 45.0 * D, 180.0 * D],
        translation: [1.0; 3],
        seed: Some(1000 * seed + start),
    };
    let twin = Twin::new(&model, 5, seed, &draw);
    let mut settings = calib::Settings { target: model.target(), ..Default::default() };
    settings.global.correlate.runners_up = runners_up;
    let result =
        calib::calibrate(&twin.rig(), calib::Method::Gmm, &settings, |_| Control::Continue)
            .expect("calibration");
    let errors = eval::sensor_errors(&twin, &result);
    // The errors skip the reference, the twin's first sensor.
    let k = twin.truth.iter().position(|(name, _)| name == "left").expect("left") - 1;
    let error = errors[k].as_ref().expect("the left unit's result").error;
    (result, error)
}

/// A Mid-100's `left` unit from a tape-measure nominal (the `mid100` study's seed 1, start 0):
/// it shares a strip about 8 deg wide with the middle unit. The global stage's best overlays
/// turn it 90-125 deg so that its view piles onto the middle unit's: more of it lands (13-18 %
/// of the points against 3 % at the truth), and more stands where the middle unit saw through.
/// Weighed three times, the free space puts the right placement first. The refinement slides
/// 2-3 cm along the strip (the plane adjustment's move back is beyond its limit): the result is
/// in the right basin and must not read `failed`.
#[test]
fn a_narrow_unit_is_placed_by_what_its_overlap_shows() {
    // Nine overlays, the default: with five the right one is not among them (`CorrelateSettings`).
    let runners_up = gmmcalib::calib::correlate::CorrelateSettings::default().runners_up;
    assert_eq!(runners_up, 8);
    let (result, error) = mid100_left(1, 0, runners_up);
    let (deg, m) = (error.rotation.angle() / D, error.translation.vector.norm());
    assert!(deg < 0.5 && m < 0.05, "{deg:.3} deg {:.1} mm", m * 1e3);
    let verdict = result.verdict.sensors.iter().find(|v| v.sensor == "left").unwrap();
    assert_ne!(verdict.level, Level::Failed, "{:?}", verdict.reasons);
    if deg > 0.1 || m > 0.01 {
        assert_ne!(verdict.level, Level::Good, "{deg:.3} deg {:.1} mm", m * 1e3);
    }
    let selection = result.selection.iter().find(|s| s.sensor == "left").expect("left");
    let chosen = &selection.hypotheses[selection.chosen];
    // A global overlay that lands far more of the unit, and scores below it by its free space.
    let piled = selection.hypotheses.iter().find(|h| {
        matches!(h.source, Source::Global { .. })
            && h.score.landing() > chosen.score.landing() + 0.1
            && h.score.value() < chosen.score.value()
    });
    assert!(piled.is_some(), "{:?}", selection.hypotheses.iter().map(|h| h.score.value()));
}

/// The same rig's trial (seed 4, start 1) with the global stage's first five candidates only:
/// none in the right basin, and the best placement within a tape measure's reach of the nominal
/// is 18 deg / 0.6 m off. It scores above the nominal, but below zero: more of it stands where
/// the middle unit saw through (three times weighed) than lands on its surfaces. The verdict
/// must say `failed`, naming that.
#[test]
fn a_placement_the_free_space_contradicts_is_failed() {
    use gmmcalib::calib::verdict::ReasonKind;
    let (result, error) = mid100_left(4, 1, 4);
    assert!(error.rotation.angle() / D > 1.0, "the five candidates hold the right one now");
    let verdict = result.verdict.sensors.iter().find(|v| v.sensor == "left").unwrap();
    assert_eq!(verdict.level, Level::Failed, "{:?}", verdict.reasons);
    let contradicted = verdict.reasons.iter().find_map(|r| match r.kind {
        ReasonKind::Contradicted { landing, contradiction } => Some((landing, contradiction)),
        _ => None,
    });
    let (landing, contradiction) = contradicted.expect("the free space named");
    assert!(3.0 * contradiction > landing, "{landing} {contradiction}");
}
