//! The data layouts `calibrate` reads: GMMCalib's, `DIR/sensor_N/<frame>.{pcd,ply,bin}`
//! (sensors and frames ordered naturally, `sensor_2` before `sensor_10`; a scan's sensor is its
//! folder name and its frame the file stem, so frames pair across sensors by stem); and
//! OpenCalib's, `lidar_cloud_path.txt` naming each device's file (one frame per device) beside
//! its guess, `initial_extrinsic.txt`.

use std::cmp::Ordering;

use super::{EntryKind, Host, join, read_text};
use crate::calib::Scan;
use crate::io::{opencalib, parse_cloud};
use crate::se3::Pose;

const EXTENSIONS: [&str; 3] = ["pcd", "ply", "bin"];

/// What a data folder holds: its scans, and the nominals its layout gives (OpenCalib's guess).
pub struct Dataset {
    pub scans: Vec<Scan>,
    pub guess: Option<Vec<(String, Pose)>>,
}

/// Every scan under `dir` and the nominals the layout gives, if any.
pub fn read_dir(host: &mut dyn Host, dir: &str) -> Result<Dataset, String> {
    let paths = join(dir, "lidar_cloud_path.txt");
    if host.kind(&paths) != EntryKind::File {
        return Ok(Dataset { scans: read_scans(host, dir)?, guess: None });
    }
    let devices =
        opencalib::read_paths(&read_text(host, &paths)?, &paths).map_err(|e| e.to_string())?;
    let mut scans = Vec::new();
    for device in &devices {
        // The paths are relative to OpenCalib's tree; the files sit beside the list.
        let name = device.path.rsplit('/').next().unwrap_or(&device.path);
        let file = join(dir, name);
        scans.push(scan(host, device.name.clone(), "1".into(), file)?);
    }
    let guess = join(dir, "initial_extrinsic.txt");
    let guess = if host.kind(&guess) == EntryKind::File {
        let poses =
            opencalib::read_guess(&read_text(host, &guess)?, &guess).map_err(|e| e.to_string())?;
        Some(opencalib::nominals(&poses, &devices, &guess).map_err(|e| e.to_string())?)
    } else {
        None
    };
    Ok(Dataset { scans, guess })
}

/// The scan in `file`, labelled (sensor, frame).
fn scan(host: &mut dyn Host, sensor: String, frame: String, file: String) -> Result<Scan, String> {
    let bytes = host.read(&file).map_err(|e| format!("{file}: {e}"))?;
    let parsed = parse_cloud(&bytes, &file).map_err(|e| e.to_string())?;
    Ok(Scan { sensor, frame, points: parsed.cloud.points, source: Some(file) })
}

/// Every scan under `dir`, sensor by sensor, frames in natural order.
fn read_scans(host: &mut dyn Host, dir: &str) -> Result<Vec<Scan>, String> {
    let mut views = Vec::new();
    for (sensor, folder) in sensor_folders(host, dir)? {
        for (frame, file) in frame_files(host, &folder)? {
            views.push(scan(host, sensor.clone(), frame, file)?);
        }
    }
    Ok(views)
}

/// `(name, path)` of the `sensor_*` folders in `dir`, naturally ordered.
fn sensor_folders(host: &mut dyn Host, dir: &str) -> Result<Vec<(String, String)>, String> {
    let mut folders = Vec::new();
    for name in host.list(dir).map_err(|e| format!("{dir}: {e}"))? {
        let path = join(dir, &name);
        if name.starts_with("sensor_") && host.kind(&path) == EntryKind::Dir {
            folders.push((name, path));
        }
    }
    if folders.is_empty() {
        return Err(format!("{dir}: no sensor folders (sensor_1, sensor_2, ...)"));
    }
    folders.sort_by(|a, b| natural(&a.0, &b.0));
    Ok(folders)
}

/// `(stem, path)` of the point-cloud files in `folder`, naturally ordered by stem.
fn frame_files(host: &mut dyn Host, folder: &str) -> Result<Vec<(String, String)>, String> {
    let mut names = host.list(folder).map_err(|e| format!("{folder}: {e}"))?;
    // A fixed order, so that which of two files for one frame is named first does not
    // depend on the file system.
    names.sort();
    let mut files: Vec<(String, String)> = Vec::new();
    for name in names {
        let Some((stem, ext)) = name.rsplit_once('.') else { continue };
        let path = join(folder, &name);
        if !EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str())
            || host.kind(&path) != EntryKind::File
        {
            continue;
        }
        if let Some((_, other)) = files.iter().find(|(s, _)| s == stem) {
            return Err(format!("{other} and {path}: two files for frame {stem}"));
        }
        files.push((stem.to_string(), path));
    }
    if files.is_empty() {
        return Err(format!("{folder}: no point-cloud frames (.pcd, .ply, .bin)"));
    }
    files.sort_by(|a, b| natural(&a.0, &b.0));
    Ok(files)
}

/// Natural order: runs of digits compare as numbers, everything else as text.
pub fn natural(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a, b);
    loop {
        let (Some(ca), Some(cb)) = (a.chars().next(), b.chars().next()) else {
            return a.len().cmp(&b.len());
        };
        let order = if ca.is_ascii_digit() && cb.is_ascii_digit() {
            let (da, ra) = split_digits(a);
            let (db, rb) = split_digits(b);
            (a, b) = (ra, rb);
            let (ta, tb) = (da.trim_start_matches('0'), db.trim_start_matches('0'));
            ta.len().cmp(&tb.len()).then(ta.cmp(tb)).then(da.len().cmp(&db.len()))
        } else {
            (a, b) = (&a[ca.len_utf8()..], &b[cb.len_utf8()..]);
            ca.cmp(&cb)
        };
        if order != Ordering::Equal {
            return order;
        }
    }
}

fn split_digits(s: &str) -> (&str, &str) {
    s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order() {
        let mut names = vec!["sensor_10", "sensor_2", "sensor_1", "10.pcd", "9.pcd", "a", "02"];
        names.sort_by(|a, b| natural(a, b));
        assert_eq!(names, ["02", "9.pcd", "10.pcd", "a", "sensor_1", "sensor_2", "sensor_10"]);
        assert_eq!(natural("frame_007", "frame_7"), Ordering::Greater);
        assert_eq!(natural("x1", "x1"), Ordering::Equal);
    }
}
