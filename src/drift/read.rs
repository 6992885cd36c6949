//! Reading a stored calibration: our result JSON (`gmmcalib calibrate --json`, the page's
//! export), a URDF (joint origins) or a `/tf_static` YAML (`--export tf-yaml`), told apart by
//! their first character. Errors name the file, the place and the problem.

use serde::Deserialize;
use serde_norway::Value;

use super::{Extrinsics, Mount, Source};
use crate::calib::Precision;
use crate::io::recording::urdf::Urdf;
use crate::io::recording::{Transform, Tree};
use crate::se3::{Pose, from_row_major};
use nalgebra::{Quaternion, Translation3, UnitQuaternion};

/// A stored calibration that cannot be read.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadError {
    pub file: String,
    /// Where in the file (a line and column, a key, a sensor), or empty.
    pub place: String,
    pub problem: String,
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.place.is_empty() {
            true => write!(f, "{}: {}", self.file, self.problem),
            false => write!(f, "{}: {}: {}", self.file, self.place, self.problem),
        }
    }
}

impl std::error::Error for ReadError {}

/// The extrinsics in `text` (the file named `file`).
pub fn read(text: &str, file: &str) -> Result<Extrinsics, ReadError> {
    let fail = |place: String, problem: String| ReadError { file: file.into(), place, problem };
    match text.trim_start().chars().next() {
        Some('{' | '[') => json(text, &fail),
        Some('<') => {
            let urdf = Urdf::parse(text).map_err(|e| fail(String::new(), e))?;
            Ok(tree(Source::Urdf, &urdf.tree()))
        }
        Some(_) => tf_yaml(text, &fail),
        None => Err(fail(String::new(), "empty file".into())),
    }
}

#[derive(Deserialize)]
struct JsonResult {
    reference: String,
    sensors: Vec<JsonSensor>,
}

#[derive(Deserialize)]
struct JsonSensor {
    name: String,
    extrinsic: [f64; 16],
    precision: Option<JsonPrecision>,
}

#[derive(Deserialize)]
struct JsonPrecision {
    rotation: [f64; 3],
    position: [f64; 3],
}

fn json(text: &str, fail: &dyn Fn(String, String) -> ReadError) -> Result<Extrinsics, ReadError> {
    let at = |e: serde_json::Error| {
        fail(format!("line {} column {}", e.line(), e.column()), {
            // serde_json appends " at line L column C"; the place says it already.
            let s = e.to_string();
            s.split(" at line ").next().unwrap_or(&s).to_string()
        })
    };
    if text.trim_start().starts_with('[') {
        let n = serde_json::from_str::<Vec<serde_json::Value>>(text).map_err(at)?.len();
        return Err(fail(
            String::new(),
            format!("holds {n} results (--method all); compare takes one method's result"),
        ));
    }
    let result: JsonResult = serde_json::from_str(text).map_err(at)?;
    let mut mounts = Vec::new();
    for s in result.sensors {
        let place = || format!("sensor '{}'", s.name);
        if !s.extrinsic.iter().all(|x| x.is_finite()) {
            return Err(fail(place(), "extrinsic holds a number that is not finite".into()));
        }
        let precision =
            s.precision.map(|p| Precision { rotation: p.rotation, position: p.position });
        mounts.push(Mount { sensor: s.name, extrinsic: from_row_major(&s.extrinsic), precision });
    }
    if !mounts.iter().any(|m| m.sensor == result.reference) {
        let problem = format!("reference '{}' is not among the sensors", result.reference);
        return Err(fail("reference".into(), problem));
    }
    Ok(Extrinsics { source: Source::Json, reference: Some(result.reference), mounts })
}

/// Every frame of a tree as a mount, `T_root_frame`.
fn tree(source: Source, tree: &Tree) -> Extrinsics {
    let mounts = tree
        .edges
        .iter()
        .filter_map(|e| {
            let extrinsic = tree.roots().iter().find_map(|r| tree.resolve(r, &e.child).ok())?;
            Some(Mount { sensor: e.child.clone(), extrinsic, precision: None })
        })
        .collect();
    Extrinsics { source, reference: None, mounts }
}

/// A `tf2_msgs/TFMessage` in YAML: `transforms: [{header: {frame_id}, child_frame_id,
/// transform: {translation: {x, y, z}, rotation: {x, y, z, w}}}]`.
fn tf_yaml(
    text: &str,
    fail: &dyn Fn(String, String) -> ReadError,
) -> Result<Extrinsics, ReadError> {
    let value: Value = serde_norway::from_str(text).map_err(|e| {
        let place = e.location().map_or(String::new(), |l| format!("line {}", l.line()));
        fail(place, format!("not YAML: {e}"))
    })?;
    let list = value.get("transforms").and_then(Value::as_sequence).ok_or_else(|| {
        fail(String::new(), "expected a URDF, our JSON or a tf YAML (no 'transforms' list)".into())
    })?;
    let mut edges = Vec::new();
    for (i, t) in list.iter().enumerate() {
        let place = |key: &str| format!("transforms[{i}].{key}");
        let text_at = |path: &[&str]| {
            path.iter()
                .try_fold(t, |v, k| v.get(*k))
                .and_then(Value::as_str)
                .map(str::to_string)
                .ok_or_else(|| fail(place(&path.join(".")), "missing or not text".into()))
        };
        let number = |path: &[&str]| {
            path.iter()
                .try_fold(t, |v, k| v.get(*k))
                .and_then(Value::as_f64)
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    fail(place(&path.join(".")), "missing or not a finite number".into())
                })
        };
        let parent = text_at(&["header", "frame_id"])?;
        let child = text_at(&["child_frame_id"])?;
        let [x, y, z] = ["x", "y", "z"].map(|k| number(&["transform", "translation", k]));
        let [qx, qy, qz, qw] = ["x", "y", "z", "w"].map(|k| number(&["transform", "rotation", k]));
        let q = Quaternion::new(qw?, qx?, qy?, qz?);
        if (q.norm() - 1.0).abs() > 1e-6 {
            let problem = format!("not a unit quaternion (norm {})", q.norm());
            return Err(fail(place("transform.rotation"), problem));
        }
        let pose =
            Pose::from_parts(Translation3::new(x?, y?, z?), UnitQuaternion::from_quaternion(q));
        edges.push(Transform { parent, child, pose, stamp_ns: 0 });
    }
    Ok(tree(Source::TfYaml, &Tree::new(edges)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::ros::{Extrinsic, tf_static_yaml, urdf};
    use crate::se3::pose_from_xyz_rpy;

    fn exported() -> Vec<Extrinsic> {
        [
            ("sensor_1", [1.0, 0.5, 1.6], [0.1, 0.0, 0.3]),
            ("sensor_2", [1.0, -0.5, 1.7], [-0.1, 0.02, -2.9]),
        ]
        .map(|(c, xyz, rpy)| Extrinsic {
            parent: "base_link".into(),
            child: c.into(),
            pose: pose_from_xyz_rpy(xyz, rpy),
        })
        .to_vec()
    }

    #[test]
    fn reads_back_what_the_exports_write() {
        for (text, source) in
            [(tf_static_yaml(&exported()), Source::TfYaml), (urdf(&exported()), Source::Urdf)]
        {
            let read = read(&text, "f").unwrap();
            assert_eq!(read.source, source);
            for e in exported() {
                let m = read.mount(&e.child).unwrap();
                assert!(
                    (m.extrinsic.translation.vector - e.pose.translation.vector).norm() < 1e-12
                );
                assert!(m.extrinsic.rotation.angle_to(&e.pose.rotation) < 1e-12);
            }
        }
    }

    #[test]
    fn errors_name_the_file_and_the_place() {
        let e = read("{\"reference\": \"a\", \"sensors\": [}", "old.json").unwrap_err();
        assert!(e.to_string().starts_with("old.json: line 1 column"), "{e}");
        let e = read("[{}, {}]", "all.json").unwrap_err();
        assert!(e.to_string().contains("holds 2 results"), "{e}");
        let bad = tf_static_yaml(&exported()).replacen("w: ", "w: x", 1);
        let e = read(&bad, "tf.yaml").unwrap_err();
        assert_eq!(e.place, "transforms[0].transform.rotation.w", "{e}");
        let e = read("a: 1\n", "x.yaml").unwrap_err();
        assert!(e.problem.contains("no 'transforms' list"), "{e}");
        let e = read("<robot><joint name=\"j\"><parent link=\"a\"/></joint></robot>", "r.urdf");
        assert!(e.unwrap_err().to_string().starts_with("r.urdf: joint 'j'"));
    }
}
