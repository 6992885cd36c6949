//! Rig descriptions: GMMCalib's `config.yaml` plus a few optional keys of ours. One reader, one
//! set of rules, for the CLI and the page (through wasm).
//!
//! ```yaml
//! number_of_sensors: 2
//! transform_sensor_1:                      # sensor -> vehicle
//!   - [-0.346, 0.0165, -0.0163, 2.31, 0.58, 1.61]   # [roll, pitch, yaw (rad), x, y, z (m)]
//! min_bound:
//!   - [8.5, -3, -1]                        # ROI in the vehicle frame (m)
//! max_bound: [11, 4, 2]                    # the plain form, without the extra list, works too
//! # ours, all optional: reference, and the settings every door shares (`SettingsInput`:
//! # method, target (mesh:PATH relative to the config), target_edge, components, iterations,
//! # tolerance, multiresolution, exact, initial_sigma, seed, global, level, bev, refine)
//! ```
//!
//! Rules: `transform_<name>` gives sensor `<name>`'s nominal (the data folder of that name);
//! `number_of_sensors`, when present, must count them; the ROI is optional, but `min_bound`
//! and `max_bound` come together, with min <= max on every axis; unknown keys are ignored, as
//! GMMCalib's own configs carry keys this tool does not use.

use serde_norway::{Mapping, Value};

use crate::calib::{Settings, SettingsInput, TargetChoice};
use crate::cloud::Aabb;
use crate::io::IoError;
use crate::se3::{Pose, pose_from_xyz_rpy};

/// A sensor's nominal `T_vehicle_sensor` as the file gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct Nominal {
    /// The sensor's (data folder's) name.
    pub sensor: String,
    /// Translation (m).
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw (rad).
    pub rpy: [f64; 3],
}

impl Nominal {
    pub fn pose(&self) -> Pose {
        pose_from_xyz_rpy(self.xyz, self.rpy)
    }
}

/// What a config sets; everything but the nominals is optional.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// Nominal extrinsics, in the file's order.
    pub nominal: Vec<Nominal>,
    pub roi: Option<Aabb>,
    pub reference: Option<String>,
    /// The settings it sets, under the keys every door shares ([`SettingsInput`]). A
    /// `target: mesh:PATH` is left for the caller to read, relative to the config's folder.
    pub settings: SettingsInput,
}

impl Config {
    /// Parses the config text; `file` names it in every error.
    pub fn from_yaml(text: &str, file: &str) -> Result<Config, IoError> {
        let fail = |problem: String| IoError { file: file.to_string(), offset: None, problem };
        let value: Value = serde_norway::from_str(text)
            .map_err(|e| fail(format!("bad YAML: {}", one_line(&e.to_string()))))?;
        let Value::Mapping(map) = value else {
            return Err(fail("expected a mapping of keys to values".into()));
        };
        let mut nominal = Vec::new();
        for (key, value) in &map {
            let Some(sensor) = key.as_str().and_then(|k| k.strip_prefix("transform_")) else {
                continue;
            };
            let (xyz, rpy) =
                transform(value).map_err(|e| fail(format!("transform_{sensor}: {e}")))?;
            nominal.push(Nominal { sensor: sensor.to_string(), xyz, rpy });
        }
        let bound = |key: &str| {
            let value = map.get(key).ok_or_else(|| fail(format!("missing key {key}")))?;
            numbers::<3>(value, "[x, y, z]").map_err(|e| fail(format!("{key}: {e}")))
        };
        let roi = match (map.contains_key("min_bound"), map.contains_key("max_bound")) {
            (false, false) => None,
            _ => {
                let roi = Aabb::new(bound("min_bound")?, bound("max_bound")?);
                if !roi.is_valid() {
                    return Err(fail("min_bound must be <= max_bound on every axis".into()));
                }
                Some(roi)
            }
        };
        // GMMCalib's sensor count, kept only as a check that no transform is missing.
        if let Some(n) = count(&map, "number_of_sensors").map_err(fail)? {
            if n != nominal.len() {
                let keys = nominal.len();
                return Err(fail(format!(
                    "number_of_sensors is {n} but {keys} transform_sensor_N keys"
                )));
            }
        }
        let settings = settings(&map).map_err(fail)?;
        Ok(Config { nominal, roi, reference: string(&map, "reference").map_err(fail)?, settings })
    }

    /// The nominals as poses, by sensor name.
    pub fn nominal_poses(&self) -> Vec<(String, Pose)> {
        self.nominal.iter().map(|n| (n.sensor.clone(), n.pose())).collect()
    }
}

/// The settings keys of `map`, one at a time so that an error names its key, and checked as
/// the run will apply them.
fn settings(map: &Mapping) -> Result<SettingsInput, String> {
    let mut known = Mapping::new();
    for (key, value) in map {
        let one = Mapping::from_iter([(key.clone(), value.clone())]);
        serde_norway::from_value::<SettingsInput>(Value::Mapping(one)).map_err(|e| {
            let (key, shown, problem) = (key.as_str().unwrap_or("?"), show(value), e.to_string());
            // serde says "invalid type: string "x", expected a boolean": say what was expected.
            match problem.split_once(", expected ") {
                Some((_, "a boolean")) => format!("{key}: expected true or false, got {shown}"),
                Some((_, expected)) => format!("{key}: expected {expected}, got {shown}"),
                None if problem.contains(&shown) => format!("{key}: {problem}"),
                None => format!("{key}: {problem}, got {shown}"),
            }
        })?;
        known.insert(key.clone(), value.clone());
    }
    let settings: SettingsInput =
        serde_norway::from_value(Value::Mapping(known)).map_err(|e| one_line(&e.to_string()))?;
    let mut unread = settings.clone();
    if matches!(unread.target, Some(TargetChoice::MeshFile(_))) {
        unread.target = None;
    }
    unread.apply(&mut Settings::default())?;
    Ok(settings)
}

/// A sensor's nominal in any of the forms users have: GMMCalib's six numbers `[roll, pitch,
/// yaw, x, y, z]` (rad, m), seven `[x, y, z, qx, qy, qz, qw]`, or sixteen (a 4x4 matrix,
/// row-major); as translation and roll, pitch, yaw.
fn transform(value: &Value) -> Result<([f64; 3], [f64; 3]), String> {
    const FORMS: &str = "[roll, pitch, yaw, x, y, z], [x, y, z, qx, qy, qz, qw] or a 4x4 row-major";
    let count = value
        .as_sequence()
        .map(|s| match s.as_slice() {
            [Value::Sequence(inner)] => inner.len(),
            s => s.len(),
        })
        .unwrap_or(0);
    match count {
        7 => {
            let v = numbers::<7>(value, "[x, y, z, qx, qy, qz, qw]")?;
            let q = nalgebra::Quaternion::new(v[6], v[3], v[4], v[5]);
            if (q.norm() - 1.0).abs() > 1e-3 {
                return Err(format!("the quaternion's norm is {:.4}, not 1", q.norm()));
            }
            let pose = Pose::from_parts(
                nalgebra::Translation3::new(v[0], v[1], v[2]),
                nalgebra::UnitQuaternion::from_quaternion(q),
            );
            Ok(crate::se3::xyz_rpy(&pose))
        }
        16 => {
            let v = numbers::<16>(value, "(a 4x4 matrix, row-major)")?;
            let m = nalgebra::Matrix4::from_row_slice(&v);
            let r = m.fixed_view::<3, 3>(0, 0).into_owned();
            let orthonormal = (r.transpose() * r - nalgebra::Matrix3::identity()).amax() < 1e-4
                && (r.determinant() - 1.0).abs() < 1e-4
                && m.row(3).iter().zip([0.0, 0.0, 0.0, 1.0]).all(|(a, b)| (a - b).abs() < 1e-9);
            if !orthonormal {
                return Err("the 4x4 matrix is not a rigid transform".into());
            }
            Ok(crate::se3::xyz_rpy(&crate::se3::from_row_major(&v)))
        }
        _ => {
            let v = numbers::<6>(value, "[roll, pitch, yaw, x, y, z]").map_err(|e| {
                if count == 6 { e } else { format!("expected {FORMS}, got {count} numbers") }
            })?;
            Ok(([v[3], v[4], v[5]], [v[0], v[1], v[2]]))
        }
    }
}

/// `N` numbers, as `[a, b, ...]` or GMMCalib's `- [a, b, ...]` (a list holding one list).
fn numbers<const N: usize>(value: &Value, layout: &str) -> Result<[f64; N], String> {
    let mut seq = value.as_sequence().ok_or_else(|| format!("expected a list {layout}"))?;
    if let [Value::Sequence(inner)] = seq.as_slice() {
        seq = inner;
    }
    if seq.len() != N {
        return Err(format!("expected {N} numbers {layout}, got {}", seq.len()));
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(seq) {
        *o = v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("expected finite numbers {layout}, got {}", show(v)))?;
    }
    Ok(out)
}

fn count(map: &Mapping, key: &str) -> Result<Option<usize>, String> {
    map.get(key)
        .map(|v| match v.as_u64() {
            Some(n) if n > 0 => Ok(n as usize),
            _ => Err(format!("{key}: expected a positive integer, got {}", show(v))),
        })
        .transpose()
}

fn string(map: &Mapping, key: &str) -> Result<Option<String>, String> {
    map.get(key)
        .map(|v| {
            v.as_str()
                .map(String::from)
                .ok_or_else(|| format!("{key}: expected a string, got {}", show(v)))
        })
        .transpose()
}

/// A YAML value on one line, for error messages.
fn show(v: &Value) -> String {
    serde_norway::to_string(v).map_or_else(|_| "?".into(), |s| one_line(s.trim()))
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{InitialSigma, Method, Methods};
    use crate::targets::Target;

    const GMMCALIB: &str = "\
number_of_sensors: 2
transform_sensor_1:
  - [-0.3461248, 0.0165291, -0.0162606, 2.31205, 0.581505, 1.610277] #[roll, pitch, yaw, x, y z]
transform_sensor_2:
  - [0.3551248, 0.0165291, 0.0061281, 2.311906, -0.664888, 1.612698]
min_bound:
  - [8.5, -3, -1]
max_bound:
  - [11, 4, 2]
";

    fn parse(text: &str) -> Result<Config, String> {
        Config::from_yaml(text, "c.yaml").map_err(|e| e.to_string())
    }

    #[test]
    fn reads_gmmcalib_config() {
        let c = parse(GMMCALIB).unwrap();
        assert_eq!(c.nominal.len(), 2);
        let roi = c.roi.unwrap();
        assert_eq!(roi.min, [8.5, -3.0, -1.0]);
        assert_eq!(roi.max, [11.0, 4.0, 2.0]);
        let n = &c.nominal[1];
        assert_eq!(n.sensor, "sensor_2");
        assert_eq!((n.xyz[1], n.rpy[0]), (-0.664888, 0.3551248), "the numbers as written");
        assert_eq!(c.settings, SettingsInput::default(), "GMMCalib's own keys set nothing");
    }

    #[test]
    fn reads_plain_form_and_our_keys() {
        let text = "transform_sensor_1: [0, 0, 0, 1, 2, 3]\nmin_bound: [0, 0, 0]\n\
                    max_bound: [1, 1, 1]\nmethod: jrmpc\niterations: 5\ninitial_sigma: prior\n\
                    target_edge: 0.6\nexact: true\n";
        let c = parse(text).unwrap();
        let mut settings = crate::calib::Settings::default();
        assert_eq!(c.settings.apply(&mut settings).unwrap(), vec![Method::Jrmpc]);
        assert!(settings.jrmpc.exact);
        assert_eq!(c.nominal[0].xyz, [1.0, 2.0, 3.0]);
        assert_eq!(settings.jrmpc.max_iterations, 5);
        assert_eq!(settings.initial_sigma, InitialSigma::TargetSize);
        assert_eq!(settings.target, Target::Cube { edge: 0.6 });
        let all = parse("method: all\n").unwrap();
        assert_eq!(all.settings.method, Some(Methods(Method::ALL.to_vec())));
        assert_eq!(all.roi, None, "the ROI is optional");
        let none = parse("target: none\n").unwrap();
        assert_eq!(none.settings.target, Some(TargetChoice::Shape(Target::None)));
        let mesh = parse("target: mesh:models/chair.obj\n").unwrap();
        assert_eq!(mesh.settings.target, Some(TargetChoice::MeshFile("models/chair.obj".into())));
    }

    #[test]
    fn reads_quaternion_and_matrix_nominals() {
        let half = std::f64::consts::FRAC_1_SQRT_2;
        let text = format!(
            "transform_q: [1, 2, 3, 0, 0, {half}, {half}]\n\
             transform_m: [0, -1, 0, 1,  1, 0, 0, 2,  0, 0, 1, 3,  0, 0, 0, 1]\n"
        );
        let c = parse(&text).unwrap();
        for n in &c.nominal {
            assert_eq!(n.xyz, [1.0, 2.0, 3.0], "{}", n.sensor);
            assert!((n.rpy[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{n:?}");
        }
        assert!(
            parse("transform_m: [1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n")
                .unwrap_err()
                .contains("not a rigid transform")
        );
    }

    #[test]
    fn errors_name_the_key() {
        let err = |t: &str| parse(t).unwrap_err();
        assert!(err("min_bound: [0, 0, 0]\n").contains("missing key max_bound"));
        let short = "number_of_sensors: 2\ntransform_sensor_1: [0, 0, 0, 0, 0, 0]\n\
                     min_bound: [0, 0, 0]\nmax_bound: [1, 1, 1]\n";
        assert!(err(short).contains("number_of_sensors is 2 but 1"));
        assert!(err("transform_sensor_1: [1, 2]\n").contains("transform_sensor_1: expected [roll"));
        assert!(err("transform_a: [0, 0, 0, 0, 0, 0, 2]\n").contains("norm is 2.0000"));
        assert!(err("a: [1, 2\n").starts_with("c.yaml: bad YAML"));
        assert!(err("- 1\n").contains("c.yaml: expected a mapping"));
        let bad_sigma = "min_bound: [0,0,0]\nmax_bound: [1,1,1]\ninitial_sigma: wide\n";
        assert!(err(bad_sigma).contains("initial_sigma"));
        assert_eq!(
            err("exact: yes please\n"),
            "c.yaml: exact: expected true or false, got yes please"
        );
        let bad = err("method: ndt\n");
        assert!(bad.starts_with("c.yaml: method: unknown method 'ndt'"), "{bad}");
        assert!(err("components: 0\n").starts_with("c.yaml: components: expected a positive"));
        assert!(err("target_edge: -1\n").contains("target: target size must be a positive"));
        assert!(!err("a: [1, 2\n").contains('\n'));
    }
}
