//! One miscalibrated instance of the digital twin: the simulated scans plus, per sensor, its
//! data-folder name, true mount, miscalibrated nominal and the correction a calibration should
//! find. Shared by `simulate` (which writes it to disk) and `experiment` (which calibrates it in
//! memory exactly as `calibrate` would read it back).

use gmmcalib::calib::{Rig, View};
use gmmcalib::cloud::is_valid_point;
use gmmcalib::se3::{Pose, pose_from_xyz_rpy, xyz_rpy};
use gmmcalib::sim::{Preset, SimView, expected_correction, miscalibrate};
use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::args::TwinArgs;

pub struct Sensor {
    /// The preset's name (`front_left`).
    pub name: String,
    /// The data folder, `sensor_N` (1-based, preset order): the name calibration sees.
    pub folder: String,
    pub truth: Pose,
    pub nominal: Pose,
    /// The six numbers of config.yaml that give exactly `nominal`: xyz (m), rpy (rad).
    pub nominal_xyz_rpy: ([f64; 3], [f64; 3]),
    /// `truth * nominal^-1`.
    pub correction: Pose,
}

pub struct Twin {
    pub preset: Preset,
    pub sensors: Vec<Sensor>,
    /// Frame by frame, sensor by sensor within a frame (as [`Preset::simulate`] orders them).
    pub views: Vec<SimView>,
}

/// The presets by command-line name.
pub fn preset(name: &str) -> Result<Preset, String> {
    match name {
        "paper" => Ok(Preset::paper()),
        "os1-128" => Ok(Preset::os1_128()),
        _ => Err(format!("unknown preset '{name}' (expected paper or os1-128)")),
    }
}

/// SplitMix64 of `seed` and `index`: independent, reproducible seeds for trials and streams.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed.wrapping_add(index.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Twin {
    /// Scans seeded by `seed`; every sensor but the first (the reference, which keeps its true
    /// mount) gets a miscalibrated nominal from a stream derived from `seed`.
    pub fn new(args: &TwinArgs, seed: u64) -> Result<Self, String> {
        let preset = preset(&args.preset)?;
        let mut rng = Pcg64::seed_from_u64(derive_seed(seed, u64::MAX));
        let sensors = preset
            .sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let nominal = if i == 0 {
                    s.mount
                } else {
                    let angle = args.max_angle_deg.to_radians();
                    miscalibrate(&s.mount, angle, args.max_translation, &mut rng)
                };
                // The nominal exactly as config.yaml's six numbers give it back, so a
                // calibration from the files and one in memory see the same pose.
                let nominal_xyz_rpy = xyz_rpy(&nominal);
                let nominal = pose_from_xyz_rpy(nominal_xyz_rpy.0, nominal_xyz_rpy.1);
                Sensor {
                    name: s.name.clone(),
                    folder: format!("sensor_{}", i + 1),
                    truth: s.mount,
                    nominal,
                    nominal_xyz_rpy,
                    correction: expected_correction(&s.mount, &nominal),
                }
            })
            .collect();
        let views = preset.simulate(args.frames, seed);
        Ok(Self { preset, sensors, views })
    }

    /// Index into `sensors` of a view.
    pub fn sensor_of(&self, view: &SimView) -> usize {
        self.sensors.iter().position(|s| s.name == view.sensor).unwrap_or(0)
    }

    /// The rig `gmmcalib calibrate` reads from the written folder: views sensor by sensor,
    /// named by folder, misses dropped, the nominals and the preset's ROI.
    pub fn rig(&self) -> Rig {
        let mut views = Vec::with_capacity(self.views.len());
        for (i, sensor) in self.sensors.iter().enumerate() {
            for v in self.views.iter().filter(|v| self.sensor_of(v) == i) {
                views.push(View {
                    sensor: sensor.folder.clone(),
                    frame: v.frame.clone(),
                    points: v.cloud.points.iter().copied().filter(is_valid_point).collect(),
                });
            }
        }
        Rig {
            views,
            nominal: self.sensors.iter().map(|s| (s.folder.clone(), s.nominal)).collect(),
            roi: self.preset.roi,
            reference: None,
        }
    }
}
