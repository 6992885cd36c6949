//! A twin in GMMCalib's layout: one folder `sensor_N` per sensor (1-based, in the preset's
//! order; `calibrate` names sensors by folder), and each nominal as exactly the pose
//! `config.yaml`'s six numbers give back. Shared by `simulate` (which writes it) and
//! `experiment` (which calibrates it in memory exactly as `calibrate` would read it back).

use gmmcalib::calib::{Rig, Scan};
use gmmcalib::cloud::is_valid_point;
use gmmcalib::se3::{pose_from_xyz_rpy, xyz_rpy};
use gmmcalib::twin::{self, Miscalibration, Model, Twin};

use crate::args::TwinArgs;

pub struct TwinFiles {
    pub model: Model,
    /// The twin, its nominals as read back from `config.yaml`.
    pub twin: Twin,
    /// `sensor_N` per sensor, in the twin's order.
    pub folders: Vec<String>,
    /// Each nominal's xyz (m) and rpy (rad), the numbers `config.yaml` holds.
    pub nominal_numbers: Vec<([f64; 3], [f64; 3])>,
}

/// The model named by `--preset`.
pub fn model(name: &str) -> Result<Model, String> {
    Model::by_name(name)
        .ok_or_else(|| format!("unknown preset '{name}' (expected {})", twin::PRESETS.join(", ")))
}

/// The seed that draws the nominals of the study's start `start` of scan seed `seed`, so that
/// `simulate --seed S --start K` writes out the study's trial.
pub fn start_seed(seed: u64, start: u64) -> u64 {
    seed * 1000 + start
}

impl TwinFiles {
    /// The twin of `args` with the scans of `seed` (the twin's seed rule).
    pub fn new(args: &TwinArgs, seed: u64) -> Result<Self, String> {
        let mut model = model(&args.preset)?;
        for (sensor, [roll, pitch, yaw, x, y, z]) in &args.moves {
            let Model::RayCast(preset) = &mut model else {
                return Err(format!("--move needs a ray-cast preset, not {}", args.preset));
            };
            // Named as `calibrate` names it: sensor_N, 1-based.
            let n = preset.sensors.len();
            let spec = sensor
                .strip_prefix("sensor_")
                .and_then(|n| n.parse::<usize>().ok())
                .and_then(|n| preset.sensors.get_mut(n.wrapping_sub(1)))
                .ok_or_else(|| format!("--move {sensor}: expected sensor_1 .. sensor_{n}"))?;
            let delta = pose_from_xyz_rpy([*x, *y, *z], [roll, pitch, yaw].map(|a| a.to_radians()));
            spec.mount *= delta;
        }
        let angle = args.max_angle_deg.to_radians();
        let yaw = args.max_yaw_deg.map_or(angle, f64::to_radians);
        let bounds = Miscalibration {
            angle: [angle, angle, yaw],
            seed: args.start.map(|k| start_seed(seed, k)),
            ..Miscalibration::within(angle, args.max_translation)
        };
        let mut twin = Twin::new(&model, args.frames, seed, &bounds);
        let nominal_numbers: Vec<_> = twin.nominal.iter().map(|(_, p)| xyz_rpy(p)).collect();
        for ((_, nominal), (xyz, rpy)) in twin.nominal.iter_mut().zip(&nominal_numbers) {
            *nominal = pose_from_xyz_rpy(*xyz, *rpy);
        }
        let folders = (1..=twin.truth.len()).map(|i| format!("sensor_{i}")).collect();
        Ok(Self { model, twin, folders, nominal_numbers })
    }

    /// Index of the sensor named `name` in the twin.
    pub fn sensor_of(&self, name: &str) -> usize {
        self.twin.truth.iter().position(|(n, _)| n == name).unwrap_or(0)
    }

    /// The rig `gmmcalib calibrate` reads from the written folder: scans sensor by sensor,
    /// named by folder, misses dropped; the nominals and the ROI.
    pub fn rig(&self) -> Rig {
        let mut scans = Vec::with_capacity(self.twin.scans.len());
        for (i, folder) in self.folders.iter().enumerate() {
            let own = self.twin.scans.iter().filter(|s| self.sensor_of(&s.sensor) == i);
            scans.extend(own.map(|s| Scan {
                sensor: folder.clone(),
                frame: s.frame.clone(),
                points: s.cloud.points.iter().copied().filter(is_valid_point).collect(),
                source: None,
            }));
        }
        let nominal = self.folders.iter().cloned().zip(self.twin.nominal.iter().map(|(_, p)| *p));
        let reference = self.folders.first().cloned();
        Rig { scans, nominal: nominal.collect(), roi: Some(self.twin.roi), reference }
    }
}
