//! `gmmcalib simulate`: the digital twin written in GMMCalib's layout, plus the truth.
//!
//! ```text
//! DIR/config.yaml             nominal (miscalibrated) extrinsics and the preset's ROI
//! DIR/data/sensor_N/F.pcd     binary PCD, organized WIDTH columns x HEIGHT channels, misses 0
//! DIR/truth.json              true extrinsics, nominals, expected corrections (row-major 4x4)
//! DIR/target.obj              the CAD-model target, for the scenes that hold one
//! ```

use std::fs;
use std::path::Path;

use gmmcalib::export::{
    ConfigTransform, gmmcalib_config, write_obj, write_pcd_binary, write_pcd_binary_organized,
};
use gmmcalib::se3::{Pose, to_row_major};
use gmmcalib::targets::Target;
use serde::Serialize;

use crate::args::{SimulateArgs, TwinArgs};
use crate::layout::TwinFiles;

type Matrix = [[f64; 4]; 4];

#[derive(Serialize)]
struct Truth<'a> {
    preset: &'a str,
    seed: u64,
    frames: usize,
    /// Miscalibration bounds: rad per rotation axis, m per translation axis.
    max_angle: f64,
    /// Yaw's bound (rad) when it differs from `max_angle`.
    #[serde(skip_serializing_if = "Option::is_none")]
    max_yaw: Option<f64>,
    max_translation: f64,
    reference: &'a str,
    sensors: Vec<SensorTruth<'a>>,
}

#[derive(Serialize)]
struct SensorTruth<'a> {
    name: &'a str,
    folder: &'a str,
    /// True `T_vehicle_sensor`.
    truth: Matrix,
    /// Miscalibrated `T_vehicle_sensor` in config.yaml.
    nominal: Matrix,
    /// `truth * nominal^-1`: maps nominally pre-aligned points onto the truth.
    correction: Matrix,
}

pub fn run(a: &SimulateArgs) -> Result<(), String> {
    let files = TwinFiles::new(&a.twin, a.twin.seed)?;
    write(&files, &a.twin, &a.out)?;
    let n = files.folders.len();
    println!("wrote {} frames of {n} sensors to {}", a.twin.frames, a.out.display());
    Ok(())
}

/// Writes `twin` under `dir` (created if needed).
pub fn write(files: &TwinFiles, args: &TwinArgs, dir: &Path) -> Result<(), String> {
    let fail = |path: &Path, e: std::io::Error| format!("{}: {e}", path.display());
    let twin = &files.twin;
    for view in &twin.scans {
        let folder = dir.join("data").join(&files.folders[files.sensor_of(&view.sensor)]);
        fs::create_dir_all(&folder).map_err(|e| fail(&folder, e))?;
        let file = folder.join(format!("{}.pcd", view.frame));
        // A flat cloud is still a valid scan, should the shape not match.
        let bytes = write_pcd_binary_organized(&view.cloud, view.width, view.height)
            .unwrap_or_else(|| write_pcd_binary(&view.cloud));
        fs::write(&file, bytes).map_err(|e| fail(&file, e))?;
    }
    // The scene's target, so that the folder calibrates as it is: a mesh beside the config.
    let mut yaml = config_yaml(files);
    match files.model.target() {
        Target::Mesh(m) => {
            let obj = dir.join("target.obj");
            fs::write(&obj, write_obj(&m.mesh)).map_err(|e| fail(&obj, e))?;
            yaml += "target: mesh:target.obj\n";
        }
        Target::None => yaml += "target: none\n",
        _ => {}
    }
    let config = dir.join("config.yaml");
    fs::write(&config, yaml).map_err(|e| fail(&config, e))?;
    let truth = Truth {
        preset: &args.preset,
        seed: args.seed,
        frames: args.frames,
        max_angle: args.max_angle_deg.to_radians(),
        max_yaw: args.max_yaw_deg.map(f64::to_radians),
        max_translation: args.max_translation,
        reference: &files.folders[0],
        sensors: (0..files.folders.len())
            .map(|i| SensorTruth {
                name: &twin.truth[i].0,
                folder: &files.folders[i],
                truth: matrix(&twin.truth[i].1),
                nominal: matrix(&twin.nominal[i].1),
                correction: matrix(&twin.correction(i)),
            })
            .collect(),
    };
    let json = gmmcalib::export::json(&truth).map_err(|e| format!("JSON: {e}"))?;
    let path = dir.join("truth.json");
    fs::write(&path, json).map_err(|e| fail(&path, e))
}

/// GMMCalib's config (the library's writer): the nominals as the numbers the layout reads back,
/// the first sensor named the reference, the preset's ROI.
fn config_yaml(files: &TwinFiles) -> String {
    let twin = &files.twin;
    let numbers = files.nominal_numbers.iter().zip(&files.folders);
    let transforms: Vec<ConfigTransform> = twin
        .truth
        .iter()
        .zip(numbers)
        .map(|((name, _), ((xyz, rpy), folder))| ConfigTransform {
            sensor: folder.clone(),
            xyz: *xyz,
            rpy: *rpy,
            note: name.clone(),
        })
        .collect();
    let comment = "gmmcalib simulate: the first sensor is the reference (true mount); the others are\n\
                   miscalibrated. The truth is in truth.json.";
    gmmcalib_config(comment, &transforms, Some(&files.folders[0]), &twin.roi)
}

fn matrix(pose: &Pose) -> Matrix {
    let m = to_row_major(pose);
    std::array::from_fn(|r| std::array::from_fn(|c| m[4 * r + c]))
}
