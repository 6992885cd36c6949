//! Helpers shared by the integration tests: synthetic rigs through the calibration pipeline,
//! and the error of a result against the truth.

#![allow(dead_code)]

use gmmcalib::calib::{self, Calibration, Rig, Scan};
use gmmcalib::io::{opencalib, parse_cloud};
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::Pose;
use gmmcalib::twin::{Miscalibration, Model, Sampling, Twin};

/// A sampled rig: how many sensors, frames and points, the noise, the miscalibration's bounds
/// (rad, m per axis) and the seed (the twin's seed rule).
#[derive(Clone, Debug)]
pub struct RigSpec {
    pub sensors: usize,
    pub frames: usize,
    pub points_per_view: usize,
    pub noise: f64,
    pub partial: bool,
    pub max_rotation_error: f64,
    pub max_translation_error: f64,
    pub seed: u64,
}

impl Default for RigSpec {
    fn default() -> Self {
        let sampling = Sampling::default();
        Self {
            sensors: sampling.sensors,
            frames: 10,
            points_per_view: sampling.points_per_view,
            noise: sampling.noise,
            partial: sampling.partial,
            max_rotation_error: 3f64.to_radians(),
            max_translation_error: 0.1,
            seed: 1,
        }
    }
}

/// The sampled twin of `spec`.
pub fn generate(spec: &RigSpec) -> Twin {
    let sampling = Sampling {
        sensors: spec.sensors,
        points_per_view: spec.points_per_view,
        noise: spec.noise,
        partial: spec.partial,
        ..Sampling::default()
    };
    let bounds = Miscalibration::within(spec.max_rotation_error, spec.max_translation_error);
    Twin::new(&Model::Sampled(sampling), spec.frames, spec.seed, &bounds)
}

pub fn rig_of(twin: &Twin) -> Rig {
    twin.rig()
}

/// Rotation (deg) and translation (m) error of one sensor's corrected extrinsic.
pub fn extrinsic_error(result: &Calibration, truth: &Twin, i: usize) -> (f64, f64) {
    let est: &Pose = &result.sensors[i].extrinsic;
    let tru = &truth.truth[i].1;
    let d = est.inverse() * tru;
    (d.rotation.angle().to_degrees(), d.translation.vector.norm())
}

/// Worst error over the non-reference sensors.
pub fn worst_error(result: &Calibration, truth: &Twin) -> (f64, f64) {
    (1..truth.truth.len())
        .map(|i| extrinsic_error(result, truth, i))
        .fold((0.0, 0.0), |(a, t), (da, dt)| (f64::max(a, da), f64::max(t, dt)))
}

pub fn run(
    spec: &RigSpec,
    method: calib::Method,
    settings: &calib::Settings,
) -> (Calibration, Twin) {
    let truth = generate(spec);
    let result = calib::calibrate(&rig_of(&truth), method, settings, |_| Control::Continue)
        .expect("calibration");
    (result, truth)
}

/// Runs `f` for every seed on all cores (the accuracy tests sweep many seeds).
pub fn for_seeds<T: Send>(
    seeds: std::ops::RangeInclusive<u64>,
    f: impl Fn(u64) -> T + Sync,
) -> Vec<T> {
    let seeds: Vec<u64> = seeds.collect();
    let workers =
        std::thread::available_parallelism().map_or(1, |n| n.get()).min(seeds.len()).max(1);
    let mut results: Vec<(u64, T)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|w| {
                let (seeds, f) = (&seeds, &f);
                scope.spawn(move || {
                    seeds.iter().skip(w).step_by(workers).map(|&s| (s, f(s))).collect::<Vec<_>>()
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("seed worker panicked")).collect()
    });
    results.sort_by_key(|(s, _)| *s);
    results.into_iter().map(|(_, r)| r).collect()
}

/// The median: the middle value, or the mean of the two middle ones for an even count.
pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 { values[n / 2] } else { (values[n / 2 - 1] + values[n / 2]) / 2.0 }
}

/// A fresh, empty folder under the system temp dir, removed on drop.
pub struct TempDir(pub std::path::PathBuf);

impl TempDir {
    pub fn new(name: &str) -> Self {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let dir =
            std::env::temp_dir().join(format!("gmmcalib-{name}-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One OpenCalib scene as the CLI reads it: the scans named by `lidar_cloud_path.txt`, nominals
/// from `initial_extrinsic.txt`, no ROI (the overlap region).
pub fn opencalib_scene(scene: &str) -> Rig {
    let dir = format!("{}/tests/fixtures/opencalib/{scene}", env!("CARGO_MANIFEST_DIR"));
    let text = |name: &str| std::fs::read_to_string(format!("{dir}/{name}")).unwrap();
    let devices = opencalib::read_paths(&text("lidar_cloud_path.txt"), "paths").unwrap();
    let guess = opencalib::read_guess(&text("initial_extrinsic.txt"), "guess").unwrap();
    let scans = devices
        .iter()
        .map(|d| {
            let file = format!("{dir}/{}", d.path.rsplit('/').next().unwrap());
            let parsed = parse_cloud(&std::fs::read(&file).unwrap(), &file).unwrap();
            Scan {
                sensor: d.name.clone(),
                frame: "1".into(),
                points: parsed.cloud.points,
                source: None,
            }
        })
        .collect();
    let nominal = opencalib::nominals(&guess, &devices, "guess").unwrap();
    Rig { scans, nominal, roi: None, reference: Some(devices[0].name.clone()) }
}
