//! Extrinsics in ROS's own terms. Each export takes `(parent, child, T_parent_child)`: the
//! pose maps points from `child` into `parent` (a tf edge, a URDF joint origin), as every
//! format below means it. Numbers are printed with Rust's shortest round-trip form, so parsing
//! them back gives the same f64.

use crate::se3::{Pose, to_row_major, xyz_rpy};

/// One transform to export: `pose` = `T_parent_child`.
#[derive(Clone, Debug, PartialEq)]
pub struct Extrinsic {
    pub parent: String,
    pub child: String,
    pub pose: Pose,
}

fn quaternion(pose: &Pose) -> [f64; 4] {
    let q = pose.rotation.quaternion();
    [q.i, q.j, q.k, q.w]
}

/// ROS 1 `tf2_ros static_transform_publisher x y z yaw pitch roll parent child`: note the
/// order, yaw before pitch before roll.
pub fn ros1_static_transform_publisher(extrinsics: &[Extrinsic]) -> String {
    let mut out = String::from(
        "# ROS 1: T_parent_child (maps child points into parent); x y z yaw pitch roll parent child\n",
    );
    for e in extrinsics {
        let ([x, y, z], [roll, pitch, yaw]) = xyz_rpy(&e.pose);
        out += &format!(
            "rosrun tf2_ros static_transform_publisher {x} {y} {z} {yaw} {pitch} {roll} {} {}\n",
            e.parent, e.child
        );
    }
    out
}

/// ROS 2 `static_transform_publisher` with named arguments (the positional form is
/// deprecated): `--frame-id` the parent, `--child-frame-id` the child.
pub fn ros2_static_transform_publisher(extrinsics: &[Extrinsic]) -> String {
    let mut out = String::from("# ROS 2: T_parent_child (maps child points into parent)\n");
    for e in extrinsics {
        let t = e.pose.translation.vector;
        let [qx, qy, qz, qw] = quaternion(&e.pose);
        out += &format!(
            "ros2 run tf2_ros static_transform_publisher --x {} --y {} --z {} --qx {qx} --qy {qy} --qz {qz} --qw {qw} --frame-id {} --child-frame-id {}\n",
            t.x, t.y, t.z, e.parent, e.child
        );
    }
    out
}

/// A `tf2_msgs/TFMessage` in YAML, ready for
/// `ros2 topic pub --qos-durability transient_local /tf_static tf2_msgs/msg/TFMessage "$(cat FILE)"`.
pub fn tf_static_yaml(extrinsics: &[Extrinsic]) -> String {
    let mut out = String::from(
        "# /tf_static: each transform maps child_frame_id points into header.frame_id\ntransforms:\n",
    );
    for e in extrinsics {
        let t = e.pose.translation.vector;
        let [qx, qy, qz, qw] = quaternion(&e.pose);
        out += &format!(
            "- header:\n    stamp: {{sec: 0, nanosec: 0}}\n    frame_id: {}\n  child_frame_id: {}\n  transform:\n    translation: {{x: {}, y: {}, z: {}}}\n    rotation: {{x: {qx}, y: {qy}, z: {qz}, w: {qw}}}\n",
            e.parent, e.child, t.x, t.y, t.z
        );
    }
    out
}

/// A URDF: a `<robot>` with a link for every frame and a fixed joint `<parent>_to_<child>`
/// with `<origin xyz rpy>` per extrinsic, a file ROS and the drift check read as it is. To
/// correct a loaded URDF in place, see `io::recording::urdf::Urdf::with_origins`.
pub fn urdf(extrinsics: &[Extrinsic]) -> String {
    let mut out = String::from(
        "<?xml version=\"1.0\"?>\n<!-- origin = T_parent_child: maps child points into parent -->\n<robot name=\"gmmcalib_calibration\">\n",
    );
    let mut links: Vec<&str> = Vec::new();
    for e in extrinsics {
        for name in [e.parent.as_str(), e.child.as_str()] {
            if !links.contains(&name) {
                links.push(name);
            }
        }
    }
    for link in links {
        out += &format!("  <link name=\"{link}\"/>\n");
    }
    for e in extrinsics {
        let (xyz, rpy) = xyz_rpy(&e.pose);
        let list = |v: [f64; 3]| v.map(|x| x.to_string()).join(" ");
        out += &format!(
            "  <joint name=\"{p}_to_{c}\" type=\"fixed\">\n    <parent link=\"{p}\"/>\n    <child link=\"{c}\"/>\n    <origin xyz=\"{}\" rpy=\"{}\"/>\n  </joint>\n",
            list(xyz),
            list(rpy),
            p = e.parent,
            c = e.child
        );
    }
    out + "</robot>\n"
}

/// Autoware's `sensor_kit_calibration.yaml`: per parent, per child `x y z roll pitch yaw`.
pub fn autoware_calibration(extrinsics: &[Extrinsic]) -> String {
    let mut out =
        String::from("# Autoware: T_parent_child (maps child points into parent), m and rad\n");
    let mut parents: Vec<&str> = Vec::new();
    for e in extrinsics {
        if !parents.contains(&e.parent.as_str()) {
            parents.push(&e.parent);
        }
    }
    for parent in parents {
        out += &format!("{parent}:\n");
        for e in extrinsics.iter().filter(|e| e.parent == parent) {
            let ([x, y, z], [roll, pitch, yaw]) = xyz_rpy(&e.pose);
            out += &format!(
                "  {}:\n    x: {x}\n    y: {y}\n    z: {z}\n    roll: {roll}\n    pitch: {pitch}\n    yaw: {yaw}\n",
                e.child
            );
        }
    }
    out
}

/// KITTI-style `Tr_<child>: r11 r12 r13 t1 r21 r22 r23 t2 r31 r32 r33 t3`, the 3x4 row-major
/// `T_parent_child`.
pub fn kitti_tr(extrinsics: &[Extrinsic]) -> String {
    let mut out = String::new();
    for e in extrinsics {
        let m = to_row_major(&e.pose);
        let numbers: Vec<String> = m[..12].iter().map(|x| x.to_string()).collect();
        out += &format!(
            "# T_{}_{}: maps {} points into {}\nTr_{}: {}\n",
            e.parent,
            e.child,
            e.child,
            e.parent,
            e.child,
            numbers.join(" ")
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::{from_row_major, pose_from_xyz_rpy};
    use nalgebra::{Quaternion, Translation3, UnitQuaternion};

    fn sample() -> Vec<Extrinsic> {
        [
            ("base_link", "lidar_left", [1.2, 0.4, 1.9], [0.02, -0.15, 0.8]),
            ("base_link", "lidar_right", [-0.3, -0.7, 2.1], [3.0, 0.4, -2.5]),
        ]
        .map(|(p, c, xyz, rpy)| Extrinsic {
            parent: p.into(),
            child: c.into(),
            pose: pose_from_xyz_rpy(xyz, rpy),
        })
        .to_vec()
    }

    fn same(a: &Pose, b: &Pose) {
        let d = a.inverse() * b;
        assert!(
            d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12,
            "{a:?} vs {b:?}"
        );
    }

    /// The numbers of each non-comment line, and its words.
    fn lines(text: &str) -> Vec<(Vec<f64>, Vec<String>)> {
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| {
                let words: Vec<String> = l
                    .split([' ', ',', '{', '}', ':', '"'])
                    .filter(|w| !w.is_empty())
                    .map(String::from)
                    .collect();
                (words.iter().filter_map(|w| w.parse().ok()).collect(), words)
            })
            .collect()
    }

    #[test]
    fn ros1_is_x_y_z_yaw_pitch_roll_parent_child() {
        let e = sample();
        for ((n, words), e) in lines(&ros1_static_transform_publisher(&e)).iter().zip(&e) {
            assert_eq!(&words[words.len() - 2..], [e.parent.clone(), e.child.clone()]);
            same(&pose_from_xyz_rpy([n[0], n[1], n[2]], [n[5], n[4], n[3]]), &e.pose);
        }
    }

    #[test]
    fn ros2_and_tf_yaml_quaternions() {
        let e = sample();
        let pose = |n: &[f64]| {
            Pose::from_parts(
                Translation3::new(n[0], n[1], n[2]),
                UnitQuaternion::from_quaternion(Quaternion::new(n[6], n[3], n[4], n[5])),
            )
        };
        for ((n, words), e) in lines(&ros2_static_transform_publisher(&e)).iter().zip(&e) {
            let at = |f: &str| words.iter().position(|w| w == f).map(|i| words[i + 1].clone());
            assert_eq!(
                (at("--frame-id"), at("--child-frame-id")),
                (Some(e.parent.clone()), Some(e.child.clone()))
            );
            same(&pose(n), &e.pose);
        }
        let yaml = tf_static_yaml(&e);
        let value: serde_norway::Value = serde_norway::from_str(&yaml).unwrap();
        for (t, e) in value["transforms"].as_sequence().unwrap().iter().zip(&e) {
            assert_eq!(t["header"]["frame_id"].as_str(), Some(e.parent.as_str()));
            assert_eq!(t["child_frame_id"].as_str(), Some(e.child.as_str()));
            let f = |k: &str, a: &str| t["transform"][k][a].as_f64().unwrap();
            let n = [
                f("translation", "x"),
                f("translation", "y"),
                f("translation", "z"),
                f("rotation", "x"),
                f("rotation", "y"),
                f("rotation", "z"),
                f("rotation", "w"),
            ];
            same(&pose(&n), &e.pose);
        }
    }

    #[test]
    fn urdf_autoware_and_kitti_round_trip() {
        let e = sample();
        let urdf = crate::io::recording::urdf::Urdf::parse(&urdf(&e)).unwrap();
        for e in &e {
            same(&urdf.tree().resolve(&e.parent, &e.child).unwrap(), &e.pose);
        }
        let value: serde_norway::Value = serde_norway::from_str(&autoware_calibration(&e)).unwrap();
        for e in &e {
            let c = &value[e.parent.as_str()][e.child.as_str()];
            let f = |k: &str| c[k].as_f64().unwrap();
            same(
                &pose_from_xyz_rpy([f("x"), f("y"), f("z")], [f("roll"), f("pitch"), f("yaw")]),
                &e.pose,
            );
        }
        for ((n, words), e) in lines(&kitti_tr(&e)).iter().zip(&e) {
            assert_eq!(words[0], format!("Tr_{}", e.child));
            let mut m = [0.0; 16];
            m[..12].copy_from_slice(n);
            m[15] = 1.0;
            same(&from_row_major(&m), &e.pose);
        }
    }

    #[test]
    fn urdf_origins_are_edited_in_place() {
        let text = "<?xml version=\"1.0\"?>\n<robot name=\"car\">\n  <link name=\"base_link\"/>\n  <!-- keep me -->\n  <joint name=\"kit\" type=\"fixed\">\n    <parent link=\"base_link\"/>\n    <child link=\"kit\"/>\n    <origin xyz=\"1 0 1.5\" rpy=\"0 0 0.1\"/>\n  </joint>\n  <joint name=\"left\" type=\"fixed\">\n    <parent link=\"kit\"/>\n    <child link=\"lidar_left\"/>\n    <origin xyz=\"0.2 0.5 0\" rpy=\"0 0.1 0\"/>\n  </joint>\n  <joint name=\"right\" type=\"fixed\">\n    <parent link=\"kit\"/>\n    <child link=\"lidar_right\"/>\n  </joint>\n</robot>\n";
        let urdf = crate::io::recording::urdf::Urdf::parse(text).unwrap();
        let e = sample();
        let poses: Vec<(String, Pose)> = e.iter().map(|e| (e.child.clone(), e.pose)).collect();
        let edited = urdf.with_origins("base_link", &poses).unwrap();
        assert!(
            edited.contains("<!-- keep me -->")
                && edited.contains("<origin xyz=\"1 0 1.5\" rpy=\"0 0 0.1\"/>")
        );
        let tree = crate::io::recording::urdf::Urdf::parse(&edited).unwrap().tree();
        for e in &e {
            same(&tree.resolve("base_link", &e.child).unwrap(), &e.pose);
        }
    }
}
