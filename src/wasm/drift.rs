//! `compareCalibrations(stored, storedName, current, currentName, tolerance?)`: the drift check
//! (`crate::drift`) over two calibrations' texts, for the page and for programs. Returns
//! `report::DriftReport` as a plain object.

use serde::Deserialize;
use wasm_bindgen::prelude::*;

use super::{options_or_default, to_js};
use crate::drift::{self, DEFAULT_ROTATION_TOLERANCE, DEFAULT_TRANSLATION_TOLERANCE, Tolerance};
use crate::report::DriftReport;

/// `{ rotationDeg?, translation?, sigmas? }`: the library's defaults when left out.
#[derive(Deserialize, Default)]
#[serde(rename_all = "camelCase", default)]
struct ToleranceOptions {
    rotation_deg: Option<f64>,
    translation: Option<f64>,
    sigmas: Option<f64>,
}

impl ToleranceOptions {
    fn tolerance(&self) -> Result<Tolerance, JsError> {
        let check = |name: &str, v: Option<f64>| match v {
            Some(x) if !(x.is_finite() && x >= 0.0) => Err(JsError::new(&format!(
                "tolerance {name}: expected a non-negative number, got {x}"
            ))),
            _ => Ok(v),
        };
        let rotation = check("rotationDeg", self.rotation_deg)?
            .map_or(DEFAULT_ROTATION_TOLERANCE, f64::to_radians);
        let translation =
            check("translation", self.translation)?.unwrap_or(DEFAULT_TRANSLATION_TOLERANCE);
        Ok(match check("sigmas", self.sigmas)? {
            Some(sigmas) => Tolerance::Precision { sigmas, rotation, translation },
            None => Tolerance::Fixed { rotation, translation },
        })
    }
}

#[wasm_bindgen(js_name = compareCalibrations)]
pub fn compare_calibrations(
    stored: &str,
    stored_name: &str,
    current: &str,
    current_name: &str,
    tolerance: JsValue,
) -> Result<JsValue, JsError> {
    let options: ToleranceOptions = options_or_default(tolerance, "tolerance")?;
    let read = |text, name| drift::read(text, name).map_err(|e| JsError::new(&e.to_string()));
    let (old, new) = (read(stored, stored_name)?, read(current, current_name)?);
    let result = drift::compare(&old, &new, &options.tolerance()?)
        .map_err(|e| JsError::new(&format!("{current_name} against {stored_name}: {e}")))?;
    to_js(&DriftReport::from(&result))
}
