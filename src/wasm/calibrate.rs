//! `calibrate(input, onProgress?)`: a rig in, the calibration out (docs/api.md); `methods()`:
//! the methods the library offers, for the page's picker.

use std::collections::BTreeMap;

use js_sys::{Array, Float32Array, Function, Reflect};
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::{Roi, XyzRpy, to_js};
use crate::calib::{self, Calibration, Method, MethodOutcome, Rig, Scan, SettingsInput};
use crate::cloud::Aabb;
use crate::export::Exports;
use crate::jrmpc::Control;
use crate::report::Report;
use crate::se3::{Pose, pose_from_xyz_rpy, to_row_major};
use crate::targets::Target;

#[derive(Deserialize)]
struct ScanInput {
    sensor: String,
    frame: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    points: Float32Array,
    /// The file (or message) it came from, for messages.
    source: Option<String>,
}

/// A CAD-model target's file: its name (the extension picks the reader) and bytes.
#[derive(Deserialize)]
struct MeshInput {
    name: String,
    #[serde(with = "serde_wasm_bindgen::preserve")]
    bytes: js_sys::Uint8Array,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
pub(super) struct CalibrateInput {
    scans: Vec<ScanInput>,
    nominal: BTreeMap<String, XyzRpy>,
    /// Absent: around the targets found where the clouds overlap, else that overlap.
    roi: Option<Roi>,
    reference: Option<String>,
    /// The vehicle frame's name, the parent of every extrinsic in the exports (default
    /// `vehicle`).
    parent: Option<String>,
    /// The file of a `mesh` target.
    target_mesh: Option<MeshInput>,
    /// The settings, under the keys every door shares.
    #[serde(flatten)]
    settings: SettingsInput,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ProgressOutput<'a> {
    /// The method this progress is of.
    method: &'static str,
    /// "global" (sensors aligned), "views" (the views prepared), "jrmpc" or "cad" (EM's
    /// iterations), "framePairs" (pairs registered) or "finish" (the result made).
    stage: &'static str,
    /// The stages the method goes through, in order (`Stages::plan`).
    stages: Vec<&'static str>,
    iteration: usize,
    max_iterations: usize,
    mean_sigma: f64,
    max_change: f64,
    /// Current correction per sensor (row-major 4x4), in result order.
    corrections: Vec<[f64; 16]>,
    sensors: &'a [String],
}

#[derive(Serialize)]
struct MethodInfo {
    name: &'static str,
    /// What it does, in a few words.
    label: &'static str,
    /// Runs JRMPC (and reconstructs the target).
    jrmpc: bool,
    /// Registers frame pairs by ICP.
    pairs: bool,
    /// Aligns globally first unless told otherwise (`alignGlobally` absent).
    global: bool,
}

/// The methods `calibrate` takes (besides `all`, which compares them), with a label and the
/// stages each runs.
#[wasm_bindgen]
pub fn methods() -> Result<JsValue, JsError> {
    let list: Vec<MethodInfo> = Method::ALL
        .iter()
        .map(|&method| {
            let stages = calib::Stages::of(method, &calib::Settings::default());
            MethodInfo {
                name: method.name(),
                label: method.label(),
                jrmpc: stages.jrmpc,
                pairs: stages.pairs.is_some(),
                global: stages.global.is_some(),
            }
        })
        .collect();
    to_js(&list)
}

fn pose_of(name: &str, p: &XyzRpy) -> Result<Pose, JsError> {
    if p.xyz.iter().chain(&p.rpy).all(|v| v.is_finite()) {
        Ok(pose_from_xyz_rpy(p.xyz, p.rpy))
    } else {
        Err(JsError::new(&format!("nominal extrinsic of sensor '{name}' is not finite")))
    }
}

/// Calibrates a rig by one method, or by every method when `input.method` is `'all'` (an
/// array of results, with `{method, error}` for a method that failed). `onProgress(progress)`
/// runs after every EM iteration and frame pair; returning `false` cancels the run.
#[wasm_bindgen]
pub fn calibrate(input: JsValue, on_progress: Option<Function>) -> Result<JsValue, JsError> {
    let (rig, settings, methods, parent) = rig_and_settings(input)?;
    let sensors = rig.sensors();
    let mut run = calib::Run::new(std::borrow::Cow::Owned(rig), &settings, &methods);
    let mut sink = ProgressSink::new(on_progress, ProgressShape::new(sensors, &run));
    run.drive(1, &mut |method, p| sink.send(method, p));
    sink.error()?;
    outcomes(run.into_outcomes(), methods.len() > 1, &parent)
}

/// The result of a run's `outcomes`: one report (or its error), or when `compared` an array of
/// every method's report or `{method, error}`; each report with its exports, `parent` naming
/// the vehicle frame.
pub(super) fn outcomes(
    outcomes: Vec<MethodOutcome>,
    compared: bool,
    parent: &str,
) -> Result<JsValue, JsError> {
    if !compared {
        let (_, outcome) = outcomes.into_iter().next().ok_or_else(internal)?;
        return output(&outcome.map_err(|e| JsError::new(&e.to_string()))?, parent);
    }
    let array = Array::new();
    for (method, outcome) in outcomes {
        let value = match outcome {
            Ok(c) => output(&c, parent)?,
            Err(e) => {
                let failed = js_sys::Object::new();
                Reflect::set(&failed, &"method".into(), &method.name().into())
                    .map_err(|_| internal())?;
                Reflect::set(&failed, &"error".into(), &e.to_string().into())
                    .map_err(|_| internal())?;
                failed.into()
            }
        };
        array.push(&value);
    }
    Ok(array.into())
}

/// The first settings key of `input` that does not read, as `key: problem`: serde's error of
/// a flattened field names no key.
fn settings_key_error(input: &JsValue) -> Option<String> {
    let object = input.dyn_ref::<js_sys::Object>()?;
    js_sys::Object::entries(object).iter().find_map(|entry| {
        let entry = Array::from(&entry);
        let (key, value) = (entry.get(0), entry.get(1));
        let one = js_sys::Object::new();
        Reflect::set(&one, &key, &value).ok()?;
        let error = serde_wasm_bindgen::from_value::<SettingsInput>(one.into()).err()?;
        // Its text is a JS error's: "Error: ...".
        let problem = error.to_string();
        let problem = problem.strip_prefix("Error: ").unwrap_or(&problem).to_string();
        Some(format!("{}: {problem}", key.as_string().unwrap_or_default()))
    })
}

/// The rig, the settings, the methods and the vehicle frame's name `input` describes.
pub(super) fn rig_and_settings(
    input: JsValue,
) -> Result<(Rig, calib::Settings, Vec<Method>, String), JsError> {
    let input: CalibrateInput = serde_wasm_bindgen::from_value(input.clone()).map_err(|e| {
        let problem = settings_key_error(&input).unwrap_or_else(|| e.to_string());
        JsError::new(&format!("invalid calibrate input: {problem}"))
    })?;
    let mut scans = Vec::with_capacity(input.scans.len());
    for v in &input.scans {
        let flat = v.points.to_vec();
        let cloud = crate::Cloud::from_flat(&flat).ok_or_else(|| {
            JsError::new(&format!(
                "scan {}/{}: points length {} is not a multiple of 3",
                v.sensor,
                v.frame,
                flat.len()
            ))
        })?;
        scans.push(Scan {
            sensor: v.sensor.clone(),
            frame: v.frame.clone(),
            points: cloud.points,
            source: v.source.clone(),
        });
    }
    let nominal = input
        .nominal
        .iter()
        .map(|(name, p)| Ok((name.clone(), pose_of(name, p)?)))
        .collect::<Result<Vec<_>, JsError>>()?;
    let rig = Rig {
        scans,
        nominal,
        roi: input.roi.map(|roi| Aabb::new(roi.min, roi.max)),
        reference: input.reference,
    };
    let error = |e: String| JsError::new(&e);
    let mut input_settings = input.settings;
    input_settings
        .resolve_mesh(|_| {
            let MeshInput { name, bytes } =
                input.target_mesh.as_ref().ok_or("a mesh target needs its file in targetMesh")?;
            Target::from_mesh_file(&bytes.to_vec(), name).map_err(|e| e.to_string())
        })
        .map_err(error)?;
    let mut settings = calib::Settings::default();
    let methods = input_settings.apply(&mut settings).map_err(error)?;
    let parent = input.parent.unwrap_or_else(|| "vehicle".into());
    Ok((rig, settings, methods, parent))
}

/// What JS sees of the library's progress: the sensors' names and each method's plan.
#[derive(Clone)]
pub(super) struct ProgressShape {
    sensors: Vec<String>,
    /// Each method's plan, by its stages' names.
    plans: Vec<(Method, Vec<&'static str>)>,
}

impl ProgressShape {
    pub(super) fn new(sensors: Vec<String>, run: &calib::Run) -> Self {
        let plans = (run.methods().iter().enumerate())
            .map(|(i, &m)| (m, run.plan(i).iter().map(calib::Stage::name).collect()))
            .collect();
        Self { sensors, plans }
    }

    /// `p` of `method` as JS sees it.
    pub(super) fn value(&self, method: Method, p: &calib::Progress) -> Result<JsValue, JsError> {
        let plan = self.plans.iter().find(|(m, _)| *m == method).map(|(_, plan)| plan);
        to_js(&ProgressOutput {
            method: method.name(),
            stage: p.stage.name(),
            stages: plan.cloned().unwrap_or_default(),
            iteration: p.iteration,
            max_iterations: p.max_iterations,
            mean_sigma: p.mean_sigma,
            max_change: p.max_change,
            corrections: p.corrections.iter().map(to_row_major).collect(),
            sensors: &self.sensors,
        })
    }
}

/// Passes the library's progress to the JS callback, if any: `false` from it cancels; an
/// exception cancels too, and is reported by [`ProgressSink::error`].
pub(super) struct ProgressSink {
    callback: Option<Function>,
    shape: ProgressShape,
    error: Option<JsValue>,
}

impl ProgressSink {
    pub(super) fn new(callback: Option<Function>, shape: ProgressShape) -> Self {
        Self { callback, shape, error: None }
    }

    pub(super) fn send(&mut self, method: Method, p: &calib::Progress) -> Control {
        let Some(f) = &self.callback else { return Control::Continue };
        let answer = (self.shape.value(method, p).map_err(JsValue::from))
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

/// The library's [`Report`], with the reconstruction's bulk arrays as `Float32Array`s for
/// transfer, and its [`Exports`] (`exports`), `parent` naming the vehicle frame.
fn output(c: &Calibration, parent: &str) -> Result<JsValue, JsError> {
    let report = Report::from(c);
    let value = to_js(&report)?;
    Reflect::set(&value, &"exports".into(), &to_js(&Exports::of(&report, parent))?)
        .map_err(|_| internal())?;
    let t = &report.reconstruction;
    let reconstruction = Reflect::get(&value, &"reconstruction".into()).map_err(|_| internal())?;
    for (key, values) in [("means", &t.means), ("sigmas", &t.sigmas), ("priors", &t.priors)] {
        let v: Vec<f32> = values.iter().map(|&x| x as f32).collect();
        Reflect::set(&reconstruction, &key.into(), &Float32Array::from(v.as_slice()))
            .map_err(|_| internal())?;
    }
    Ok(value)
}

fn internal() -> JsError {
    JsError::new("internal: cannot build the result")
}
