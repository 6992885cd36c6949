//! `syntheticRig(options)`: a rig with known truth for the demo and the tests.

use js_sys::Float32Array;
use serde::Deserialize;
use wasm_bindgen::prelude::*;

use super::{RigOutput, RigView, Roi, XyzRpy, options_or_default, to_js};
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

/// A synthetic rig with known truth (a cube seen by several sensors whose nominal extrinsics
/// are wrong), in the shape `calibrate` takes, plus `truth` (true `T_vehicle_sensor`) and
/// `reference` (the first sensor).
#[wasm_bindgen(js_name = syntheticRig)]
pub fn synthetic_rig(options: JsValue) -> Result<JsValue, JsError> {
    let o: SyntheticInput = options_or_default(options, "syntheticRig")?;
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
    to_js(&RigOutput {
        views: rig
            .views
            .iter()
            .map(|v| RigView {
                sensor: v.sensor.clone(),
                frame: v.frame.clone(),
                points: Float32Array::from(v.points.as_flattened()),
                dropped: 0,
            })
            .collect(),
        nominal: rig.nominal.iter().map(|(n, p)| (n.clone(), XyzRpy::from(p))).collect(),
        truth: rig.truth.iter().map(|(n, p)| (n.clone(), XyzRpy::from(p))).collect(),
        roi: Roi { min: rig.roi.min, max: rig.roi.max },
        reference: rig.nominal.first().map(|(n, _)| n.clone()).unwrap_or_default(),
    })
}
