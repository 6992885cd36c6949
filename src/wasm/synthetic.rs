//! `syntheticRig(options)`: a rig with known truth for the demo and the tests.

use std::collections::BTreeMap;

use js_sys::Float32Array;
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::{Roi, XyzRpy, to_js};
use crate::se3::{Pose, xyz_rpy};
use crate::synth::{self, RigSpec};

#[derive(Deserialize, Default)]
#[serde(default, rename_all = "camelCase")]
struct SyntheticInput {
    sensors: Option<usize>,
    frames: Option<usize>,
    points_per_view: Option<usize>,
    noise: Option<f64>,
    partial: Option<bool>,
    seed: Option<u64>,
}

#[derive(Serialize)]
struct SyntheticViewOutput {
    sensor: String,
    frame: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
}

#[derive(Serialize)]
struct SyntheticOutput {
    views: Vec<SyntheticViewOutput>,
    nominal: BTreeMap<String, XyzRpy>,
    truth: BTreeMap<String, XyzRpy>,
    roi: Roi,
}

/// A synthetic rig with known truth (a cube seen by several sensors whose nominal extrinsics
/// are wrong), in the shape `calibrate` takes, plus `truth` (true `T_vehicle_sensor`).
#[wasm_bindgen(js_name = syntheticRig)]
pub fn synthetic_rig(options: JsValue) -> Result<JsValue, JsError> {
    let o: SyntheticInput = if options.is_undefined() || options.is_null() {
        SyntheticInput::default()
    } else {
        serde_wasm_bindgen::from_value(options)
            .map_err(|e| JsError::new(&format!("invalid syntheticRig options: {e}")))?
    };
    let d = RigSpec::default();
    let spec = RigSpec {
        sensors: o.sensors.unwrap_or(d.sensors).clamp(2, 16),
        frames: o.frames.unwrap_or(d.frames).clamp(1, 1000),
        points_per_view: o.points_per_view.unwrap_or(d.points_per_view).clamp(10, 1_000_000),
        noise: o.noise.filter(|n| n.is_finite() && *n >= 0.0).unwrap_or(d.noise),
        partial: o.partial.unwrap_or(d.partial),
        seed: o.seed.unwrap_or(d.seed),
        ..d
    };
    let rig = synth::generate(&spec);
    let pose_out = |p: &Pose| {
        let (xyz, rpy) = xyz_rpy(p);
        XyzRpy { xyz, rpy }
    };
    to_js(&SyntheticOutput {
        views: rig
            .views
            .iter()
            .map(|v| SyntheticViewOutput {
                sensor: v.sensor.clone(),
                frame: v.frame.clone(),
                points: Float32Array::from(v.points.as_flattened()),
            })
            .collect(),
        nominal: rig.nominal.iter().map(|(n, p)| (n.clone(), pose_out(p))).collect(),
        truth: rig.truth.iter().map(|(n, p)| (n.clone(), pose_out(p))).collect(),
        roi: Roi { min: rig.roi.min, max: rig.roi.max },
    })
}
