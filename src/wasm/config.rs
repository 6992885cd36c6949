//! `parseConfig(text, fileName)`: GMMCalib's `config.yaml` read by the library's one reader
//! (`io::config`), in the shape the page's rig panel takes.

use std::collections::BTreeMap;

use serde::Serialize;
use wasm_bindgen::prelude::*;

use super::{Roi, XyzRpy, to_js};
use crate::calib::InitialSigma;
use crate::io::config::Config;
use crate::target::Target;

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ConfigOutput {
    nominal: BTreeMap<String, XyzRpy>,
    roi: Option<Roi>,
    reference: Option<String>,
    method: Option<String>,
    components: Option<usize>,
    iterations: Option<usize>,
    /// The cube's edge (m), from `target_edge` or a cube `target`.
    edge: Option<f64>,
    /// The target in its short form (`cube:0.5`, `box:W,D,H`, `sphere:D`, `none`).
    target: Option<String>,
    initial_sigma: Option<SigmaOutput>,
}

/// The initial width as the page's settings hold it: a width (m), `"prior"` or `"bbox"`.
#[derive(Serialize)]
#[serde(untagged)]
enum SigmaOutput {
    Fixed(f64),
    Rule(&'static str),
}

/// Reads a GMMCalib config; throws an `Error` naming the file and the key.
#[wasm_bindgen(js_name = parseConfig)]
pub fn parse_config(text: &str, file_name: &str) -> Result<JsValue, JsError> {
    let c = Config::from_yaml(text, file_name).map_err(|e| JsError::new(&e.to_string()))?;
    let initial_sigma = c.initial_sigma.map(|s| match s {
        InitialSigma::Fixed(x) => SigmaOutput::Fixed(x),
        InitialSigma::TargetSize => SigmaOutput::Rule("prior"),
        InitialSigma::BoundingBox => SigmaOutput::Rule("bbox"),
    });
    to_js(&ConfigOutput {
        nominal: c
            .nominal
            .iter()
            .map(|n| (n.sensor.clone(), XyzRpy { xyz: n.xyz, rpy: n.rpy }))
            .collect(),
        roi: c.roi.map(|r| Roi { min: r.min, max: r.max }),
        reference: c.reference,
        method: c.method,
        components: c.components,
        iterations: c.iterations,
        edge: c.target.as_ref().and_then(|t| match t {
            Target::Cube { edge } => Some(*edge),
            _ => None,
        }),
        target: c.target.as_ref().map(short_form),
        initial_sigma,
    })
}

/// The short form `Target` parses from.
fn short_form(t: &Target) -> String {
    match t {
        Target::Cube { edge } => format!("cube:{edge}"),
        Target::Box { size: [w, d, h] } => format!("box:{w},{d},{h}"),
        Target::Sphere { diameter } => format!("sphere:{diameter}"),
        Target::None => "none".into(),
    }
}
