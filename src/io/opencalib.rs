//! OpenCalib's rig description (PJLab-ADG/SensorsCalibration, `lidar2lidar`): its rough guess
//! per device, `initial_extrinsic.txt`, and which file is which device,
//! `lidar_cloud_path.txt`. Text in, typed values out; every error names the file and the line.
//!
//! ```text
//! device_id: 1
//! (Roll,Pitch,Yaw,tx,ty,tz): 0 0 90 -0.0676 0.6258 -0.3515     degrees and metres
//! ```
//!
//! The guess is `T_device0_device` with `R = Rz(yaw) Ry(pitch) Rx(roll)`: device 0 is the
//! reference and its frame is the vehicle frame.

use super::{IoError, Offset};
use crate::se3::{Pose, pose_from_xyz_rpy};

/// One device's entry of `lidar_cloud_path.txt`: its id, its file, and a sensor name from the
/// file's name (`top-2022-02-15-17-36-04-449.pcd` -> `top`).
#[derive(Clone, Debug, PartialEq)]
pub struct Device {
    pub id: u32,
    pub path: String,
    pub name: String,
}

/// `initial_extrinsic.txt`: `(device id, T_device0_device)` in the file's order.
pub fn read_guess<'t>(text: &'t str, file: &str) -> Result<Vec<(u32, Pose)>, IoError> {
    let mut out = Vec::new();
    let value = |line: &'t str| line.split_once("):").map(|(_, v)| v);
    device_entries(text, file, "an extrinsic", value, |device, line, v| {
        let fail = |problem: String| IoError {
            file: file.into(),
            offset: Some(Offset::Line(line)),
            problem,
        };
        let v: Vec<f64> = v
            .split_whitespace()
            .map(|x| x.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| {
                fail(
                    "expected six finite numbers (roll, pitch, yaw in deg, tx, ty, tz in m)".into(),
                )
            })?;
        let &[roll, pitch, yaw, x, y, z] = v.as_slice() else {
            return Err(fail(format!(
                "expected six numbers (Roll,Pitch,Yaw,tx,ty,tz), got {}",
                v.len()
            )));
        };
        out.push((device, pose_from_xyz_rpy([x, y, z], [roll, pitch, yaw].map(f64::to_radians))));
        Ok(())
    })?;
    if out.is_empty() {
        return Err(IoError {
            file: file.into(),
            offset: None,
            problem: "no device extrinsics".into(),
        });
    }
    Ok(out)
}

/// `lidar_cloud_path.txt`: each device's file, in the file's order.
pub fn read_paths<'t>(text: &'t str, file: &str) -> Result<Vec<Device>, IoError> {
    let mut out: Vec<Device> = Vec::new();
    let value = |line: &'t str| line.strip_prefix("path:");
    device_entries(text, file, "a path", value, |id, line, path| {
        let path = path.trim().to_string();
        let stem = path.rsplit('/').next().unwrap_or(&path);
        let stem = stem.rsplit_once('.').map_or(stem, |(s, _)| s);
        let name = stem.split('-').next().filter(|s| !s.is_empty()).unwrap_or(stem).to_string();
        if out.iter().any(|d| d.name == name) {
            return Err(IoError {
                file: file.into(),
                offset: Some(Offset::Line(line)),
                problem: format!("two devices named '{name}'"),
            });
        }
        out.push(Device { id, path, name });
        Ok(())
    })?;
    if out.is_empty() {
        return Err(IoError { file: file.into(), offset: None, problem: "no device paths".into() });
    }
    Ok(out)
}

/// The layout both files share: `device_id: N` lines, each followed by one value line that
/// `value` recognises (returning the value's text), `what` in messages. `each(device id, line
/// number, value)` runs on every entry in order; any other line, a bad id or a value before
/// its id is an error naming the line.
fn device_entries<'t>(
    text: &'t str,
    file: &str,
    what: &str,
    value: impl Fn(&'t str) -> Option<&'t str>,
    mut each: impl FnMut(u32, usize, &'t str) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let mut id = None;
    for (n, line) in text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())) {
        let fail =
            |problem: String| IoError { file: file.into(), offset: Some(Offset::Line(n)), problem };
        if line.is_empty() {
            continue;
        }
        if let Some(v) = line.strip_prefix("device_id:") {
            id = Some(
                v.trim()
                    .parse::<u32>()
                    .map_err(|_| fail(format!("device_id '{}' is not a number", v.trim())))?,
            );
        } else if let Some(v) = value(line) {
            let device = id.take().ok_or_else(|| fail(format!("{what} before its device_id")))?;
            each(device, n, v)?;
        } else {
            return Err(fail(format!("unexpected line '{line}'")));
        }
    }
    Ok(())
}

/// Each device's nominal by its name: the guess of each device in `paths`.
pub fn nominals(
    guess: &[(u32, Pose)],
    paths: &[Device],
    file: &str,
) -> Result<Vec<(String, Pose)>, IoError> {
    paths
        .iter()
        .map(|d| {
            let pose = guess.iter().find(|(id, _)| *id == d.id).map(|(_, p)| *p);
            pose.map(|p| (d.name.clone(), p)).ok_or_else(|| IoError {
                file: file.into(),
                offset: None,
                problem: format!("no extrinsic for device {} ({})", d.id, d.name),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::xyz_rpy;

    const GUESS: &str = "device_id: 0\n(Roll,Pitch,Yaw,tx,ty,tz): 0 0 0 0 0 0\ndevice_id: 1\n(Roll,Pitch,Yaw,tx,ty,tz): 0 0 90 -0.0676 0.6258 -0.3515\n";
    const PATHS: &str = "device_id: 0\npath: data/0002/top-2022-02-15-17-36-04-449.pcd\ndevice_id: 1\npath: data/0002/left.pcd\n";

    #[test]
    fn reads_opencalib_files() {
        let guess = read_guess(GUESS, "initial_extrinsic.txt").unwrap();
        let (xyz, rpy) = xyz_rpy(&guess[1].1);
        assert!((rpy[2] - 90f64.to_radians()).abs() < 1e-12 && (xyz[1] - 0.6258).abs() < 1e-12);
        let paths = read_paths(PATHS, "lidar_cloud_path.txt").unwrap();
        assert_eq!(paths.iter().map(|d| d.name.as_str()).collect::<Vec<_>>(), ["top", "left"]);
        let named = nominals(&guess, &paths, "x").unwrap();
        assert_eq!(named[1].0, "left");
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let e = read_guess("device_id: 0\n(Roll,Pitch,Yaw,tx,ty,tz): 0 0 x 0 0 0\n", "g.txt")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "g.txt, line 2: expected six finite numbers (roll, pitch, yaw in deg, tx, ty, tz in m)"
        );
        let e = read_guess("(Roll,Pitch,Yaw,tx,ty,tz): 0 0 0 0 0 0\n", "g.txt").unwrap_err();
        assert!(e.to_string().contains("line 1: an extrinsic before its device_id"));
        let e = read_paths("device_id: 0\npath: a.pcd\ndevice_id: 1\npath: b/a.pcd\n", "p.txt")
            .unwrap_err();
        assert!(e.to_string().contains("two devices named 'a'"));
        assert!(read_guess("", "g.txt").unwrap_err().to_string().contains("no device extrinsics"));
    }
}
