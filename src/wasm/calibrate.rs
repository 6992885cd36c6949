//! `calibrate(input, onProgress?)`: a rig in, the calibration out (README, "Wasm API").

use std::collections::BTreeMap;

use js_sys::{Float32Array, Function, Reflect};
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::{Roi, XyzRpy, to_js};
use crate::calib::{self, Calibration, InitialSigma, Rig, View};
use crate::cloud::Aabb;
use crate::jrmpc::{Control, Prior};
use crate::report::Report;
use crate::se3::{Pose, pose_from_xyz_rpy, to_row_major};

#[derive(Deserialize)]
struct ViewInput {
    sensor: String,
    frame: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum TargetInput {
    Cube { edge: f64 },
    Sphere { radius: f64 },
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct CalibrateInput {
    views: Vec<ViewInput>,
    nominal: BTreeMap<String, XyzRpy>,
    roi: Roi,
    reference: Option<String>,
    method: Option<String>,
    target: Option<TargetInput>,
    components: Option<usize>,
    iterations: Option<usize>,
    tolerance: Option<f64>,
    /// Initial component width (m), or "prior" / "bbox".
    initial_sigma: Option<InitialSigmaInput>,
    seed: Option<u64>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum InitialSigmaInput {
    Fixed(f64),
    Rule(String),
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ProgressOutput<'a> {
    /// "jrmpc" (EM's iterations) or "framePairs" (pairs registered).
    stage: &'static str,
    iteration: usize,
    max_iterations: usize,
    mean_sigma: f64,
    max_change: f64,
    /// Current correction per sensor (row-major 4x4), in result order.
    corrections: Vec<[f64; 16]>,
    sensors: &'a [String],
}

fn pose_of(name: &str, p: &XyzRpy) -> Result<Pose, JsError> {
    if p.xyz.iter().chain(&p.rpy).all(|v| v.is_finite()) {
        Ok(pose_from_xyz_rpy(p.xyz, p.rpy))
    } else {
        Err(JsError::new(&format!("nominal extrinsic of sensor '{name}' is not finite")))
    }
}

/// Calibrates a rig. `input` and the result are documented in the README ("Wasm API").
/// `onProgress(progress)` runs after every EM iteration; returning `false` cancels the run.
#[wasm_bindgen]
pub fn calibrate(input: JsValue, on_progress: Option<Function>) -> Result<JsValue, JsError> {
    let (rig, settings) = rig_and_settings(input)?;
    let mut sink = ProgressSink::new(on_progress, calib::sensor_names(&rig));
    let result = calib::calibrate(&rig, &settings, |p| sink.send(p));
    sink.error()?;
    output(&result.map_err(|e| JsError::new(&e.to_string()))?)
}

/// The rig and the settings `input` describes.
pub(super) fn rig_and_settings(input: JsValue) -> Result<(Rig, calib::Settings), JsError> {
    let input: CalibrateInput = serde_wasm_bindgen::from_value(input)
        .map_err(|e| JsError::new(&format!("invalid calibrate input: {e}")))?;
    let mut views = Vec::with_capacity(input.views.len());
    for v in &input.views {
        let flat = v.points.to_vec();
        let cloud = crate::Cloud::from_flat(&flat).ok_or_else(|| {
            JsError::new(&format!(
                "view {}/{}: points length {} is not a multiple of 3",
                v.sensor,
                v.frame,
                flat.len()
            ))
        })?;
        views.push(View { sensor: v.sensor.clone(), frame: v.frame.clone(), points: cloud.points });
    }
    let nominal = input
        .nominal
        .iter()
        .map(|(name, p)| Ok((name.clone(), pose_of(name, p)?)))
        .collect::<Result<Vec<_>, JsError>>()?;
    let rig = Rig {
        views,
        nominal,
        roi: Aabb::new(input.roi.min, input.roi.max),
        reference: input.reference,
    };
    let mut settings = calib::Settings::default();
    if let Some(method) = &input.method {
        settings.method =
            method.parse().map_err(|e: calib::CalibError| JsError::new(&e.to_string()))?;
    }
    if let Some(target) = input.target {
        settings.prior = match target {
            TargetInput::Cube { edge } if edge.is_finite() && edge > 0.0 => Prior::Cube { edge },
            TargetInput::Sphere { radius } if radius.is_finite() && radius > 0.0 => {
                Prior::Sphere { radius }
            }
            _ => return Err(JsError::new("target size must be a positive number")),
        };
    }
    settings.components = input.components.unwrap_or(settings.components);
    settings.jrmpc.max_iterations = input.iterations.unwrap_or(settings.jrmpc.max_iterations);
    settings.jrmpc.tolerance = input.tolerance.unwrap_or(settings.jrmpc.tolerance);
    settings.seed = input.seed.unwrap_or(settings.seed);
    settings.initial_sigma = match input.initial_sigma {
        None => settings.initial_sigma,
        Some(InitialSigmaInput::Fixed(s)) if s.is_finite() && s > 0.0 => InitialSigma::Fixed(s),
        Some(InitialSigmaInput::Rule(r)) if r == "prior" => InitialSigma::PriorSize,
        Some(InitialSigmaInput::Rule(r)) if r == "bbox" => InitialSigma::BoundingBox,
        Some(_) => {
            return Err(JsError::new("initialSigma must be a positive number, 'prior' or 'bbox'"));
        }
    };
    Ok((rig, settings))
}

/// Passes the library's progress to the JS callback, if any: `false` from it cancels; an
/// exception cancels too, and is reported by [`ProgressSink::error`].
pub(super) struct ProgressSink {
    callback: Option<Function>,
    sensors: Vec<String>,
    error: Option<JsValue>,
}

impl ProgressSink {
    pub(super) fn new(callback: Option<Function>, sensors: Vec<String>) -> Self {
        Self { callback, sensors, error: None }
    }

    pub(super) fn send(&mut self, p: &calib::Progress) -> Control {
        let Some(f) = &self.callback else { return Control::Continue };
        let answer = Self::value(&self.sensors, p)
            .map_err(JsValue::from)
            .and_then(|v| f.call1(&JsValue::NULL, &v));
        match answer {
            Ok(v) if v == JsValue::FALSE => Control::Stop,
            Ok(_) => Control::Continue,
            Err(e) => {
                self.error = Some(e);
                Control::Stop
            }
        }
    }

    /// `p` as JS sees it.
    pub(super) fn value(sensors: &[String], p: &calib::Progress) -> Result<JsValue, JsError> {
        to_js(&ProgressOutput {
            stage: p.stage.name(),
            iteration: p.iteration,
            max_iterations: p.max_iterations,
            mean_sigma: p.mean_sigma,
            max_change: p.max_change,
            corrections: p.corrections.iter().map(to_row_major).collect(),
            sensors,
        })
    }

    /// What the callback threw, if it did.
    pub(super) fn error(&mut self) -> Result<(), JsError> {
        match self.error.take() {
            None => Ok(()),
            Some(e) => {
                let message =
                    e.as_string().or_else(|| js_sys::Error::from(e).message().as_string());
                Err(JsError::new(&format!("onProgress threw: {}", message.unwrap_or_default())))
            }
        }
    }
}

/// The library's [`Report`], with the target's bulk arrays as `Float32Array`s for transfer.
pub(super) fn output(c: &Calibration) -> Result<JsValue, JsError> {
    let report = Report::from(c);
    let value = to_js(&report)?;
    let t = &report.target;
    let target = Reflect::get(&value, &"target".into()).map_err(|_| internal())?;
    for (key, values) in [("means", &t.means), ("sigmas", &t.sigmas), ("priors", &t.priors)] {
        let v: Vec<f32> = values.iter().map(|&x| x as f32).collect();
        Reflect::set(&target, &key.into(), &Float32Array::from(v.as_slice()))
            .map_err(|_| internal())?;
    }
    Ok(value)
}

fn internal() -> JsError {
    JsError::new("internal: cannot set the target arrays of the result")
}
