//! Accuracy on the digital twin: the paper preset's three cubes on flat ground, the
//! non-reference sensors' nominals wrong by up to +-3 deg / +-0.1 m, calibrated by `gmm`. A few
//! seeds for CI; `gmmcalib study` prints the full distributions (docs/accuracy.md).

use gmmcalib::calib::{self, Method, Rig, Scan};
use gmmcalib::eval::{self, SensorError};
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::Pose;
use gmmcalib::twin::{Miscalibration, Model, Preset, Twin, expected_correction};

use crate::common::for_seeds;

/// Rotation (deg) and translation (m) of an error.
fn deg_m(d: &Pose) -> (f64, f64) {
    (d.rotation.angle().to_degrees(), d.translation.vector.norm())
}

/// One trial: `frames` scans of the paper preset from `seed`, nominals drawn from `(seed,
/// start)` as `gmmcalib study` draws them, calibrated with `settings`.
fn trial(frames: usize, seed: u64, start: u64, settings: &calib::Settings) -> Vec<SensorError> {
    let draw = Miscalibration { seed: Some(seed * 1000 + start), ..Miscalibration::default() };
    let twin = Twin::new(&Model::RayCast(Preset::paper()), frames, seed, &draw);
    let result = calib::calibrate(&twin.rig(), calib::Method::Gmm, settings, |_| Control::Continue)
        .expect("calibration");
    eval::sensor_errors(&twin, &result).into_iter().map(|e| e.expect("a result")).collect()
}

/// Per axis (rotation about x, y, z; position x, y, z): the RMS error over `errors` over the
/// RMS of the one-sigma precision claimed, as lines of text and as ratios.
fn precision_check(errors: &[&SensorError]) -> (Vec<String>, [f64; 6]) {
    let (claimed, axes) = eval::precision_rms(errors.iter().copied());
    let ratios = axes.map(|(error, claim)| error / claim);
    let names = [
        "rotation about x",
        "rotation about y",
        "rotation about z",
        "position x",
        "position y",
        "position z",
    ];
    let mut lines =
        vec![format!("precision claimed by {claimed} of {} calibrations", errors.len())];
    lines.extend(names.iter().zip(ratios).map(|(n, r)| format!("{n}: ratio {r:.2}")));
    (lines, ratios)
}

/// Seeds `1..=seeds` of the paper preset, one start each within the spec, 5 frames.
fn paper_trials(seeds: u64, settings: &calib::Settings) -> Vec<Vec<SensorError>> {
    for_seeds(1..=seeds, |seed| trial(5, seed, 0, settings))
}

#[test]
fn gmm_on_the_twin_is_precise() {
    let errors = paper_trials(4, &calib::Settings::default());
    for (seed, e) in (1..).zip(&errors) {
        let (deg, m) = deg_m(&e[0].error);
        println!("seed {seed}: {deg:.4} deg / {:.2} mm", m * 1e3);
    }
    for (seed, e) in (1..).zip(&errors) {
        let (deg, m) = deg_m(&e[0].error);
        assert!(deg <= 0.1 && m <= 0.01, "seed {seed}: {deg} deg, {m} m");
    }
}

#[test]
fn plane_adjustment_removes_most_of_the_error() {
    let with = calib::Settings::default();
    let without = calib::Settings { planes: None, ..Default::default() };
    let mean_mm = |settings: &calib::Settings| {
        let mm: Vec<f64> =
            paper_trials(4, settings).iter().map(|e| deg_m(&e[0].error).1 * 1e3).collect();
        println!("{mm:.2?} mm");
        mm.iter().sum::<f64>() / mm.len() as f64
    };
    let (adjusted, refined) = (mean_mm(&with), mean_mm(&without));
    // Measured: 2.4 mm against 5.3 mm.
    assert!(adjusted < 0.6 * refined, "{adjusted} mm with, {refined} mm without");
}

/// The one-sigma precision `gmm` claims is the spread its errors have: the RMS error over
/// seeds is within a factor of two of the RMS claim on the axes the targets pin down least
/// (yaw, and the position across them). Measured on these 8 seeds: 0.76 and 0.77 (3 sensors,
/// 20 seeds x 5: 0.93 and 0.94; docs/accuracy.md, "How precise").
#[test]
fn the_claimed_precision_is_the_spread_of_the_errors() {
    let errors = paper_trials(8, &calib::Settings::default());
    let errors: Vec<&SensorError> = errors.iter().flatten().collect();
    let (lines, ratios) = precision_check(&errors);
    for line in lines {
        println!("{line}");
    }
    assert!(errors.iter().all(|e| e.precision.is_some()), "every sensor has a precision");
    let (yaw, y) = (ratios[2], ratios[4]);
    assert!((0.5..=2.0).contains(&yaw) && (0.5..=2.0).contains(&y), "ratios {yaw} {y}");
}

/// `frames` scans of the paper preset with the second sensor's nominal moved by `error`
/// (vehicle frame), and that nominal.
fn rig_with_error(frames: usize, seed: u64, error: Pose) -> (Rig, Pose) {
    let preset = Preset::paper();
    let views = preset.simulate(frames, seed);
    let nominal = error * preset.sensors[1].mount;
    let rig = Rig {
        scans: views
            .into_iter()
            .map(|v| Scan {
                sensor: v.sensor,
                frame: v.frame,
                points: v.cloud.points,
                source: None,
            })
            .collect(),
        nominal: vec![
            (preset.sensors[0].name.clone(), preset.sensors[0].mount),
            (preset.sensors[1].name.clone(), nominal),
        ],
        roi: Some(preset.roi),
        reference: Some(preset.sensors[0].name.clone()),
    };
    (rig, nominal)
}

#[test]
fn levelling_puts_each_ground_on_the_reference_ground() {
    let truth = Preset::paper().sensors[1].mount;
    // Pitch and roll errors large enough to move the ground 10 m ahead by half a metre.
    let error = gmmcalib::se3::pose_from_xyz_rpy([0.05, -0.08, 0.1], [0.04, -0.05, 0.03]);
    let (rig, nominal) = rig_with_error(2, 7, error);
    let settings = calib::Settings { level_ground: Some(true), bev: None, ..Default::default() };
    let result = calib::calibrate(&rig, Method::Jrmpc, &settings, |_| Control::Continue).unwrap();
    let [reference, other] = &result.levelling[..] else { panic!("{:?}", result.levelling) };
    assert_eq!(reference.motion, Pose::identity());
    let ground = reference.ground.expect("reference ground");
    assert!((ground.normal - nalgebra::Vector3::z()).norm() < 1e-4, "{:?}", ground.normal);
    assert!(ground.offset.abs() < 1e-3, "{}", ground.offset);
    // What is left after levelling: no tilt, no height change under the ROI.
    let left = expected_correction(&truth, &nominal) * other.motion.inverse();
    let tilt = (left.rotation * nalgebra::Vector3::z()).angle(&nalgebra::Vector3::z());
    assert!(tilt.to_degrees() < 0.01, "tilt {} deg", tilt.to_degrees());
    let under_roi = nalgebra::Point3::new(12.25, 0.0, 0.0);
    let lift = (left * under_roi).z - under_roi.z;
    assert!(lift.abs() < 1e-3, "lift {lift} m");
    assert!(other.skipped.is_none() && other.inliers > 1000, "{other:?}");
}

#[test]
fn bev_search_catches_a_yaw_beyond_jrmpc_reach() {
    let truth = Preset::paper().sensors[1].mount;
    // 8 deg of yaw moves the cubes 1.7 m sideways, past their 1.5 m spacing.
    let error = gmmcalib::se3::pose_from_xyz_rpy([0.25, -0.3, 0.05], [0.02, -0.03, 0.14]);
    let (rig, nominal) = rig_with_error(5, 3, error);
    // The local search on its own: with the global stage (gmm's default) the yaw is gone
    // before the bird's-eye search starts.
    let local = calib::Settings { align_globally: Some(false), ..Default::default() };
    let result = calib::calibrate(&rig, calib::Method::Gmm, &local, |_| Control::Continue).unwrap();
    let bev = result.levelling[1].bev.expect("a bird's-eye alignment");
    println!("bev: {:.2} deg, shift {:?}", bev.yaw.to_degrees(), bev.shift);
    assert!((bev.yaw + 0.14).abs() < 1f64.to_radians(), "{bev:?}");
    assert!(bev.score > 1.5 * bev.score_unchanged, "{bev:?}");
    let (deg, m) =
        deg_m(&(result.sensors[1].correction.inverse() * expected_correction(&truth, &nominal)));
    println!("gmm after the search: {deg:.4} deg / {:.2} mm", m * 1e3);
    assert!(deg <= 0.1 && m <= 0.01, "{deg} deg, {m} m");
}
