//! `simulateRig(options)`: the digital twin (`twin`) for the demo and the tests, in the shape
//! `calibrate` takes, with the truth kept so the page can show the actual error.

use std::collections::BTreeMap;

use js_sys::Float32Array;
use serde::Deserialize;
use wasm_bindgen::prelude::*;

use crate::targets::Target;

use super::{RigOutput, RigScan, Roi, XyzRpy, options_or_default, to_js};
use crate::twin::{self, Miscalibration, Model, Sampling, Twin};

#[derive(Deserialize, Default)]
#[serde(rename_all = "camelCase")]
struct SimulateInput {
    preset: Option<String>,
    frames: Option<usize>,
    seed: Option<u64>,
    max_angle_deg: Option<f64>,
    max_translation: Option<f64>,
    /// The `sampled` preset's knobs.
    sensors: Option<usize>,
    points_per_view: Option<usize>,
    noise: Option<f64>,
    partial: Option<bool>,
}

/// Most frames one call simulates: each is a full scan per sensor (about 100k rays).
const MAX_FRAMES: usize = 200;

/// Simulates `frames` scans per sensor of a preset (`twin::PRESETS`: `'paper'`, `'paper-roof'`,
/// `'os1-128'`, `'sampled'`). Every sensor but the first (the reference) gets a wrong nominal
/// mount, up to `maxAngleDeg` (deg, default 3) and `maxTranslation` (m, default 0.1) per axis.
/// Returns `{scans, nominal, roi, reference, truth}`: scans in the sensor frame, `truth` the
/// true `T_vehicle_sensor`. Seeded by the twin's one rule: `gmmcalib simulate` with the same
/// preset, frames and seed writes the same rig.
#[wasm_bindgen(js_name = simulateRig)]
pub fn simulate_rig(options: JsValue) -> Result<JsValue, JsError> {
    let o: SimulateInput = options_or_default(options, "simulateRig")?;
    let name = o.preset.as_deref().unwrap_or("paper");
    let mut model = Model::by_name(name).ok_or_else(|| {
        JsError::new(&format!("unknown preset '{name}' (expected {})", twin::PRESETS.join(", ")))
    })?;
    if let Model::Sampled(sampling) = &mut model {
        *sampling = sampled(&o, sampling)?;
    }
    let frames = o.frames.unwrap_or(4);
    if !(1..=MAX_FRAMES).contains(&frames) {
        return Err(JsError::new(&format!("frames must be 1 to {MAX_FRAMES}, got {frames}")));
    }
    let bound = |v: Option<f64>, default: f64, name: &str| match v {
        None => Ok(default),
        Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
        Some(x) => Err(JsError::new(&format!("{name} must be a number >= 0, got {x}"))),
    };
    let angle =
        bound(o.max_angle_deg.map(f64::to_radians), twin::MAX_MISCALIBRATION_ANGLE, "maxAngleDeg")?;
    let translation =
        bound(o.max_translation, twin::MAX_MISCALIBRATION_TRANSLATION, "maxTranslation")?;
    let twin =
        Twin::new(&model, frames, o.seed.unwrap_or(0), &Miscalibration::within(angle, translation));
    let named = |poses: &[(String, crate::se3::Pose)]| -> BTreeMap<String, XyzRpy> {
        poses.iter().map(|(n, p)| (n.clone(), XyzRpy::from(p))).collect()
    };
    let scans = twin
        .scans
        .iter()
        .map(|s| {
            let mut cloud = s.cloud.clone();
            let dropped = cloud.drop_invalid();
            RigScan {
                sensor: s.sensor.clone(),
                frame: s.frame.clone(),
                points: Float32Array::from(cloud.points.as_flattened()),
                dropped,
            }
        })
        .collect();
    to_js(&RigOutput {
        scans,
        nominal: named(&twin.nominal),
        truth: named(&twin.truth),
        roi: Roi { min: twin.roi.min, max: twin.roi.max },
        reference: twin.truth[0].0.clone(),
        target: match model.target() {
            Target::Cube { edge } => format!("cube:{edge}"),
            Target::Mesh(_) => "mesh:target.obj".into(),
            _ => "none".into(),
        },
        target_obj: match model.target() {
            Target::Mesh(m) => Some(crate::export::write_obj(&m.mesh)),
            _ => None,
        },
    })
}

/// The `sampled` preset with the options' knobs.
fn sampled(o: &SimulateInput, base: &Sampling) -> Result<Sampling, JsError> {
    let count = |v: Option<usize>, default: usize, range: std::ops::RangeInclusive<usize>, name| {
        let v = v.unwrap_or(default);
        if range.contains(&v) {
            Ok(v)
        } else {
            Err(JsError::new(&format!(
                "{name} must be {} to {}, got {v}",
                range.start(),
                range.end()
            )))
        }
    };
    Ok(Sampling {
        sensors: count(o.sensors, base.sensors, 2..=16, "sensors")?,
        points_per_view: count(
            o.points_per_view,
            base.points_per_view,
            10..=1_000_000,
            "pointsPerView",
        )?,
        noise: match o.noise {
            None => base.noise,
            Some(n) if n.is_finite() && n >= 0.0 => n,
            Some(n) => return Err(JsError::new(&format!("noise must be a number >= 0, got {n}"))),
        },
        partial: o.partial.unwrap_or(base.partial),
        ..base.clone()
    })
}
