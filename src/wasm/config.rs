//! The rig descriptions the page reads, in the shape its rig panel takes: `parseConfig(text,
//! fileName)`, GMMCalib's `config.yaml` by the library's one reader (`config`); and
//! `parseOpenCalib(...)`, OpenCalib's `lidar_cloud_path.txt` and `initial_extrinsic.txt`
//! (`io::opencalib`).

use std::collections::BTreeMap;

use serde::Serialize;
use wasm_bindgen::prelude::*;

use super::{Roi, XyzRpy, to_js};
use crate::calib::SettingsInput;
use crate::config::Config;
use crate::io::opencalib;

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ConfigOutput {
    nominal: BTreeMap<String, XyzRpy>,
    roi: Option<Roi>,
    reference: Option<String>,
    /// The settings it sets, under the keys `calibrate` takes (a cube's `target_edge` as its
    /// `target`).
    #[serde(flatten)]
    settings: SettingsInput,
}

/// Reads a GMMCalib config; throws an `Error` naming the file and the key.
#[wasm_bindgen(js_name = parseConfig)]
pub fn parse_config(text: &str, file_name: &str) -> Result<JsValue, JsError> {
    let c = Config::from_yaml(text, file_name).map_err(|e| JsError::new(&e.to_string()))?;
    let settings = SettingsInput { target: c.settings.target_choice(), ..c.settings };
    to_js(&ConfigOutput {
        nominal: c
            .nominal
            .iter()
            .map(|n| (n.sensor.clone(), XyzRpy { xyz: n.xyz, rpy: n.rpy }))
            .collect(),
        roi: c.roi.map(|r| Roi { min: r.min, max: r.max }),
        reference: c.reference,
        settings,
    })
}

/// The settings every unset key means (`calibrate`'s defaults), for the page's controls.
#[wasm_bindgen]
pub fn defaults() -> Result<JsValue, JsError> {
    to_js(&SettingsInput::defaults())
}

#[derive(Serialize)]
struct DeviceOutput {
    /// The sensor name the scans of this device take.
    name: String,
    /// The file's name, without OpenCalib's folders: the page matches dropped files by it.
    file: String,
}

#[derive(Serialize)]
struct OpenCalibOutput {
    devices: Vec<DeviceOutput>,
    /// Device 0, OpenCalib's reference.
    reference: Option<String>,
    /// Each device's guess, when `initial_extrinsic.txt` was given.
    nominal: Option<BTreeMap<String, XyzRpy>>,
}

/// Reads OpenCalib's `lidar_cloud_path.txt` (which file is which device) and, when given, its
/// `initial_extrinsic.txt` (each device's guess); throws an `Error` naming the file and line.
#[wasm_bindgen(js_name = parseOpenCalib)]
pub fn parse_open_calib(
    paths: &str,
    paths_name: &str,
    guess: Option<String>,
    guess_name: Option<String>,
) -> Result<JsValue, JsError> {
    let error = |e: crate::io::IoError| JsError::new(&e.to_string());
    let devices = opencalib::read_paths(paths, paths_name).map_err(error)?;
    let nominal = match guess {
        Some(text) => {
            let name = guess_name.as_deref().unwrap_or("initial_extrinsic.txt");
            let poses = opencalib::read_guess(&text, name).map_err(error)?;
            let named = opencalib::nominals(&poses, &devices, name).map_err(error)?;
            Some(named.iter().map(|(n, pose)| (n.clone(), XyzRpy::from(pose))).collect())
        }
        None => None,
    };
    to_js(&OpenCalibOutput {
        reference: devices.iter().find(|d| d.id == 0).map(|d| d.name.clone()),
        devices: devices
            .iter()
            .map(|d| DeviceOutput {
                name: d.name.clone(),
                file: d.path.rsplit('/').next().unwrap_or(&d.path).to_string(),
            })
            .collect(),
        nominal,
    })
}
