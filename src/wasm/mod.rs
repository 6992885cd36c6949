//! The JavaScript surface (wasm-bindgen). Converts JS values to the library's types and back;
//! no algorithm and no control flow lives here. Bulk data crosses as flat typed arrays (`x, y,
//! z, x, y, z, ...`). Every failure becomes a JS `Error` with a message; nothing here may
//! panic, since a panic aborts the whole wasm instance. One file per exported job, as in
//! `www/src/calibrate/worker.js`.

mod calibrate;
mod command;
mod config;
mod drift;
mod exports;
mod files;
mod recording;
mod session;
mod simulate;

use std::collections::BTreeMap;

use js_sys::Float32Array;
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use crate::se3::{Pose, xyz_rpy};

pub use calibrate::{calibrate, methods};
pub use command::run_command;
pub use config::{parse_config, parse_open_calib};
pub use drift::compare_calibrations;
pub use exports::exports_of;
pub use files::{parse_cloud, parse_mesh};
pub use recording::RecordingFile;
pub use session::{CalibrationSession, JrmpcShard, align_global, align_pairs};
pub use simulate::simulate_rig;

/// A pose as JS sees it: translation (m) and roll, pitch, yaw (rad).
#[derive(Serialize, Deserialize)]
struct XyzRpy {
    xyz: [f64; 3],
    rpy: [f64; 3],
}

impl From<&Pose> for XyzRpy {
    fn from(pose: &Pose) -> Self {
        let (xyz, rpy) = xyz_rpy(pose);
        Self { xyz, rpy }
    }
}

/// An axis-aligned box (m), bounds inclusive.
#[derive(Serialize, Deserialize)]
struct Roi {
    min: [f64; 3],
    max: [f64; 3],
}

/// One scan of a generated rig, in the sensor frame.
#[derive(Serialize)]
struct RigScan {
    sensor: String,
    frame: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
    /// Missed beams (exact-zero returns) left out, as `parseCloud` would.
    dropped: usize,
}

/// A generated rig in the shape `calibrate` takes, plus `truth` (true `T_vehicle_sensor`).
#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct RigOutput {
    scans: Vec<RigScan>,
    nominal: BTreeMap<String, XyzRpy>,
    truth: BTreeMap<String, XyzRpy>,
    roi: Roi,
    reference: String,
    /// The scene's target in `Target`'s short form (`cube:0.5`, `none`, `mesh:target.obj`),
    /// and for a CAD model its OBJ text.
    target: String,
    target_obj: Option<String>,
}

#[wasm_bindgen(start)]
fn start() {
    // Diagnostics only: errors are returned as values, so a panic here is a bug.
    std::panic::set_hook(Box::new(|info| web_sys::console::error_1(&info.to_string().into())));
}

/// Optional options of the exported function `name`: defaults when `undefined` or `null`.
fn options_or_default<T: Default + serde::de::DeserializeOwned>(
    options: JsValue,
    name: &str,
) -> Result<T, JsError> {
    if options.is_undefined() || options.is_null() {
        return Ok(T::default());
    }
    serde_wasm_bindgen::from_value(options)
        .map_err(|e| JsError::new(&format!("invalid {name} options: {e}")))
}

/// JSON-compatible conversion: plain objects (not Maps), `null` for missing values.
fn to_js<T: Serialize>(value: &T) -> Result<JsValue, JsError> {
    value
        .serialize(&serde_wasm_bindgen::Serializer::json_compatible())
        .map_err(|e| JsError::new(&format!("internal: cannot convert result: {e}")))
}
