//! The data folders `calibrate` reads: the scan files in it and its folders, placed by
//! [`crate::layout`] (GMMCalib's `sensor_N/<frame>.pcd`, a folder per sensor under any name,
//! loose `<sensor>_<frame>` files, as the page takes them); and OpenCalib's,
//! `lidar_cloud_path.txt` naming each device's file (one frame per device) beside its guess,
//! `initial_extrinsic.txt`.

use super::{EntryKind, Host, join, read_text};
use crate::calib::Scan;
use crate::io::{opencalib, parse_cloud};
use crate::layout::{self, LayoutError};
use crate::se3::Pose;

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

/// Every scan under `dir` (its files and its folders' files), placed by [`layout::place`],
/// with how frames were paired said on stderr.
fn read_scans(host: &mut dyn Host, dir: &str) -> Result<Vec<Scan>, String> {
    let mut names = host.list(dir).map_err(|e| format!("{dir}: {e}"))?;
    names.sort();
    let mut paths = Vec::new();
    for name in names {
        let path = join(dir, &name);
        match host.kind(&path) {
            EntryKind::File if layout::is_scan(&name) => paths.push(name),
            EntryKind::Dir => {
                let mut inside = host.list(&path).map_err(|e| format!("{path}: {e}"))?;
                inside.retain(|n| {
                    layout::is_scan(n) && host.kind(&join(&path, n)) == EntryKind::File
                });
                // GMMCalib's sensor folders must hold scans; other folders may hold anything.
                if inside.is_empty() && name.starts_with("sensor_") {
                    return Err(format!("{path}: no point-cloud frames (.pcd, .ply, .bin)"));
                }
                paths.extend(inside.into_iter().map(|n| format!("{name}/{n}")));
            }
            _ => {}
        }
    }
    let placed = layout::place(&paths);
    // The layout names paths relative to the data folder; the user named the folder.
    if let Some(problem) = placed.problem() {
        return Err(match problem {
            LayoutError::Empty => format!("{dir}: {problem}"),
            LayoutError::NoSensor { path } => {
                LayoutError::NoSensor { path: join(dir, &path) }.to_string()
            }
            LayoutError::SameFrame { first, second, frame } => LayoutError::SameFrame {
                first: join(dir, &first),
                second: join(dir, &second),
                frame,
            }
            .to_string(),
        });
    }
    for p in &placed.pairings {
        host.err(&format!("gmmcalib: {p}\n"));
    }
    let mut scans = Vec::with_capacity(placed.scans.len());
    for p in placed.scans {
        scans.push(scan(host, p.sensor, p.frame, join(dir, &p.path))?);
    }
    Ok(scans)
}
