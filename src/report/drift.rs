//! The drift check's words and JSON: `gmmcalib drift`'s table, the findings it names on
//! stderr, and the shape `--json` and the wasm `compareCalibrations` give.

use serde::Serialize;

use crate::calib::Precision;
use crate::drift::{Drift, Limit, SensorDrift};

/// The comparison for programs: m and rad, vectors about the vehicle's x, y, z axes.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct DriftReport {
    pub passed: bool,
    pub reference: String,
    pub sensors: Vec<SensorDriftReport>,
    pub missing: Vec<String>,
    pub added: Vec<String>,
    /// One sentence per sensor that moved, changed within the calibrations' scatter, or went
    /// missing.
    pub findings: Vec<String>,
}

#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SensorDriftReport {
    pub name: String,
    pub moved: bool,
    /// Beyond the fixed limit, within three combined sigmas of both calibrations' precision:
    /// not a move the two can tell from their own scatter.
    pub unresolved: bool,
    /// Rotation vector of the change (rad) and its angle.
    pub rotation: [f64; 3],
    pub angle: f64,
    /// Position change (m) and its length.
    pub translation: [f64; 3],
    pub distance: f64,
    /// The new calibration's one sigma.
    pub precision: Option<Precision>,
    pub limit: LimitReport,
}

/// `fixed`: an angle (rad) and a distance (m); `sigmas`: per axis, `sigmas` times the
/// combined precision.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum LimitReport {
    Fixed { rotation: f64, translation: f64 },
    Sigmas { sigmas: f64, rotation: [f64; 3], position: [f64; 3] },
}

impl From<&Drift> for DriftReport {
    fn from(d: &Drift) -> Self {
        Self {
            passed: d.passed(),
            reference: d.reference.clone(),
            sensors: d.sensors.iter().map(SensorDriftReport::from).collect(),
            missing: d.missing.clone(),
            added: d.added.clone(),
            findings: drift_findings(d),
        }
    }
}

impl From<&SensorDrift> for SensorDriftReport {
    fn from(s: &SensorDrift) -> Self {
        Self {
            name: s.sensor.clone(),
            moved: s.moved,
            unresolved: s.unresolved,
            rotation: s.rotation,
            angle: s.angle,
            translation: s.translation,
            distance: s.distance,
            precision: s.precision,
            limit: match s.limit {
                Limit::Fixed { rotation, translation } => {
                    LimitReport::Fixed { rotation, translation }
                }
                Limit::Sigmas { sigmas, rotation, position } => {
                    LimitReport::Sigmas { sigmas, rotation, position }
                }
            },
        }
    }
}

fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

/// The limit in words: `0.1 deg, 10.0 mm` or `3 sigma (0.012 deg, 2.1 mm)` (the largest axis).
fn limit_words(limit: &Limit) -> String {
    let max = |v: [f64; 3]| v.into_iter().fold(0.0, f64::max);
    match *limit {
        Limit::Fixed { rotation, translation } => {
            format!("{:.3} deg, {:.1} mm", deg(rotation), translation * 1e3)
        }
        Limit::Sigmas { sigmas, rotation, position } => format!(
            "{sigmas} sigma, up to {:.3} deg, {:.1} mm per axis",
            deg(max(rotation)),
            max(position) * 1e3
        ),
    }
}

/// The table `gmmcalib drift` prints: one line per sensor, then the outcome.
pub fn drift_table(d: &Drift, stored: &str) -> String {
    let mut out = format!("drift since {stored}, relative to {}:\n", d.reference);
    for s in &d.sensors {
        let precision = s.precision.map_or("no precision".to_string(), |p| {
            let r = p.rotation.into_iter().fold(0.0, f64::max);
            let t = p.position.into_iter().fold(0.0, f64::max);
            format!("precision {:.3} deg, {:.1} mm", deg(r), t * 1e3)
        });
        out += &format!(
            "  {:<12} {:>8.3} deg {:>8.1} mm   {precision}; limit {}  {}\n",
            s.sensor,
            deg(s.angle),
            s.distance * 1e3,
            limit_words(&s.limit),
            match (s.moved, s.unresolved) {
                (true, _) => "MOVED",
                (false, true) => "ok (beyond the limit, within both calibrations' scatter)",
                (false, false) => "ok",
            }
        );
    }
    for name in &d.missing {
        out += &format!("  {name:<12} missing from the new calibration\n");
    }
    for name in &d.added {
        out += &format!("  {name:<12} not in the stored calibration: not compared\n");
    }
    out += if d.passed() { "passed: no sensor moved\n" } else { "FAILED: drift\n" };
    out
}

/// One sentence per sensor that moved, changed beyond the limit within the calibrations'
/// scatter, or went missing.
pub fn drift_findings(d: &Drift) -> Vec<String> {
    let moved = d.sensors.iter().filter(|s| s.moved).map(|s| {
        format!(
            "{} moved {:.3} deg and {:.1} mm relative to {} (limit {})",
            s.sensor,
            deg(s.angle),
            s.distance * 1e3,
            d.reference,
            limit_words(&s.limit)
        )
    });
    let unresolved = d.sensors.iter().filter(|s| s.unresolved).map(|s| {
        format!(
            "{} changed {:.3} deg and {:.1} mm relative to {}, beyond the limit ({}) but within \
             {} sigma of both calibrations' precision: they cannot tell it from their own \
             scatter (more frames, or a scene with more structure, sharpen them)",
            s.sensor,
            deg(s.angle),
            s.distance * 1e3,
            d.reference,
            limit_words(&s.limit),
            crate::drift::UNRESOLVED_SIGMAS
        )
    });
    let missing = d.missing.iter().map(|m| format!("{m} is missing from the new calibration"));
    moved.chain(unresolved).chain(missing).collect()
}
