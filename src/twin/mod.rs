//! The digital twin: rigs with known truth, in the shape a calibration takes. One simulator,
//! one preset table, one seed rule, so the same seed gives the same rig in the page, the CLI
//! and the tests.
//!
//! - [`Preset`]: the ray-cast presets (paper section V): a static scene of ground, boxes and
//!   meshes ([`MeshObject`]; [`shapes`] builds a chair and a board on a stand),
//!   LiDARs ([`Lidar`]: rotating, [`spinning`], or solid-state rosette scanners, [`rosette`],
//!   from a [`catalogue`] of real-sensor-like models) with exact ray intersection ([`scene`]),
//!   so occlusion, ring spacing, beam incidence and missing returns look like a real scan.
//!   The rig zoo ([`zoo`]) adds upside-down and sideways mounts, a Livox Mid-100, a
//!   five-LiDAR car, a moving car, and half-float coordinates ([`float16`]).
//! - [`Sampling`]: a cube sampled afresh for every view, for any number of sensors and points.
//! - [`Twin::new`]: a model's scans plus a nominal per sensor that is wrong by a seeded draw
//!   ([`Miscalibration`]), and the truth.
//!
//! The seed rule: the scans come from `seed`; the miscalibration from
//! `derive_seed(seed, MISCALIBRATION_STREAM)` unless a draw seed is given (a study draws
//! several starts for the same scans). Changing the bounds keeps the scans.

pub mod catalogue;
pub mod float16;
pub mod lidar;
mod mesh_object;
mod preset;
pub mod rosette;
mod sampled;
pub mod scene;
pub mod shapes;
pub mod spinning;
pub mod zoo;

use rand::{Rng, RngExt, SeedableRng};
use rand_pcg::Pcg64;

use crate::calib::{Rig, Scan};
use crate::cloud::{Aabb, Cloud, is_valid_point};
use crate::se3::{Pose, pose_from_xyz_rpy};

pub use lidar::Lidar;
pub use mesh_object::MeshObject;
pub use preset::{Preset, SensorSpec};
pub use rosette::Rosette;
pub use sampled::Sampling;
pub use scene::{OrientedBox, Scene};
pub use spinning::Spinning;

/// Default miscalibration bound per rotation axis (rad): 3 deg, as in the paper.
pub const MAX_MISCALIBRATION_ANGLE: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// Default miscalibration bound per translation axis (m).
pub const MAX_MISCALIBRATION_TRANSLATION: f64 = 0.1;
/// The stream of [`derive_seed`] the miscalibration draws from.
pub const MISCALIBRATION_STREAM: u64 = u64::MAX;

/// What makes a twin's scans.
#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    RayCast(Preset),
    Sampled(Sampling),
}

/// The presets by name: what the page's demo picker, `gmmcalib simulate --preset` and the
/// studies take. The last five are the rig zoo ([`zoo`]).
pub const PRESETS: [&str; 12] = [
    "paper",
    "paper-roof",
    "os1-128",
    "sampled",
    "paper-chair",
    "paper-board",
    "street",
    "stacked",
    "sideways",
    "mid100",
    "surround",
    "moving",
];

/// Shots per unit and frame of the `mid100` preset: 0.6 s of a Mid-40, enough to fill its
/// disc while a study stays quick (the real rig accumulates several seconds, ~330k a unit).
pub const MID100_POINTS: usize = 60_000;

impl Model {
    /// The preset named `name` (one of [`PRESETS`]).
    pub fn by_name(name: &str) -> Option<Model> {
        match name {
            "paper" => Some(Model::RayCast(Preset::paper())),
            "paper-roof" => Some(Model::RayCast(Preset::paper_roof())),
            "os1-128" => Some(Model::RayCast(Preset::os1_128())),
            "sampled" => Some(Model::Sampled(Sampling::default())),
            "paper-chair" => Some(Model::RayCast(Preset::paper_chair())),
            "paper-board" => Some(Model::RayCast(Preset::paper_board())),
            "street" => Some(Model::RayCast(Preset::street())),
            "stacked" => Some(Model::RayCast(Preset::stacked())),
            "sideways" => Some(Model::RayCast(Preset::sideways())),
            "mid100" => Some(Model::RayCast(Preset::mid100(MID100_POINTS))),
            "surround" => Some(Model::RayCast(Preset::surround())),
            "moving" => Some(Model::RayCast(Preset::moving())),
            _ => None,
        }
    }

    /// Sensor names and true `T_vehicle_sensor`, in order; the first is the reference.
    pub fn mounts(&self) -> Vec<(String, Pose)> {
        match self {
            Model::RayCast(p) => p.sensors.iter().map(|s| (s.name.clone(), s.mount)).collect(),
            Model::Sampled(s) => s.names().into_iter().zip(s.mounts()).collect(),
        }
    }

    /// The calibration target the scene holds: a 0.5 m cube, the mesh standing in the cubes'
    /// places (centred, as a file would give it), or none for a scene without one.
    pub fn target(&self) -> crate::targets::Target {
        use crate::targets::{MeshTarget, Target};
        match self {
            Model::RayCast(p) if p.targetless => Target::None,
            Model::RayCast(p) => match p.scene.meshes.first() {
                Some(m) => Target::Mesh(MeshTarget {
                    name: "twin target".into(),
                    mesh: std::sync::Arc::new(m.mesh().centred()),
                }),
                None => Target::default(),
            },
            Model::Sampled(_) => Target::default(),
        }
    }

    pub fn roi(&self) -> Aabb {
        match self {
            Model::RayCast(p) => p.roi,
            Model::Sampled(s) => s.roi(),
        }
    }

    /// `frames` scans per sensor, frame by frame, sensor by sensor within a frame; frames
    /// named "1", "2", ... Seeded.
    pub fn simulate(&self, frames: usize, seed: u64) -> Vec<OrganizedScan> {
        match self {
            Model::RayCast(p) => p.simulate(frames, seed),
            Model::Sampled(s) => s.simulate(frames, seed),
        }
    }
}

/// One simulated scan, labelled (sensor, frame) like real data, in the sensor's own frame. A
/// ray-cast cloud is organized (`width * height` points, row-major, one row per channel) with
/// misses as exact zeros; a sampled one is a single row.
#[derive(Clone, Debug, PartialEq)]
pub struct OrganizedScan {
    pub sensor: String,
    pub frame: String,
    pub cloud: Cloud,
    pub width: usize,
    pub height: usize,
}

/// How wrong the non-reference nominals are: each axis drawn uniformly within its bound, as a
/// mounting error is made: the sensor turned about itself (roll, pitch, yaw about the vehicle's
/// axes through the sensor) and its position off by the shift, as a tape measure errs. A turn
/// about the vehicle's origin would put a sensor 2.4 m from it up to 5 m away under a
/// half-turn: no tape measure errs so.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Miscalibration {
    /// Roll, pitch, yaw bounds (rad).
    pub angle: [f64; 3],
    /// x, y, z bounds (m).
    pub translation: [f64; 3],
    /// The draw's seed; `None`: the seed rule's (from the scans' seed).
    pub seed: Option<u64>,
}

impl Default for Miscalibration {
    /// The paper's: 3 deg and 0.1 m per axis.
    fn default() -> Self {
        Self::within(MAX_MISCALIBRATION_ANGLE, MAX_MISCALIBRATION_TRANSLATION)
    }
}

impl Miscalibration {
    /// The same bound on every rotation axis (rad) and every translation axis (m).
    pub fn within(angle: f64, translation: f64) -> Self {
        Self { angle: [angle; 3], translation: [translation; 3], seed: None }
    }

    /// A wrong nominal for `truth`, drawn from `rng`: roll, pitch, yaw, then x, y, z.
    pub fn draw(&self, truth: &Pose, rng: &mut impl Rng) -> Pose {
        let rpy = self.angle.map(|a| rng.random_range(-a..=a));
        let xyz = self.translation.map(|t| rng.random_range(-t..=t));
        let turn = pose_from_xyz_rpy([0.0; 3], rpy).rotation;
        let at = truth.translation.vector + nalgebra::Vector3::from(xyz);
        Pose::from_parts(at.into(), turn * truth.rotation)
    }
}

/// A rig with known truth: every scan, and per sensor its (wrong) nominal and true
/// `T_vehicle_sensor`; the first sensor is the reference and keeps its true mount.
#[derive(Clone, Debug)]
pub struct Twin {
    /// Frame by frame, sensor by sensor within a frame.
    pub scans: Vec<OrganizedScan>,
    pub nominal: Vec<(String, Pose)>,
    pub truth: Vec<(String, Pose)>,
    pub roi: Aabb,
}

impl Twin {
    /// `frames` scans of `model` from `seed`, the nominals wrong by `miscalibration` (the seed
    /// rule above).
    pub fn new(model: &Model, frames: usize, seed: u64, miscalibration: &Miscalibration) -> Self {
        let scans = model.simulate(frames, seed);
        let draw = miscalibration.seed.unwrap_or_else(|| derive_seed(seed, MISCALIBRATION_STREAM));
        let mut rng = Pcg64::seed_from_u64(draw);
        let truth = model.mounts();
        let nominal = truth
            .iter()
            .enumerate()
            .map(|(i, (name, mount))| {
                let pose = if i == 0 { *mount } else { miscalibration.draw(mount, &mut rng) };
                (name.clone(), pose)
            })
            .collect();
        Self { scans, nominal, truth, roi: model.roi() }
    }

    /// The rig a calibration takes: the scans with misses dropped, in order, the nominals, the
    /// ROI; the first sensor is the reference.
    pub fn rig(&self) -> Rig {
        let scans = self
            .scans
            .iter()
            .map(|s| Scan {
                sensor: s.sensor.clone(),
                frame: s.frame.clone(),
                points: s.cloud.points.iter().copied().filter(is_valid_point).collect(),
                source: None,
            })
            .collect();
        // The twin's truth is relative to its first sensor, which keeps its true mount.
        let reference = self.nominal.first().map(|(name, _)| name.clone());
        Rig { scans, nominal: self.nominal.clone(), roi: Some(self.roi), reference }
    }

    /// The correction a calibration should find for sensor `i`: `truth * nominal^-1`.
    pub fn correction(&self, i: usize) -> Pose {
        expected_correction(&self.truth[i].1, &self.nominal[i].1)
    }
}

/// The correction a calibration should find: `truth * nominal^-1`, which maps points
/// pre-aligned with the nominal mount onto where the true mount puts them.
pub fn expected_correction(truth: &Pose, nominal: &Pose) -> Pose {
    truth * nominal.inverse()
}

/// SplitMix64 of `seed` and `index`: independent, reproducible seeds for trials and streams.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed.wrapping_add(index.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
