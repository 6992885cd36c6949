//! The ray-cast presets of the digital twin (paper section V): sensors with their true mounts
//! and LiDAR models, the scene, the ROI, and simulation of organized scans.

use std::f64::consts::PI;

use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::OrganizedScan;
use super::lidar::Lidar;
use super::mesh_object::MeshObject;
use super::scene::{OrientedBox, Scene};
use super::shapes;
use crate::cloud::Aabb;
use crate::mesh::Mesh;
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
/// frame, m) around the calibration targets (cubes or meshes; the whole scene when targetless).
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
    /// True when the boxes are scenery (buildings, poles, cars), not targets: a scene without a
    /// calibration target, whose [`Preset::targets`] is empty.
    pub targetless: bool,
    /// A moving vehicle: `T_world_vehicle` of each frame (cycled when there are more frames),
    /// every sensor of a frame scanning from that pose, as motion-compensated sweeps give it.
    /// The scene and the ROI stay in the world and vehicle frames. Empty: the vehicle stands
    /// still with its frame on the world's.
    pub drive: Vec<Pose>,
}

/// Edge of the calibration and validation cubes (m).
const CUBE_EDGE: f64 = 0.5;
/// Where the paper's three calibration cubes stand: x, y (m) and yaw (deg).
const TARGET_PLACES: [(f64, f64, f64); 3] =
    [(12.3, -1.5, 0.0), (12.3, 0.0, 20.0), (12.3, 1.5, 40.0)];
/// The stream the targets' motion between frames draws from.
const MOTION_STREAM: u64 = u64::MAX - 1;
/// The street's ROI: all of it (vehicle frame, m).
pub(super) const STREET_ROI: Aabb = Aabb { min: [-22.0, -22.0, -0.5], max: [22.0, 22.0, 8.5] };

/// The street of [`Preset::street`] (world frame, m): two building walls at different angles,
/// poles and parked cars spread over +-20 m around the origin.
pub(super) fn street_boxes() -> Vec<OrientedBox> {
    let wall = |x, y, yaw: f64, length, height| {
        OrientedBox::new([x, y, height / 2.0], yaw.to_radians(), [length, 0.5, height])
    };
    let pole = |x, y| OrientedBox::new([x, y, 2.5], 0.0, [0.2, 0.2, 5.0]);
    let car = |x, y, yaw: f64| OrientedBox::new([x, y, 0.75], yaw.to_radians(), [4.5, 1.8, 1.5]);
    // Walls not parallel, so together they fix both horizontal directions.
    vec![
        wall(6.0, 14.0, 8.0, 30.0, 8.0),
        wall(-2.0, -15.0, -35.0, 24.0, 6.0),
        pole(15.0, -5.0),
        pole(-10.0, 5.0),
        pole(8.0, 7.5),
        pole(19.0, 3.0),
        pole(-14.0, -7.0),
        car(11.0, -6.0, 3.0),
        car(-8.0, -4.0, 85.0),
        car(17.0, 8.0, -15.0),
        car(-15.0, 9.0, 20.0),
        car(3.0, 9.5, 0.0),
    ]
}

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
            boxes: TARGET_PLACES
                .iter()
                .map(|&(x, y, yaw)| OrientedBox::cube_on_ground(x, y, CUBE_EDGE, yaw * d))
                // Validation cube, 16 m ahead of the sensors; visible above the middle cube.
                .chain([OrientedBox::cube_on_ground(18.3, 0.0, CUBE_EDGE, 30.0 * d)])
                .collect(),
            meshes: Vec::new(),
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
            targetless: false,
            drive: Vec::new(),
        }
    }

    /// The paper's rig with a chair ([`shapes::chair`], GMMCalib's CAD-model target) in place of
    /// each calibration cube (same places and yaws, facing the sensors); the validation cube
    /// stays.
    pub fn paper_chair() -> Self {
        Self::paper_with(&shapes::chair(), 1.0)
    }

    /// The paper's rig with a board on a stand ([`shapes::board_on_stand`], 0.8 x 0.6 m, 1.2 m
    /// tall) in place of each calibration cube; the ROI reaches 1.4 m up to take the boards in.
    pub fn paper_board() -> Self {
        Self::paper_with(&shapes::board_on_stand(), 1.4)
    }

    /// [`Preset::paper`] with `target` standing at each cube's place, the ROI up to `top` (m).
    fn paper_with(target: &Mesh, top: f64) -> Self {
        let mut preset = Self::paper();
        let validation = preset.scene.boxes.swap_remove(3);
        preset.scene.boxes = vec![validation];
        preset.validation_box = Some(0);
        preset.scene.meshes = TARGET_PLACES
            .iter()
            .map(|&(x, y, yaw)| MeshObject::on_ground(target, x, y, yaw.to_radians()))
            .collect();
        preset.roi.max[2] = top;
        preset
    }

    /// A street without a calibration target, for targetless calibration with truth: a ground
    /// plane between two building walls at different angles, with poles and parked cars spread
    /// over +-20 m, seen by the paper's sensor model on a road vehicle's roof corners (1.9 m up,
    /// 0.7 m either side, yawed +-45 deg out and pitched 5 deg down, as road rigs mount them).
    /// The paper's mounts rolled +-20 deg towards cubes see opposite halves of such a street
    /// (one looks up where the other looks down) and are left to the cube scenes. The ROI is
    /// the whole street.
    pub fn street() -> Self {
        let mut preset = Self::paper();
        let d = PI / 180.0;
        for (sensor, side) in preset.sensors.iter_mut().zip([1.0, -1.0]) {
            sensor.mount =
                pose_from_xyz_rpy([1.0, 0.7 * side, 1.9], [0.0, 5.0 * d, 45.0 * d * side]);
        }
        preset.scene.boxes = street_boxes();
        preset.validation_box = None;
        preset.targetless = true;
        preset.roi = STREET_ROI;
        preset
    }

    /// The calibration boxes: every box except the validation cube; none when targetless.
    /// Mesh targets are `scene.meshes`.
    pub fn targets(&self) -> impl Iterator<Item = &OrientedBox> {
        self.scene
            .boxes
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.targetless && Some(*i) != self.validation_box)
            .map(|(_, b)| b)
    }

    /// `frames` scans per sensor of the scene from the vehicle (standing on the world's frame,
    /// or at each frame's pose of `drive`), each frame with fresh noise and dropout. Views are ordered frame by frame,
    /// sensor by sensor within a frame; frames are named "1", "2", ... Seeded: same seed, same
    /// views.
    pub fn simulate(&self, frames: usize, seed: u64) -> Vec<OrganizedScan> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut motion = Pcg64::seed_from_u64(super::derive_seed(seed, MOTION_STREAM));
        let mut views = Vec::with_capacity(frames * self.sensors.len());
        for frame in 0..frames {
            let scene = self.scene_of_frame(&mut motion);
            for s in &self.sensors {
                let pose = self.vehicle_pose(frame).map_or(s.mount, |v| v * s.mount);
                views.push(OrganizedScan {
                    sensor: s.name.clone(),
                    frame: (frame + 1).to_string(),
                    cloud: s.lidar.scan(&scene, &pose, frame, &mut rng),
                    width: s.lidar.width(),
                    height: s.lidar.height(),
                });
            }
        }
        views
    }

    /// `T_world_vehicle` of frame `frame` (0-based) of a moving vehicle; `None` when it stands
    /// still on the world's frame.
    pub fn vehicle_pose(&self, frame: usize) -> Option<Pose> {
        (!self.drive.is_empty()).then(|| self.drive[frame % self.drive.len()])
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
        // Meshes draw after the boxes, so presets without meshes move exactly as before.
        for m in &mut scene.meshes {
            let (dx, dy) = (rng.random_range(-reach..=reach), rng.random_range(-reach..=reach));
            let turn =
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng.random_range(-0.5..=0.5));
            m.pose.translation.vector += Vector3::new(dx, dy, 0.0);
            m.pose.rotation = turn * m.pose.rotation;
        }
        scene
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// Each sensor's hits of one frame, in the world frame.
    fn world_hits(preset: &Preset) -> Vec<Vec<Vector3<f64>>> {
        let views = preset.simulate(1, 1);
        preset
            .sensors
            .iter()
            .zip(&views)
            .map(|(s, view)| {
                let hits = view.cloud.points.iter().filter(|p| **p != [0.0; 3]);
                hits.map(|p| (s.mount * Point3::from(p.map(f64::from))).coords).collect()
            })
            .collect()
    }

    #[test]
    fn mesh_presets_put_points_on_every_target() {
        for preset in [Preset::paper_chair(), Preset::paper_board()] {
            assert_eq!(preset.targets().count(), 0, "the only box is the validation cube");
            assert_eq!(preset.scene.meshes.len(), 3);
            for (s, hits) in preset.sensors.iter().zip(world_hits(&preset)) {
                let in_roi: Vec<_> =
                    hits.iter().filter(|w| preset.roi.contains([w.x, w.y, w.z])).collect();
                // On a target: inside its bounds, above the ground's noise; else the ground.
                let on = |w: &Vector3<f64>, m: &MeshObject| w.z > 0.03 && m.contains(*w, 0.03);
                let per_target: Vec<usize> = (preset.scene.meshes.iter())
                    .map(|m| in_roi.iter().filter(|w| on(w, m)).count())
                    .collect();
                assert!(per_target.iter().all(|&n| n > 50), "{}: {per_target:?}", s.name);
                let stray = in_roi
                    .iter()
                    .filter(|w| !preset.scene.meshes.iter().any(|m| on(w, m)) && w.z.abs() > 0.05)
                    .count();
                assert_eq!(stray, 0, "{}: every ROI point is on a target or the ground", s.name);
            }
        }
    }

    #[test]
    fn street_has_no_target_but_walls_poles_and_cars() {
        let street = Preset::street();
        assert_eq!(street.targets().count(), 0);
        assert!(street.scene.meshes.is_empty() && street.validation_box.is_none());
        let hits = world_hits(&street);
        for (i, b) in street.scene.boxes.iter().enumerate() {
            let seen: usize = hits
                .iter()
                .map(|h| h.iter().filter(|w| w.z > 0.05 && b.contains(**w, 0.02)).count())
                .sum();
            assert!(seen > 20, "box {i} ({:?}) has {seen} points", b.size);
        }
        let ground: usize =
            hits.iter().map(|h| h.iter().filter(|w| w.z.abs() < 0.05).count()).sum();
        assert!(ground > 10_000, "ground {ground}");
        // The ROI holds every point off the ground (the ground runs on to the sensors' range).
        for w in hits.iter().flatten().filter(|w| w.z > 0.05) {
            assert!(street.roi.contains([w.x, w.y, w.z]), "{w:?} outside the ROI");
        }
    }
}
