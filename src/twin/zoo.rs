//! The rig zoo: presets that stand for the kinds of rig users bring, each with its truth.
//! Upside-down and sideways mounts, a Livox Mid-100's three rosette units, OpenCalib's
//! five-LiDAR Hesai car, a car driving through a street, half-float coordinates. All targetless:
//! the ROI is the whole scene.

use nalgebra::{Translation3, Unit, UnitQuaternion, Vector3};

use super::lidar::Lidar;
use super::preset::{Preset, STREET_ROI, SensorSpec, street_boxes};
use super::scene::{OrientedBox, Scene};
use crate::cloud::Aabb;
use crate::se3::{Pose, pose_from_xyz_rpy};

const D: f64 = std::f64::consts::PI / 180.0;

/// A sensor at `xyz` (m) turned by roll, pitch, yaw `rpy` (deg) on the vehicle.
fn sensor(name: &str, xyz: [f64; 3], rpy: [f64; 3], lidar: Lidar) -> SensorSpec {
    SensorSpec { name: name.into(), mount: pose_from_xyz_rpy(xyz, rpy.map(|a| a * D)), lidar }
}

/// `sensors` in a targetless scene of `boxes` on the ground, the ROI all of it.
fn targetless(sensors: Vec<SensorSpec>, boxes: Vec<OrientedBox>, roi: Aabb) -> Preset {
    Preset {
        sensors,
        scene: Scene { ground: true, boxes, meshes: Vec::new() },
        roi,
        validation_box: None,
        target_motion: None,
        targetless: true,
        drive: Vec::new(),
    }
}

impl Preset {
    /// Two Velodyne HDL-32E-like LiDARs stacked on a roof mast, as rigs do that want the road
    /// near the car and the buildings' upper floors at once: the upper one (the reference)
    /// upright 2.5 m up, the lower one 0.4 m below it mounted upside-down (roll 180 deg), so
    /// its 30 deg fan looks up. Both store float16 coordinates (as some drivers and recordings
    /// do; up to 1.6 cm off beyond 32 m). The street of [`Preset::street`].
    pub fn stacked() -> Self {
        let mut lidar = Lidar::hdl_32e();
        *lidar.float16_mut() = true;
        let sensors = vec![
            sensor("upper", [1.0, 0.0, 2.5], [0.0, 0.0, 0.0], lidar.clone()),
            sensor("lower", [1.0, 0.0, 2.1], [180.0, 0.0, 0.0], lidar),
        ];
        targetless(sensors, street_boxes(), STREET_ROI)
    }

    /// Mounts at odd angles on a car in the street of [`Preset::street`]: an Ouster OS1-64-like
    /// reference upright on the roof, an HDL-32E-like on the left flank lying on its side
    /// (roll 90 deg: it sweeps the vertical plane along the car, its wide lower fan facing
    /// out), and a VLP-16-like at the front of the roof pitched 50 deg down at the road ahead.
    pub fn sideways() -> Self {
        let sensors = vec![
            sensor("roof", [1.3, 0.0, 2.0], [0.0, 0.0, 0.0], Lidar::os1_64()),
            sensor("left_side", [1.8, 0.95, 1.1], [90.0, 0.0, 0.0], Lidar::hdl_32e()),
            sensor("front_down", [2.9, 0.0, 1.6], [0.0, 50.0, 0.0], Lidar::vlp_16()),
        ];
        targetless(sensors, street_boxes(), STREET_ROI)
    }

    /// A Livox Mid-100 (hku-mars/mlcc's rig): three Mid-40-like rosette units side by side,
    /// 9 cm apart on a 1.2 m tripod, yawed +30 (left), 0 (middle, the reference) and -30 deg
    /// (right), so neighbours overlap in a strip about 8 deg wide (a fifth of a unit's points),
    /// in a courtyard: walls, pillars, crates, a parked car. Each frame integrates `points`
    /// shots a unit, the pattern going on from the frame before.
    pub fn mid100(points: usize) -> Self {
        let unit = Lidar::mid_40(points);
        let sensors = vec![
            sensor("middle", [0.0, 0.0, 1.2], [0.0, 0.0, 0.0], unit.clone()),
            sensor("left", [0.0, 0.09, 1.2], [0.0, 0.0, 30.0], unit.clone()),
            sensor("right", [0.0, -0.09, 1.2], [0.0, 0.0, -30.0], unit),
        ];
        let roi = Aabb::new([-1.0, -22.0, -0.5], [26.0, 22.0, 9.0]);
        targetless(sensors, courtyard(), roi)
    }

    /// OpenCalib's Hesai car (its `hesai/scene1`): a Pandar64-like roof LiDAR (the reference)
    /// and four PandarQT-like short-range units at the bumpers' corners, 0.8-0.9 m up, yawed
    /// -120, 140, 120 and 25 deg as OpenCalib's guesses have them and leaning 10 deg out from
    /// the car (their real tilts are unknown; OpenCalib's guesses are 39-72 deg off). The
    /// street of [`Preset::street`].
    pub fn surround() -> Self {
        // The car's centre (m): each corner unit leans away from it.
        let centre = Vector3::new(1.45, 0.0, 0.0);
        let corner = |name: &str, xyz: [f64; 3], yaw: f64| {
            let out = (Vector3::new(xyz[0], xyz[1], 0.0) - centre).normalize();
            let lean = UnitQuaternion::from_axis_angle(
                &Unit::new_normalize(Vector3::z().cross(&out)),
                10.0 * D,
            );
            let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw * D);
            let mount = Pose::from_parts(Translation3::from(Vector3::from(xyz)), lean * turn);
            SensorSpec { name: name.into(), mount, lidar: Lidar::pandar_qt() }
        };
        let sensors = vec![
            sensor("p64", [1.3, 0.0, 2.0], [0.0, 0.0, 0.0], Lidar::pandar_64()),
            corner("rear_right", [-0.9, -0.9, 0.9], -120.0),
            corner("rear_left", [-0.9, 0.9, 0.9], 140.0),
            corner("front_right", [3.8, -0.9, 0.8], 120.0),
            corner("front_left", [3.8, 0.9, 0.8], 25.0),
        ];
        targetless(sensors, street_boxes(), STREET_ROI)
    }

    /// A car driving through the street of [`Preset::street`] (small_gicp's HDL-32E pair is
    /// such a rig): an HDL-32E-like on the roof (the reference) and a VLP-16-like on the front
    /// bumper. Each frame is a motion-compensated sweep from the next of eight poses 3 m apart
    /// along the street, the heading swinging up to 5 deg, both sensors at that pose: fixed
    /// extrinsics, a scene that moves between frames. The ROI is the whole street around the
    /// car (vehicle frame).
    pub fn moving() -> Self {
        let sensors = vec![
            sensor("roof", [1.2, 0.0, 2.0], [0.0, 0.0, 0.0], Lidar::hdl_32e()),
            sensor("bumper", [3.7, 0.0, 0.6], [0.0, 0.0, 0.0], Lidar::vlp_16()),
        ];
        let roi = Aabb::new([-30.0, -25.0, -0.5], [30.0, 25.0, 8.5]);
        let mut preset = targetless(sensors, street_boxes(), roi);
        let sideways = [0.0, 0.2, 0.5, 0.6, 0.5, 0.2, -0.1, -0.3];
        let heading = [0.0, 3.0, 5.0, 3.0, 0.0, -3.0, -5.0, -4.0];
        preset.drive = (0..8)
            .map(|k| {
                pose_from_xyz_rpy(
                    [-9.0 + 3.0 * k as f64, sideways[k], 0.0],
                    [0.0, 0.0, heading[k] * D],
                )
            })
            .collect();
        preset
    }
}

/// A courtyard ahead of a sensor at the origin looking along +x (m): a back wall 22 m out,
/// building faces either side at different angles, pillars and crates (some in the strips
/// where a Mid-100's units overlap, about +-15 deg), a parked car and a low platform.
fn courtyard() -> Vec<OrientedBox> {
    let wall = |x, y, yaw: f64, size| OrientedBox::new([x, y, 4.0], yaw * D, size);
    let pillar = |x, y| OrientedBox::new([x, y, 3.0], 0.0, [0.4, 0.4, 6.0]);
    let crate_ = |x, y, yaw: f64| OrientedBox::new([x, y, 0.6], yaw * D, [1.2, 1.2, 1.2]);
    vec![
        wall(22.0, 0.0, 5.0, [0.6, 40.0, 8.0]),
        wall(12.0, 14.0, -8.0, [30.0, 0.6, 8.0]),
        wall(12.0, -13.0, 12.0, [30.0, 0.6, 8.0]),
        pillar(9.0, 2.6),
        pillar(12.0, -3.4),
        pillar(6.5, 6.0),
        pillar(7.0, -6.5),
        crate_(5.5, 1.5, 20.0),
        crate_(8.0, -2.3, -10.0),
        crate_(14.0, 7.0, 30.0),
        crate_(15.0, -8.0, 15.0),
        crate_(10.0, 0.0, 40.0),
        OrientedBox::new([16.0, 3.0, 0.75], 70.0 * D, [4.5, 1.8, 1.5]),
        OrientedBox::new([18.0, -1.0, 0.25], 0.0, [3.0, 10.0, 0.5]),
    ]
}
