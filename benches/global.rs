//! The global stage's bench job (issue 19: at most 1 s per sensor in wasm), shared by the native
//! bench and its wasm build (`bench_global`, timed from JS): OpenCalib's road scene 0001 from
//! its own guess. The scans are compiled in, so the wasm build needs no file access.

use gmmcalib::calib::global::{self, GlobalSettings};
use gmmcalib::io::{opencalib, parse_cloud};
use gmmcalib::se3::Pose;

const PATHS: &str = include_str!("../tests/fixtures/opencalib/0001/lidar_cloud_path.txt");
const GUESS: &str = include_str!("../tests/fixtures/opencalib/0001/initial_extrinsic.txt");
const CLOUDS: [(&str, &[u8]); 3] = [
    ("top.pcd", include_bytes!("../tests/fixtures/opencalib/0001/top.pcd")),
    ("left.pcd", include_bytes!("../tests/fixtures/opencalib/0001/left.pcd")),
    ("right.pcd", include_bytes!("../tests/fixtures/opencalib/0001/right.pcd")),
];

/// The scene: each device's points (device order, the reference first) and nominal.
pub struct Scene {
    pub scans: Vec<Vec<[f32; 3]>>,
    pub nominals: Vec<Pose>,
}

pub fn scene() -> Scene {
    let devices = opencalib::read_paths(PATHS, "lidar_cloud_path.txt").expect("paths");
    let guess = opencalib::read_guess(GUESS, "initial_extrinsic.txt").expect("guess");
    let nominals =
        opencalib::nominals(&guess, &devices, "initial_extrinsic.txt").expect("nominals");
    let scans = devices
        .iter()
        .map(|d| {
            let name = d.path.rsplit('/').next().unwrap_or(&d.path);
            let (_, bytes) = CLOUDS.iter().find(|(n, _)| *n == name).expect("a scan per device");
            parse_cloud(bytes, name).expect("scan").cloud.points
        })
        .collect();
    Scene { scans, nominals: nominals.into_iter().map(|(_, pose)| pose).collect() }
}

/// The global stage on `scene`, reference device 0; returns the sensors it aligned.
pub fn run(scene: &Scene) -> usize {
    let seeds: Vec<u64> = (0..scene.scans.len() as u64).collect();
    let scans = scene.scans.clone();
    let aligned = global::align(scans, &scene.nominals, 0, &GlobalSettings::default(), &seeds);
    aligned.iter().filter(|a| a.overlay.is_some()).count()
}

/// The scene as a rig (one frame, the guess as the nominals, no ROI), for the calibration.
#[allow(dead_code)] // native only
pub fn rig(scene: &Scene) -> gmmcalib::calib::Rig {
    let names = ["top", "left", "right"];
    gmmcalib::calib::Rig {
        scans: scene
            .scans
            .iter()
            .zip(names)
            .map(|(points, name)| gmmcalib::calib::Scan {
                sensor: name.into(),
                frame: "1".into(),
                points: points.clone(),
                source: None,
            })
            .collect(),
        nominal: names.iter().map(|n| n.to_string()).zip(scene.nominals.clone()).collect(),
        roi: None,
        reference: Some("top".into()),
    }
}
