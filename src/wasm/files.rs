//! `parseCloud(bytes, fileName)`: a PCD, PLY or KITTI file in, flat points out;
//! `parseMesh(bytes, fileName)`: a CAD-model target's OBJ, PLY or STL in, its outline out;
//! `placeScans(paths)`: which file is which sensor and frame.

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

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct MeshOutput {
    /// Corner positions, flat x, y, z, ... (m), base centre at the origin (as placed).
    #[serde(with = "serde_wasm_bindgen::preserve")]
    vertices: Float32Array,
    /// Corner indices, three per triangle.
    #[serde(with = "serde_wasm_bindgen::preserve")]
    triangles: js_sys::Uint32Array,
    /// Extents along x, y, z (m) and the largest (the target's size).
    extents: [f64; 3],
    size: f64,
}

/// Parses a CAD-model target (`.obj`, `.ply` or `.stl` by `fileName`), centred as the
/// calibration uses it. Throws an `Error` naming the file, the place and the problem (no
/// faces, NaN vertices, a point cloud given as a mesh, ...).
#[wasm_bindgen(js_name = parseMesh)]
pub fn parse_mesh(bytes: &[u8], file_name: &str) -> Result<JsValue, JsError> {
    let target = crate::targets::Target::from_mesh_file(bytes, file_name)
        .map_err(|e| JsError::new(&e.to_string()))?;
    let crate::targets::Target::Mesh(m) = &target else { unreachable!("a mesh file gives a mesh") };
    let b = m.mesh.bounds();
    let vertices: Vec<f32> = m.mesh.vertices.iter().flatten().map(|&c| c as f32).collect();
    let triangles: Vec<u32> = m.mesh.triangles.iter().flatten().copied().collect();
    to_js(&MeshOutput {
        vertices: Float32Array::from(vertices.as_slice()),
        triangles: js_sys::Uint32Array::from(triangles.as_slice()),
        extents: std::array::from_fn(|i| b.max[i] - b.min[i]),
        size: target.size().unwrap_or(0.0),
    })
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct PlacedOutput {
    path: String,
    sensor: String,
    frame: String,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct DuplicateOutput {
    first: String,
    second: String,
    frame: String,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct LayoutOutput {
    scans: Vec<PlacedOutput>,
    /// How frames were paired where names did not pair them, in words.
    pairings: Vec<String>,
    nameless: Vec<String>,
    sensors_last: Option<String>,
    duplicates: Vec<DuplicateOutput>,
}

/// Which scan file is which sensor and frame (`gmmcalib::layout::place`, as the CLI reads a
/// folder): `paths` '/'-separated; returns `{scans: [{path, sensor, frame}], pairings,
/// nameless, sensorsLast, duplicates: [{first, second, frame}]}`.
#[wasm_bindgen(js_name = placeScans)]
pub fn place_scans(paths: Vec<String>) -> Result<JsValue, JsError> {
    let layout = crate::layout::place(&paths);
    to_js(&LayoutOutput {
        scans: layout
            .scans
            .into_iter()
            .map(|p| PlacedOutput { path: p.path, sensor: p.sensor, frame: p.frame })
            .collect(),
        pairings: layout.pairings.iter().map(ToString::to_string).collect(),
        nameless: layout.nameless,
        sensors_last: layout.sensors_last,
        duplicates: layout
            .duplicates
            .into_iter()
            .map(|(first, second, frame)| DuplicateOutput { first, second, frame })
            .collect(),
    })
}
