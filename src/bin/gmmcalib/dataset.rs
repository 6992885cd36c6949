//! The data layouts `calibrate` reads: GMMCalib's, `DIR/sensor_N/<frame>.{pcd,ply,bin}`
//! (sensors and frames ordered naturally, `sensor_2` before `sensor_10`; a scan's sensor is its
//! folder name and its frame the file stem, so frames pair across sensors by stem); and
//! OpenCalib's, `lidar_cloud_path.txt` naming each device's file (one frame per device) beside
//! its guess, `initial_extrinsic.txt`.

use std::cmp::Ordering;
use std::fs;
use std::path::{Path, PathBuf};

use gmmcalib::calib::Scan;
use gmmcalib::io::{opencalib, parse_cloud};
use gmmcalib::se3::Pose;

const EXTENSIONS: [&str; 3] = ["pcd", "ply", "bin"];

/// What a data folder holds: its scans, and the nominals its layout gives (OpenCalib's guess).
pub struct Dataset {
    pub scans: Vec<Scan>,
    pub guess: Option<Vec<(String, Pose)>>,
}

/// Every scan under `dir` and the nominals the layout gives, if any.
pub fn read_dir(dir: &Path) -> Result<Dataset, String> {
    let paths = dir.join("lidar_cloud_path.txt");
    if !paths.is_file() {
        return Ok(Dataset { scans: read_scans(dir)?, guess: None });
    }
    let text =
        |path: &Path| fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()));
    let label = paths.display().to_string();
    let devices = opencalib::read_paths(&text(&paths)?, &label).map_err(|e| e.to_string())?;
    let mut scans = Vec::new();
    for device in &devices {
        // The paths are relative to OpenCalib's tree; the files sit beside the list.
        let name = device.path.rsplit('/').next().unwrap_or(&device.path);
        let file = dir.join(name);
        let label = file.display().to_string();
        let bytes = fs::read(&file).map_err(|e| format!("{label}: {e}"))?;
        let parsed = parse_cloud(&bytes, &label).map_err(|e| e.to_string())?;
        scans.push(Scan {
            sensor: device.name.clone(),
            frame: "1".into(),
            points: parsed.cloud.points,
            source: Some(label),
        });
    }
    let guess = dir.join("initial_extrinsic.txt");
    let guess = if guess.is_file() {
        let file = guess.display().to_string();
        let poses = opencalib::read_guess(&text(&guess)?, &file).map_err(|e| e.to_string())?;
        Some(opencalib::nominals(&poses, &devices, &file).map_err(|e| e.to_string())?)
    } else {
        None
    };
    Ok(Dataset { scans, guess })
}

/// Every scan under `dir`, sensor by sensor, frames in natural order.
fn read_scans(dir: &Path) -> Result<Vec<Scan>, String> {
    let mut views = Vec::new();
    for (sensor, folder) in sensor_folders(dir)? {
        for (frame, file) in frame_files(&folder)? {
            let label = file.display().to_string();
            let bytes = fs::read(&file).map_err(|e| format!("{label}: {e}"))?;
            let parsed = parse_cloud(&bytes, &label).map_err(|e| e.to_string())?;
            views.push(Scan {
                sensor: sensor.clone(),
                frame,
                points: parsed.cloud.points,
                source: Some(label),
            });
        }
    }
    Ok(views)
}

/// `(name, path)` of the `sensor_*` folders in `dir`, naturally ordered.
fn sensor_folders(dir: &Path) -> Result<Vec<(String, PathBuf)>, String> {
    let mut folders = Vec::new();
    for (name, path) in entries(dir)? {
        if path.is_dir() && name.starts_with("sensor_") {
            folders.push((name, path));
        }
    }
    if folders.is_empty() {
        return Err(format!("{}: no sensor folders (sensor_1, sensor_2, ...)", dir.display()));
    }
    folders.sort_by(|a, b| natural(&a.0, &b.0));
    Ok(folders)
}

/// `(stem, path)` of the point-cloud files in `folder`, naturally ordered by stem.
fn frame_files(folder: &Path) -> Result<Vec<(String, PathBuf)>, String> {
    let mut files: Vec<(String, PathBuf)> = Vec::new();
    for (name, path) in entries(folder)? {
        let Some((stem, ext)) = name.rsplit_once('.') else { continue };
        if !path.is_file() || !EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()) {
            continue;
        }
        if let Some((_, other)) = files.iter().find(|(s, _)| s == stem) {
            let (a, b) = (other.display(), path.display());
            return Err(format!("{a} and {b}: two files for frame {stem}"));
        }
        files.push((stem.to_string(), path));
    }
    if files.is_empty() {
        return Err(format!("{}: no point-cloud frames (.pcd, .ply, .bin)", folder.display()));
    }
    files.sort_by(|a, b| natural(&a.0, &b.0));
    Ok(files)
}

/// `(file name, path)` of every entry in `dir`.
fn entries(dir: &Path) -> Result<Vec<(String, PathBuf)>, String> {
    let read = fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = Vec::new();
    for entry in read {
        let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
        out.push((entry.file_name().to_string_lossy().into_owned(), entry.path()));
    }
    Ok(out)
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
