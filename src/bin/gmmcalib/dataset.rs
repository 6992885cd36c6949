//! GMMCalib's data layout: `DIR/sensor_N/<frame>.{pcd,ply,bin}`, read into calibration scans.
//! Sensors and frames are ordered naturally (`sensor_2` before `sensor_10`); a view's sensor is
//! its folder name and its frame the file stem, so frames pair across sensors by stem.

use std::cmp::Ordering;
use std::fs;
use std::path::{Path, PathBuf};

use gmmcalib::calib::Scan;
use gmmcalib::io::parse_cloud;

const EXTENSIONS: [&str; 3] = ["pcd", "ply", "bin"];

/// Every scan under `dir`, sensor by sensor, frames in natural order.
pub fn read_scans(dir: &Path) -> Result<Vec<Scan>, String> {
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
