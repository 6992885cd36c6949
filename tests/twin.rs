//! Accuracy on the digital twin (issue 6): the paper preset's three cubes on flat ground, the
//! non-reference sensors' nominals wrong by up to +-3 deg / +-0.1 m, calibrated by `gmm`.
//!
//! `TWIN_STUDY=seeds,starts[,max_deg,max_m[,method]]` with `--ignored` prints the distribution
//! that the README reports (more knobs in `study`, e.g. `TWIN_SENSORS=3`, `TWIN_FRAMES=7`);
//! the plain tests keep a few for CI.

mod common;

use std::f64::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

use gmmcalib::calib::{self, Method, Precision, Rig, View};
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::{Pose, pose_from_xyz_rpy};
use gmmcalib::sim::{Preset, SensorSpec, expected_correction, miscalibrate};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use common::{for_seeds, median};

/// Time spent in `calibrate` over a study (µs).
static CALIBRATION_MICROS: AtomicU64 = AtomicU64::new(0);
/// JRMPC iterations the studies' calibrations ran, summed.
static ITERATIONS: AtomicU64 = AtomicU64::new(0);
/// Levelling warnings (a bird's-eye search at the edge of its range) over a study.
static WARNINGS: AtomicU64 = AtomicU64::new(0);

/// What one non-reference sensor's calibration got wrong, and what it claimed.
struct SensorError {
    /// `C_est^-1 C_true` of its correction.
    error: Pose,
    /// Its rotation about the vehicle axes, `log(R_est R_true^T)` (rad), and position
    /// (estimate - truth, m).
    rotation: Vector3<f64>,
    position: Vector3<f64>,
    precision: Option<Precision>,
}

/// Per non-reference sensor.
type Errors = Vec<SensorError>;

/// Rotation (deg) and translation (m) of an error.
fn deg_m(d: &Pose) -> (f64, f64) {
    (d.rotation.angle().to_degrees(), d.translation.vector.norm())
}

/// One trial: `frames` scans of the preset (scene noise from `seed`), nominals drawn from
/// `(seed, start)`, calibrated with `settings`.
fn trial(
    preset: &Preset,
    frames: usize,
    seed: u64,
    start: u64,
    bounds: Bounds,
    settings: &calib::Settings,
) -> Errors {
    let views = preset.simulate(frames, seed);
    let mut rng = Pcg64::seed_from_u64(seed * 1000 + start);
    let nominal: Vec<(String, Pose)> = preset
        .sensors
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let pose = match i {
                0 => s.mount,
                _ if bounds.yaw == bounds.angle => {
                    miscalibrate(&s.mount, bounds.angle, bounds.translation, &mut rng)
                }
                // Yaw beyond the spec: the same convention as `miscalibrate`, per-axis bounds.
                _ => {
                    let limits = [bounds.angle, bounds.angle, bounds.yaw];
                    let rpy = limits.map(|a| rng.random_range(-a..=a));
                    let t = bounds.translation;
                    let xyz = [(); 3].map(|_| rng.random_range(-t..=t));
                    pose_from_xyz_rpy(xyz, rpy) * s.mount
                }
            };
            (s.name.clone(), pose)
        })
        .collect();
    let rig = Rig {
        views: views
            .into_iter()
            .map(|v| View { sensor: v.sensor, frame: v.frame, points: v.cloud.points })
            .collect(),
        nominal: nominal.clone(),
        roi: preset.roi,
        reference: None,
    };
    let clock = std::time::Instant::now();
    let result = calib::calibrate(&rig, settings, |_| Control::Continue).expect("calibration");
    CALIBRATION_MICROS.fetch_add(clock.elapsed().as_micros() as u64, Ordering::Relaxed);
    ITERATIONS.fetch_add(result.iterations as u64, Ordering::Relaxed);
    let warnings = result.levelling.iter().filter(|l| l.warning.is_some()).count();
    WARNINGS.fetch_add(warnings as u64, Ordering::Relaxed);
    if std::env::var("TWIN_HISTORY").is_ok_and(|n| n == "1") {
        // The first iteration whose largest change is below each level.
        let below = |level: f64| result.history.iter().position(|h| h.max_change <= level);
        let levels = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4].map(|l| format!("{l:.0e}: {:?}", below(l)));
        println!("seed {seed} start {start}: first below {}", levels.join(", "));
    }
    if std::env::var("TWIN_NOTES").is_ok_and(|n| n == "1") {
        for note in result.plane_adjustment.iter().chain(&result.kept_jrmpc) {
            println!("seed {seed} start {start}: {}: {}", note.sensor, note.reason);
        }
        for l in &result.levelling {
            if let Some(b) = &l.bev {
                let share = b.score / b.points as f64;
                println!("seed {seed} start {start}: {}: bird's-eye overlap {share:.3}", l.sensor);
            }
        }
    }
    preset.sensors[1..]
        .iter()
        .zip(&nominal[1..])
        .zip(&result.sensors[1..])
        .map(|((truth, (_, nominal)), estimate)| SensorError {
            error: estimate.correction.inverse() * expected_correction(&truth.mount, nominal),
            rotation: (estimate.extrinsic.rotation * truth.mount.rotation.inverse()).scaled_axis(),
            position: estimate.extrinsic.translation.vector - truth.mount.translation.vector,
            precision: estimate.precision,
        })
        .collect()
}

/// The paper preset plus a third sensor on the roof centre, pitched down 10 deg.
fn three_sensor_preset() -> Preset {
    let mut preset = Preset::paper();
    let lidar = preset.sensors[0].lidar.clone();
    preset.sensors.push(SensorSpec {
        name: "roof".into(),
        mount: gmmcalib::se3::pose_from_xyz_rpy([1.2, 0.0, 2.0], [0.0, 10f64.to_radians(), 0.0]),
        lidar,
    });
    preset
}

/// Miscalibration bounds per axis: roll and pitch, yaw (rad), translation (m).
#[derive(Clone, Copy)]
struct Bounds {
    angle: f64,
    yaw: f64,
    translation: f64,
}

fn spec_bounds() -> Bounds {
    Bounds { angle: 3.0 * PI / 180.0, yaw: 3.0 * PI / 180.0, translation: 0.1 }
}

/// Per axis (rotation about x, y, z; position x, y, z): the RMS error over `errors` against
/// the RMS of the one-sigma precision claimed, as lines of text and as ratios (error over
/// claim). Sensors without a claim are left out.
fn precision_check(errors: &[&SensorError]) -> (Vec<String>, [f64; 6]) {
    let claimed: Vec<(&SensorError, Precision)> =
        errors.iter().filter_map(|e| Some((*e, e.precision?))).collect();
    let n = claimed.len().max(1) as f64;
    let rms = |f: &dyn Fn(&(&SensorError, Precision)) -> f64| {
        (claimed.iter().map(|c| f(c).powi(2)).sum::<f64>() / n).sqrt()
    };
    let mut lines =
        vec![format!("precision claimed by {} of {} calibrations", claimed.len(), errors.len())];
    let mut ratios = [0.0; 6];
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let (error, claim) = (rms(&|c| c.0.rotation[i]), rms(&|c| c.1.rotation[i]));
        ratios[i] = error / claim;
        lines.push(format!(
            "rotation about {axis}: RMS error {:.4} deg, claimed {:.4} deg (ratio {:.2})",
            error.to_degrees(),
            claim.to_degrees(),
            ratios[i]
        ));
    }
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let (error, claim) = (rms(&|c| c.0.position[i]), rms(&|c| c.1.position[i]));
        ratios[3 + i] = error / claim;
        lines.push(format!(
            "position {axis}: RMS error {:.2} mm, claimed {:.2} mm (ratio {:.2})",
            error * 1e3,
            claim * 1e3,
            ratios[3 + i]
        ));
    }
    (lines, ratios)
}

fn summary(errors: &[f64]) -> String {
    let mut sorted = errors.to_vec();
    let med = median(&mut sorted);
    format!("median {med:.4}, max {:.4}", sorted.last().copied().unwrap_or(f64::NAN))
}

/// Seeds `1..=seeds` of the paper preset, one start each within the spec, 5 frames.
fn paper_trials(seeds: u64, settings: &calib::Settings) -> Vec<Errors> {
    let preset = Preset::paper();
    for_seeds(1..=seeds, |seed| trial(&preset, 5, seed, 0, spec_bounds(), settings))
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
/// 20 seeds x 5: 0.93 and 0.94; README, "How precise").
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
        views: views
            .into_iter()
            .map(|v| View { sensor: v.sensor, frame: v.frame, points: v.cloud.points })
            .collect(),
        nominal: vec![
            (preset.sensors[0].name.clone(), preset.sensors[0].mount),
            (preset.sensors[1].name.clone(), nominal),
        ],
        roi: preset.roi,
        reference: None,
    };
    (rig, nominal)
}

#[test]
fn levelling_puts_each_ground_on_the_reference_ground() {
    let truth = Preset::paper().sensors[1].mount;
    // Pitch and roll errors large enough to move the ground 10 m ahead by half a metre.
    let error = gmmcalib::se3::pose_from_xyz_rpy([0.05, -0.08, 0.1], [0.04, -0.05, 0.03]);
    let (rig, nominal) = rig_with_error(2, 7, error);
    let settings = calib::Settings {
        method: Method::Jrmpc,
        level_ground: Some(true),
        bev: None,
        ..Default::default()
    };
    let result = calib::calibrate(&rig, &settings, |_| Control::Continue).unwrap();
    let [reference, other] = &result.levelling[..] else { panic!("{:?}", result.levelling) };
    assert_eq!(reference.applied, Pose::identity());
    let ground = reference.ground.expect("reference ground");
    assert!((ground.normal - nalgebra::Vector3::z()).norm() < 1e-4, "{:?}", ground.normal);
    assert!(ground.offset.abs() < 1e-3, "{}", ground.offset);
    // What is left after levelling: no tilt, no height change under the ROI.
    let left = expected_correction(&truth, &nominal) * other.applied.inverse();
    let tilt = (left.rotation * nalgebra::Vector3::z()).angle(&nalgebra::Vector3::z());
    assert!(tilt.to_degrees() < 0.01, "tilt {} deg", tilt.to_degrees());
    let under_roi = nalgebra::Point3::new(12.25, 0.0, 0.0);
    let lift = (left * under_roi).z - under_roi.z;
    assert!(lift.abs() < 1e-3, "lift {lift} m");
    assert!(other.note.is_none() && other.inliers > 1000, "{other:?}");
}

#[test]
fn bev_search_catches_a_yaw_beyond_jrmpc_reach() {
    let truth = Preset::paper().sensors[1].mount;
    // 8 deg of yaw moves the cubes 1.7 m sideways, past their 1.5 m spacing.
    let error = gmmcalib::se3::pose_from_xyz_rpy([0.25, -0.3, 0.05], [0.02, -0.03, 0.14]);
    let (rig, nominal) = rig_with_error(5, 3, error);
    let result =
        calib::calibrate(&rig, &calib::Settings::default(), |_| Control::Continue).unwrap();
    let bev = result.levelling[1].bev.expect("a bird's-eye alignment");
    println!("bev: {:.2} deg, shift {:?}", bev.yaw.to_degrees(), bev.shift);
    assert!((bev.yaw + 0.14).abs() < 1f64.to_radians(), "{bev:?}");
    assert!(bev.score > 1.5 * bev.score_unchanged, "{bev:?}");
    let (deg, m) =
        deg_m(&(result.sensors[1].correction.inverse() * expected_correction(&truth, &nominal)));
    println!("gmm after the search: {deg:.4} deg / {:.2} mm", m * 1e3);
    assert!(deg <= 0.1 && m <= 0.01, "{deg} deg, {m} m");
}

#[test]
#[ignore = "a study: TWIN_STUDY=seeds,starts[,max_deg,max_m[,method]] cargo test --test twin -- --ignored --nocapture"]
fn study() {
    let spec = std::env::var("TWIN_STUDY").unwrap_or_else(|_| "20,5".into());
    let parts: Vec<&str> = spec.split(',').collect();
    let number = |i: usize, default: f64| parts.get(i).map_or(default, |p| p.parse().unwrap());
    let (seeds, starts) = (number(0, 20.0) as u64, number(1, 5.0) as u64);
    let angle = number(2, 3.0).to_radians();
    let yaw = std::env::var("TWIN_YAW").map_or(angle, |y| y.parse::<f64>().unwrap().to_radians());
    let bounds = Bounds { angle, yaw, translation: number(3, 0.1) };
    let mut settings = calib::Settings::default();
    if let Some(method) = parts.get(4) {
        settings.method = method.parse::<Method>().unwrap();
    }
    // TWIN_REFINE=method,robust_scale_m,d1/d2/... (robust 0 = none), TWIN_LEVEL=0|1.
    if let Ok(refine) = std::env::var("TWIN_REFINE") {
        let r: Vec<&str> = refine.split(',').collect();
        settings.refine.method = r[0].parse().unwrap();
        let robust: f64 = r[1].parse().unwrap();
        settings.refine.icp.robust_scale = (robust > 0.0).then_some(robust);
        settings.refine.match_distances = r[2].split('/').map(|d| d.parse().unwrap()).collect();
    }
    if let Ok(tolerance) = std::env::var("TWIN_EARLY_TOLERANCE") {
        settings.refine.early_tolerance = Some(tolerance.parse().unwrap()); // rad and m
    }
    if let Ok(tolerance) = std::env::var("TWIN_REFINE_TOLERANCE") {
        let tolerance: f64 = tolerance.parse().unwrap(); // rad and m
        settings.refine.icp.rotation_tolerance = tolerance;
        settings.refine.icp.translation_tolerance = tolerance;
    }
    if let Ok(k) = std::env::var("TWIN_NEIGHBOURS") {
        settings.refine.icp.neighbours = k.parse().unwrap();
    }
    if let Ok(d) = std::env::var("TWIN_DEPARTURE_DEG") {
        let deg: f64 = d.parse().unwrap();
        settings.refine.max_departure = (deg.to_radians(), deg / 10.0);
    }
    if let Ok(k) = std::env::var("TWIN_COMPONENTS") {
        settings.components = k.parse().unwrap();
    }
    if std::env::var("TWIN_BEV").is_ok_and(|b| b == "0") {
        settings.bev = None;
    }
    // TWIN_PLANES=0: no plane adjustment after the refinement; or
    // TWIN_PLANES=edge_m,assign_m,robust_m,iterations.
    if let Ok(planes) = std::env::var("TWIN_PLANES") {
        if planes == "0" {
            settings.planes = None;
        } else if let Some(p) = settings.planes.as_mut() {
            let v: Vec<f64> = planes.split(',').map(|x| x.parse().unwrap()).collect();
            (p.edge_distance, p.assign_distance, p.robust_scale) = (v[0], v[1], v[2]);
            p.iterations = v[3] as usize;
        }
    }
    if let Ok(level) = std::env::var("TWIN_LEVEL") {
        settings.level_ground = Some(level == "1");
    }
    if let Ok(iterations) = std::env::var("TWIN_ITERATIONS") {
        settings.jrmpc.max_iterations = iterations.parse().unwrap();
    }
    if let Ok(tolerance) = std::env::var("TWIN_TOLERANCE") {
        settings.jrmpc.tolerance = tolerance.parse().unwrap(); // rad and m per iteration
    }
    let three = std::env::var("TWIN_SENSORS").is_ok_and(|s| s == "3");
    let mut preset = if three { three_sensor_preset() } else { Preset::paper() };
    if let Ok(columns) = std::env::var("TWIN_COLUMNS") {
        preset.sensors.iter_mut().for_each(|s| s.lidar.horizontal_steps = columns.parse().unwrap());
    }
    if let Ok(z) = std::env::var("TWIN_ROI_ZMIN") {
        preset.roi.min[2] = z.parse().unwrap();
    }
    if let Ok(noise) = std::env::var("TWIN_NOISE") {
        preset.sensors.iter_mut().for_each(|s| s.lidar.range_noise = noise.parse().unwrap());
    }
    let frames = std::env::var("TWIN_FRAMES").map_or(5, |f| f.parse().unwrap());
    let jobs: Vec<(u64, u64)> =
        (1..=seeds).flat_map(|s| (0..starts).map(move |k| (s, k))).collect();
    let results = for_seeds(0..=(jobs.len() as u64 - 1), |j| {
        let (seed, start) = jobs[j as usize];
        trial(&preset, frames, seed, start, bounds, &settings)
    });
    let errors: Vec<&SensorError> = results.iter().flatten().collect();
    for line in precision_check(&errors).0 {
        println!("{line}");
    }
    // Per error: |roll, pitch, yaw| (deg) and |x, y, z| (mm).
    let axes: Vec<[f64; 6]> = results
        .iter()
        .flatten()
        .map(|e| &e.error)
        .map(|d| {
            let (xyz, rpy) = gmmcalib::se3::xyz_rpy(d);
            [0, 1, 2, 3, 4, 5]
                .map(|i| if i < 3 { rpy[i].to_degrees().abs() } else { xyz[i - 3].abs() * 1e3 })
        })
        .collect();
    let mean_axis = |i: usize| axes.iter().map(|a| a[i]).sum::<f64>() / axes.len() as f64;
    println!(
        "mean |roll pitch yaw| (deg) {:.4} {:.4} {:.4}, |x y z| (mm) {:.2} {:.2} {:.2}",
        mean_axis(0),
        mean_axis(1),
        mean_axis(2),
        mean_axis(3),
        mean_axis(4),
        mean_axis(5)
    );
    // Signed means: a bias shows here, seed noise averages out.
    let signed: Vec<[f64; 2]> = results
        .iter()
        .flatten()
        .map(|e| &e.error)
        .map(|d| {
            let (xyz, rpy) = gmmcalib::se3::xyz_rpy(d);
            [rpy[2].to_degrees(), xyz[1] * 1e3]
        })
        .collect();
    let n = signed.len() as f64;
    println!(
        "signed mean yaw {:.4} deg, y {:.2} mm",
        signed.iter().map(|s| s[0]).sum::<f64>() / n,
        signed.iter().map(|s| s[1]).sum::<f64>() / n
    );
    let all: Vec<(f64, f64)> = results.iter().flatten().map(|e| deg_m(&e.error)).collect();
    for ((seed, start), e) in jobs.iter().zip(&results) {
        let cells: Vec<String> = e
            .iter()
            .map(|e| deg_m(&e.error))
            .map(|(a, t)| format!("{a:.4} deg {:.2} mm", t * 1e3))
            .collect();
        println!("seed {seed} start {start}: {}", cells.join(" | "));
    }
    // Rotation errors (deg) and translation errors (mm), apart.
    let columns = |errors: &[(f64, f64)]| -> (Vec<f64>, Vec<f64>) {
        errors.iter().map(|(a, t)| (*a, t * 1e3)).unzip()
    };
    let (angles, shifts) = columns(&all);
    let good = all.iter().filter(|(a, t)| *a <= 0.1 && *t <= 0.01).count();
    println!("rotation (deg): {}", summary(&angles));
    println!("translation (mm): {}", summary(&shifts));
    println!("within 0.1 deg & 1 cm: {good} of {}", all.len());
    // With several non-reference sensors, each one's own distribution (issue 6 asks for every
    // sensor).
    let sensors = results.first().map_or(0, Vec::len);
    for s in (0..sensors).filter(|_| sensors > 1) {
        let own: Vec<(f64, f64)> = results.iter().map(|e| deg_m(&e[s].error)).collect();
        let (angles, shifts) = columns(&own);
        println!("sensor {}: {} deg, {} mm", s + 1, summary(&angles), summary(&shifts));
    }
    let seconds = CALIBRATION_MICROS.load(Ordering::Relaxed) as f64 * 1e-6;
    println!("calibration: {:.2} s each (trials run in parallel)", seconds / jobs.len() as f64);
    let iterations = ITERATIONS.load(Ordering::Relaxed) as f64;
    println!("JRMPC iterations: {:.1} each", iterations / jobs.len() as f64);
    println!("levelling warnings: {}", WARNINGS.load(Ordering::Relaxed));
}
