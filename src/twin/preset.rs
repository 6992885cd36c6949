//! The ray-cast presets of the digital twin (paper section V): sensors with their true mounts
//! and LiDAR models, the scene, the ROI, and simulation of organized scans.

use std::f64::consts::PI;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::OrganizedScan;
use super::lidar::Lidar;
use super::scene::{OrientedBox, Scene};
use crate::cloud::Aabb;
use crate::se3::{Pose, pose_from_xyz_rpy};

/// One simulated sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorSpec {
    pub name: String,
    /// True `T_vehicle_sensor`.
    pub mount: Pose,
    pub lidar: Lidar,
}

/// A complete twin: sensors, scene (vehicle frame, ground at z = 0), and the ROI (vehicle
/// frame, m) around the calibration cubes.
#[derive(Clone, Debug, PartialEq)]
pub struct Preset {
    pub sensors: Vec<SensorSpec>,
    pub scene: Scene,
    pub roi: Aabb,
    /// Index into `scene.boxes` of the validation cube, if any; every other box is a target.
    pub validation_box: Option<usize>,
    /// When set, the targets move between frames (as GMMCalib's cube is carried around):
    /// each frame shifts every target by up to this much (m) along x and y and turns it by up
    /// to 30 deg, drawn from a stream of its own. `None`: a static scene.
    pub target_motion: Option<f64>,
}

/// Edge of the calibration and validation cubes (m).
const CUBE_EDGE: f64 = 0.5;
/// The stream the targets' motion between frames draws from.
const MOTION_STREAM: u64 = u64::MAX - 1;

impl Preset {
    /// The paper's simulated rig: two LiDARs front-left and front-right (EDGAR-like, x 2.3 m,
    /// y +-0.6 m, z 1.6 m, rolled 20 deg towards the centre line), 50 channels over -20..+5 deg,
    /// 2048 columns, 50 m range, 1 cm range noise.
    pub fn paper() -> Self {
        let d = PI / 180.0;
        Self::with_lidar(Lidar::uniform(50, -20.0 * d, 5.0 * d, 2048, 50.0, 0.01))
    }

    /// The same scene and mounts seen by an Ouster OS1-128-like sensor: 128 channels over
    /// -22.5..+22.5 deg, 2048 columns, 120 m range, 1 cm range noise.
    pub fn os1_128() -> Self {
        let d = PI / 180.0;
        Self::with_lidar(Lidar::uniform(128, -22.5 * d, 22.5 * d, 2048, 120.0, 0.01))
    }

    /// The paper's rig plus a third sensor on the roof centre, pitched down 10 deg.
    pub fn paper_roof() -> Self {
        let mut preset = Self::paper();
        let lidar = preset.sensors[0].lidar.clone();
        preset.sensors.push(SensorSpec {
            name: "roof".into(),
            mount: pose_from_xyz_rpy([1.2, 0.0, 2.0], [0.0, 10f64.to_radians(), 0.0]),
            lidar,
        });
        preset
    }

    /// Two mounts and the cube scene around one sensor model.
    fn with_lidar(lidar: Lidar) -> Self {
        let d = PI / 180.0;
        // A positive roll tips the sensor's left (+y) side up and its right side down, so the
        // left sensor (+y) rolls +20 deg and the right one -20 deg: both lean towards the centre.
        let sensor = |name: &str, y: f64, roll: f64| SensorSpec {
            name: name.to_string(),
            mount: pose_from_xyz_rpy([2.3, y, 1.6], [roll, 0.0, 0.0]),
            lidar: lidar.clone(),
        };
        let scene = Scene {
            ground: true,
            boxes: vec![
                OrientedBox::cube_on_ground(12.3, -1.5, CUBE_EDGE, 0.0),
                OrientedBox::cube_on_ground(12.3, 0.0, CUBE_EDGE, 20.0 * d),
                OrientedBox::cube_on_ground(12.3, 1.5, CUBE_EDGE, 40.0 * d),
                // Validation cube, 16 m ahead of the sensors; visible above the middle cube.
                OrientedBox::cube_on_ground(18.3, 0.0, CUBE_EDGE, 30.0 * d),
            ],
        };
        Self {
            sensors: vec![
                sensor("front_left", 0.6, 20.0 * d),
                sensor("front_right", -0.6, -20.0 * d),
            ],
            scene,
            roi: Aabb::new([11.0, -2.5, -0.5], [13.5, 2.5, 1.0]),
            validation_box: Some(3),
            target_motion: None,
        }
    }

    /// The calibration targets: every box except the validation cube.
    pub fn targets(&self) -> impl Iterator<Item = &OrientedBox> {
        self.scene
            .boxes
            .iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != self.validation_box)
            .map(|(_, b)| b)
    }

    /// `frames` scans per sensor of the static scene from the static vehicle (vehicle frame =
    /// world frame), each frame with fresh noise and dropout. Views are ordered frame by frame,
    /// sensor by sensor within a frame; frames are named "1", "2", ... Seeded: same seed, same
    /// views.
    pub fn simulate(&self, frames: usize, seed: u64) -> Vec<OrganizedScan> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut motion = Pcg64::seed_from_u64(super::derive_seed(seed, MOTION_STREAM));
        let mut views = Vec::with_capacity(frames * self.sensors.len());
        for frame in 1..=frames {
            let scene = self.scene_of_frame(&mut motion);
            for s in &self.sensors {
                views.push(OrganizedScan {
                    sensor: s.name.clone(),
                    frame: frame.to_string(),
                    cloud: s.lidar.scan(&scene, &s.mount, &mut rng),
                    width: s.lidar.width(),
                    height: s.lidar.height(),
                });
            }
        }
        views
    }

    /// The scene of the next frame: the targets moved when `target_motion` is set.
    fn scene_of_frame(&self, rng: &mut Pcg64) -> Scene {
        let Some(reach) = self.target_motion else { return self.scene.clone() };
        let mut scene = self.scene.clone();
        for (i, b) in scene.boxes.iter_mut().enumerate() {
            if Some(i) == self.validation_box {
                continue;
            }
            b.centre.x += rng.random_range(-reach..=reach);
            b.centre.y += rng.random_range(-reach..=reach);
            b.yaw += rng.random_range(-0.5..=0.5);
        }
        scene
    }
}
