//! The run, the state machine every driver steps (threads natively, Web Workers in the page):
//! the stages it goes through and reports, the steps a driver may take elsewhere and record,
//! and what a cancel or a failure elsewhere does to the methods under way and after.

use std::borrow::Cow;

use crate::common::{RigSpec, generate, rig_of};
use gmmcalib::calib::{self, CalibError, Rig, Scan, Settings, Stage, Stages};
use gmmcalib::jrmpc::{Control, Shards};
use gmmcalib::twin::Preset;

/// Every method's run reports its stages in the order its plan gives (what the page shares its
/// progress bar by), each as it begins: the run's own steps (the views, the result) too.
#[test]
fn a_run_reports_the_stages_its_plan_names_in_order() {
    use gmmcalib::twin::{Miscalibration, Model, Preset, Twin};
    // A scene with a ground, so that `gmm`'s global stage has sensors to align.
    let twin = Twin::new(&Model::RayCast(Preset::paper_roof()), 1, 2, &Miscalibration::default());
    let rig = twin.rig();
    let sensors = rig.sensors().len();
    let settings = Settings::default();
    for name in ["gmm", "jrmpc", "gicp"] {
        let method = name.parse().unwrap();
        let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &[method]);
        let plan = run.plan(0);
        assert_eq!(plan, Stages::of(method, &settings).plan());
        let mut seen: Vec<Stage> = Vec::new();
        run.drive(1, &mut |_, p| {
            if seen.last() != Some(&p.stage) {
                seen.push(p.stage);
            }
            assert_eq!(p.corrections.len(), sensors, "{name}: a correction per sensor");
            Control::Continue
        });
        assert_eq!(seen, plan, "{name}");
        assert!(run.into_outcomes()[0].1.is_ok(), "{name}");
    }
    let gmm = Stages::of(calib::Method::Gmm, &settings).plan();
    assert_eq!(gmm, [Stage::Global, Stage::Views, Stage::Jrmpc, Stage::FramePairs, Stage::Finish]);
    let none = Settings { target: gmmcalib::targets::Target::None, ..Settings::default() };
    assert_eq!(
        Stages::of(calib::Method::Gmm, &none).plan(),
        [Stage::Global, Stage::Views, Stage::FramePairs, Stage::Finish],
        "gmm runs no JRMPC on a whole scene"
    );
}

/// Frame pairs registered elsewhere (the page's pool workers) and recorded in any order give
/// the calibration and the verdict `calibrate` gives.
#[test]
fn frame_pairs_recorded_in_any_order_calibrate_alike() {
    let spec = RigSpec { sensors: 3, frames: 4, seed: 6, ..RigSpec::default() };
    let rig = rig_of(&generate(&spec));
    let settings = Settings::default();
    let direct =
        calib::calibrate(&rig, gicp(), &settings, |_| Control::Continue).expect("calibration");

    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &[gicp()]);
    assert_eq!(run.stage(), Some(Stage::Views), "the run prepares the views first");
    run.advance();
    assert_eq!(run.stage(), Some(Stage::FramePairs), "gicp registers frame pairs");
    let clouds: Vec<Vec<[f32; 3]>> =
        run.views().expect("views").clouds().iter().map(|c| c.to_vec()).collect();
    let pairs = run.frame_pairs().expect("frame pairs");
    let jobs = pairs.pairs().to_vec();
    assert_eq!(jobs.len(), 8, "two sensors against the reference, four frames each");
    let icp = pairs.icp().clone();
    for (j, job) in jobs.iter().enumerate().rev() {
        let target = calib::fixed_cloud(&clouds[job.reference_view], &icp, false).expect("target");
        let pose = calib::align(&target, &clouds[job.view], &job.start, &icp);
        pairs.record(j, pose.map_err(|e| e.to_string()));
    }
    // A second outcome for a recorded pair, or one for no pair, changes nothing.
    pairs.record(0, Err("late".into()));
    pairs.record(99, Err("none".into()));
    assert_eq!(pairs.done(), jobs.len());
    run.advance();
    assert_eq!(run.stage(), Some(Stage::Finish), "then makes the result");
    run.advance();
    assert_eq!(run.stage(), None);
    let (_, recorded) = run.into_outcomes().pop().expect("one outcome");
    let recorded = recorded.expect("calibration");
    for (a, b) in direct.sensors.iter().zip(&recorded.sensors) {
        assert_eq!((a.name.as_str(), a.correction), (b.name.as_str(), b.correction));
    }
    assert_eq!(direct.skipped.len(), recorded.skipped.len());
    // The verdict's surfaces came from the frame pairs' targets there and were searched again
    // here: the same evidence, bit for bit.
    assert_eq!(direct.verdict, recorded.verdict);
}

/// A cancel while the global stage runs (here from its first progress) stops the next phase
/// at once, and no later method starts.
#[test]
fn a_run_cancelled_in_its_global_stage_stops_its_next_phase_at_once() {
    let preset = Preset::paper();
    let scans: Vec<Scan> = preset
        .simulate(2, 5)
        .into_iter()
        .map(|v| Scan { sensor: v.sensor, frame: v.frame, points: v.cloud.points, source: None })
        .collect();
    let nominal = preset.sensors.iter().map(|s| (s.name.clone(), s.mount)).collect();
    let reference = Some(preset.sensors[0].name.clone());
    let rig = Rig { scans, nominal, roi: Some(preset.roi), reference };
    let settings = calib::Settings::default();
    let methods = [calib::Method::Gmm, calib::Method::Jrmpc];
    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &methods);
    assert_eq!(run.stage(), Some(calib::Stage::Global));
    let mut seen = Vec::new();
    run.drive(1, &mut |_, p| {
        seen.push((p.stage, p.iteration));
        if p.stage == Stage::Global { Control::Stop } else { Control::Continue }
    });
    // The stop ends the stage (the other sensor is aligned as it ends) and EM, before its first
    // iteration; the frame pairs of the stopped method run, as after a stop in EM, between the
    // run's own steps (the views prepared, the result made).
    assert_eq!(seen[0], (Stage::Global, 0));
    assert_eq!(seen[1], (Stage::Views, 0));
    assert_eq!(seen.last(), Some(&(Stage::Finish, 0)));
    let between = &seen[2..seen.len() - 1];
    assert!(between.iter().all(|(s, _)| *s == Stage::FramePairs), "{seen:?}");
    let outcomes = run.into_outcomes();
    assert_eq!(outcomes.len(), 1, "no later method starts");
    if let (_, Ok(calibration)) = &outcomes[0] {
        assert!(calibration.cancelled && calibration.iterations == 0, "{calibration:?}");
    }
}

fn gicp() -> calib::Method {
    "gicp".parse().unwrap()
}

/// Steps `run` by hand, as a worker-pool driver does: the global stage's sensors one at a
/// time, EM's iterations on one shard, each frame pair in turn; `at` sees each stage as it
/// begins and may end the method there (`true`: `fail` it) instead.
fn step_by_hand(run: &mut calib::Run, at: &mut impl FnMut(usize, Stage) -> bool) {
    while let (Some((index, _)), Some(stage)) = (run.method(), run.stage()) {
        if at(index, stage) {
            run.fail(CalibError::StageFailed("the worker stopped".into()));
            continue;
        }
        match stage {
            Stage::Global => {
                while let Some(global) = run.global_stage() {
                    let pending = global.pending();
                    let Some(sensor) = pending.first() else { break };
                    global.align(&[*sensor], 1);
                }
            }
            Stage::Jrmpc => {
                let points = run.em_points().expect("EM's points").clone();
                let mut shards = Shards::new(points, 1);
                while let Some(em) = run.em().filter(|em| !em.finished()) {
                    shards.iterate(em);
                }
            }
            Stage::FramePairs => {
                let count = run.frame_pairs().map_or(0, |p| p.pairs().len());
                run.register_pairs(0..count, 1, &mut |_| Control::Continue);
            }
            Stage::Cad => run.register_cad(&mut |_| Control::Continue),
            Stage::Views | Stage::Finish => {}
        }
        run.advance();
    }
}

/// A run stepped by hand goes through each method's plan in order and ends with what
/// `calibrate` gives, bit for bit; once done, a further advance changes nothing.
#[test]
fn a_run_stepped_by_hand_follows_each_plan_and_calibrates_as_calibrate() {
    let spec = RigSpec { sensors: 3, frames: 2, seed: 4, ..RigSpec::default() };
    let rig = rig_of(&generate(&spec));
    let settings = Settings::default();
    let methods = [calib::Method::Jrmpc, gicp()];
    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &methods);
    let plans: Vec<Vec<Stage>> = (0..methods.len()).map(|i| run.plan(i)).collect();
    let mut seen: Vec<Vec<Stage>> = vec![Vec::new(); methods.len()];
    step_by_hand(&mut run, &mut |index, stage| {
        seen[index].push(stage);
        false
    });
    assert_eq!(seen, plans);
    run.advance();
    assert_eq!((run.stage(), run.method()), (None, None));
    let outcomes = run.into_outcomes();
    assert_eq!(outcomes.len(), methods.len());
    for ((method, outcome), expected) in outcomes.iter().zip(methods) {
        assert_eq!(*method, expected);
        let direct =
            calib::calibrate(&rig, expected, &settings, |_| Control::Continue).expect("calibrate");
        let stepped = outcome.as_ref().expect("calibration");
        for (a, b) in direct.sensors.iter().zip(&stepped.sensors) {
            assert_eq!((a.name.as_str(), a.correction), (b.name.as_str(), b.correction));
        }
    }
}

/// A method whose work failed elsewhere (a worker gone) ends with that error, and the next
/// method runs as if alone: a failure is no cancel.
#[test]
fn a_method_failed_elsewhere_ends_with_its_error_and_the_next_runs() {
    let spec = RigSpec { frames: 2, seed: 5, ..RigSpec::default() };
    let rig = rig_of(&generate(&spec));
    let settings = Settings::default();
    let methods = [calib::Method::Jrmpc, gicp()];
    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &methods);
    step_by_hand(&mut run, &mut |index, stage| index == 0 && stage == Stage::Jrmpc);
    let outcomes = run.into_outcomes();
    assert_eq!(outcomes.len(), 2);
    match &outcomes[0] {
        (calib::Method::Jrmpc, Err(CalibError::StageFailed(why))) => {
            assert_eq!(why, "the worker stopped")
        }
        other => panic!("{other:?}"),
    }
    let direct =
        calib::calibrate(&rig, gicp(), &settings, |_| Control::Continue).expect("calibrate");
    let (_, gicp) = &outcomes[1];
    let gicp = gicp.as_ref().expect("gicp calibrates");
    assert!(!gicp.cancelled);
    for (a, b) in direct.sensors.iter().zip(&gicp.sensors) {
        assert_eq!(a.correction, b.correction);
    }
}

/// A stop during EM ends EM after its current iteration; the method still makes its result
/// (marked cancelled), and no later method starts.
#[test]
fn a_run_stopped_in_em_makes_its_result_and_starts_no_other_method() {
    let spec = RigSpec { frames: 2, seed: 2, ..RigSpec::default() };
    let rig = rig_of(&generate(&spec));
    let settings = Settings::default();
    let methods = [calib::Method::Jrmpc, gicp()];
    let mut run = calib::Run::new(Cow::Borrowed(&rig), &settings, &methods);
    let mut iterations = 0;
    run.drive(1, &mut |_, p| {
        if p.stage == Stage::Jrmpc && p.iteration > 0 {
            iterations = p.iteration;
            return Control::Stop;
        }
        Control::Continue
    });
    assert_eq!(run.stage(), None);
    let outcomes = run.into_outcomes();
    assert_eq!(outcomes.len(), 1, "no later method starts");
    let calibration = outcomes[0].1.as_ref().expect("a result of what EM reached");
    assert!(calibration.cancelled);
    assert_eq!(calibration.iterations, iterations, "EM stops after the iteration it reported");
}
