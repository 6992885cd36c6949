//! `simulateRig(options)`: the ray-cast digital twin (`sim`) for the demo, in the shape
//! `calibrate` takes, with the truth kept so the page can show the actual error.

use std::collections::BTreeMap;

use js_sys::Float32Array;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::Deserialize;
use wasm_bindgen::prelude::*;

use super::{RigOutput, RigView, Roi, XyzRpy, options_or_default, to_js};
use crate::sim::{self, Preset};

#[derive(Deserialize, Default)]
#[serde(rename_all = "camelCase")]
struct SimulateInput {
    preset: Option<String>,
    frames: Option<usize>,
    seed: Option<u64>,
    max_angle_deg: Option<f64>,
    max_translation: Option<f64>,
}

/// Most frames one call simulates: each is a full scan per sensor (about 100k rays).
const MAX_FRAMES: usize = 200;

/// Simulates `frames` scans per sensor of a preset (`'paper'` or `'os1-128'`). Every sensor but
/// the first (the reference) gets a wrong nominal mount, up to `maxAngleDeg` (deg, default 3) and
/// `maxTranslation` (m, default 0.1) per axis. Returns `{views, nominal, roi, reference, truth}`:
/// views in the sensor frame, `truth` the true `T_vehicle_sensor`. Seeded.
#[wasm_bindgen(js_name = simulateRig)]
pub fn simulate_rig(options: JsValue) -> Result<JsValue, JsError> {
    let o: SimulateInput = options_or_default(options, "simulateRig")?;
    let preset = match o.preset.as_deref().unwrap_or("paper") {
        "paper" => Preset::paper(),
        "os1-128" => Preset::os1_128(),
        other => {
            return Err(JsError::new(&format!(
                "unknown preset '{other}' (expected 'paper' or 'os1-128')"
            )));
        }
    };
    let frames = o.frames.unwrap_or(4);
    if !(1..=MAX_FRAMES).contains(&frames) {
        return Err(JsError::new(&format!("frames must be 1 to {MAX_FRAMES}, got {frames}")));
    }
    let bound = |v: Option<f64>, default: f64, name: &str| match v {
        None => Ok(default),
        Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
        Some(x) => Err(JsError::new(&format!("{name} must be a number >= 0, got {x}"))),
    };
    let max_angle =
        bound(o.max_angle_deg.map(f64::to_radians), sim::MAX_MISCALIBRATION_ANGLE, "maxAngleDeg")?;
    let max_translation =
        bound(o.max_translation, sim::MAX_MISCALIBRATION_TRANSLATION, "maxTranslation")?;
    let seed = o.seed.unwrap_or(0);

    // The scans and the miscalibration draw from separate streams, so changing the bounds keeps
    // the same scans.
    let scans = preset.simulate(frames, seed);
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x6d69_7363_616c_6962);
    let mut nominal = BTreeMap::new();
    let mut truth = BTreeMap::new();
    for (i, s) in preset.sensors.iter().enumerate() {
        let wrong = if i == 0 {
            s.mount
        } else {
            sim::miscalibrate(&s.mount, max_angle, max_translation, &mut rng)
        };
        nominal.insert(s.name.clone(), XyzRpy::from(&wrong));
        truth.insert(s.name.clone(), XyzRpy::from(&s.mount));
    }
    let views = scans
        .into_iter()
        .map(|mut v| {
            let dropped = v.cloud.drop_invalid();
            RigView {
                sensor: v.sensor,
                frame: v.frame,
                points: Float32Array::from(v.cloud.points.as_flattened()),
                dropped,
            }
        })
        .collect();
    to_js(&RigOutput {
        views,
        nominal,
        truth,
        roi: Roi { min: preset.roi.min, max: preset.roi.max },
        reference: preset.sensors[0].name.clone(),
    })
}
