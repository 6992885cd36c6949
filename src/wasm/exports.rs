//! `exportsOf(input)`: one result's exports made again for a renamed vehicle frame, by the
//! writers `calibrate` used for the result's own `exports` (`export::Exports`).

use serde::Deserialize;
use wasm_bindgen::prelude::*;

use super::{Roi, to_js};
use crate::export::{Exports, Target};

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct ExportsInput {
    parent: String,
    sensors: Vec<SensorInput>,
    roi: Roi,
    reconstruction: Option<TargetInput>,
}

#[derive(Deserialize)]
struct SensorInput {
    name: String,
    /// `T_parent_sensor`, row-major 4x4.
    extrinsic: Vec<f64>,
}

/// The reconstructed target, flat: `means` as x, y, z per component.
#[derive(Default, Deserialize)]
struct TargetInput {
    means: Vec<f64>,
    sigmas: Vec<f64>,
    priors: Vec<f64>,
}

/// A result's exports that name frames (`export::Exports` without `json`), for `input = {
/// parent, sensors: [{ name, extrinsic }], roi: { min, max }, reconstruction?: { means, sigmas,
/// priors } }`: a result's own fields, with the new parent.
#[wasm_bindgen(js_name = exportsOf)]
pub fn exports_of(input: JsValue) -> Result<JsValue, JsError> {
    let input: ExportsInput = serde_wasm_bindgen::from_value(input)
        .map_err(|e| JsError::new(&format!("invalid exportsOf input: {e}")))?;
    let sensors = (input.sensors.into_iter())
        .map(|s| {
            let pose = <[f64; 16]>::try_from(s.extrinsic.as_slice())
                .ok()
                .filter(|m| m.iter().all(|x| x.is_finite()))
                .map(|m| crate::se3::from_row_major(&m))
                .ok_or_else(|| {
                    JsError::new(&format!(
                        "exportsOf: {}: extrinsic is not 16 finite numbers",
                        s.name
                    ))
                })?;
            Ok((s.name, pose))
        })
        .collect::<Result<Vec<_>, JsError>>()?;
    let t = input.reconstruction.unwrap_or_default();
    let k = t.sigmas.len();
    if t.means.len() != 3 * k || t.priors.len() != k {
        return Err(JsError::new(&format!(
            "exportsOf: reconstruction has {} means values, {k} sigmas and {} priors (expected 3 \
             means values per sigma and one prior each)",
            t.means.len(),
            t.priors.len()
        )));
    }
    let target = Target { means: &t.means, sigmas: &t.sigmas, priors: &t.priors };
    let roi = crate::cloud::Aabb::new(input.roi.min, input.roi.max);
    to_js(&Exports::new(&input.parent, &sensors, &roi, target))
}
