//! `parseCloud(bytes, fileName)`: a PCD, PLY or KITTI file in, flat points out.

use js_sys::Float32Array;
use serde::Serialize;
use wasm_bindgen::prelude::*;

use super::to_js;

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ParsedOutput {
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    intensity: JsValue,
    count: usize,
    dropped: usize,
    format: String,
    width: usize,
    height: usize,
    viewpoint_applied: bool,
}

/// Parses a PCD, PLY or KITTI `.bin` file (chosen by `fileName`'s extension). Invalid points
/// (NaN, inf, exact zero) are dropped and counted. Throws an `Error` naming the file, the
/// problem and the line or byte offset.
#[wasm_bindgen(js_name = parseCloud)]
pub fn parse_cloud(bytes: &[u8], file_name: &str) -> Result<JsValue, JsError> {
    let parsed =
        crate::io::parse_cloud(bytes, file_name).map_err(|e| JsError::new(&e.to_string()))?;
    let cloud = &parsed.cloud;
    to_js(&ParsedOutput {
        points: Float32Array::from(cloud.points.as_flattened()),
        intensity: cloud
            .intensity
            .as_ref()
            .map_or(JsValue::UNDEFINED, |i| Float32Array::from(i.as_slice()).into()),
        count: cloud.len(),
        dropped: parsed.dropped,
        format: parsed.format.to_string(),
        width: parsed.width,
        height: parsed.height,
        viewpoint_applied: parsed.viewpoint_applied,
    })
}
