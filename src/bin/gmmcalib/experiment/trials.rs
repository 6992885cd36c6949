//! The experiment's trials and what is read off them: per method, the transform errors, the
//! distance errors per frame, the global error, the miscalibrated count.

use gmmcalib::eval::{self, DistanceError, GlobalError, TransformError};

/// Range bins of the global error profile (m).
pub const RANGE_BIN: f64 = 2.0;

/// One frame of a calibrated sensor, scored.
pub struct FrameScore {
    pub frame: String,
    pub validation: Option<DistanceError>,
    pub scan: Option<DistanceError>,
}

/// One method on one non-reference sensor of one trial.
pub struct MethodRun {
    pub method: usize,
    pub sensor: String,
    pub outcome: Result<Scored, String>,
    pub seconds: f64,
}

pub struct Scored {
    pub transform: TransformError,
    pub frames: Vec<FrameScore>,
    pub global: GlobalError,
}

impl Scored {
    /// Mean validation-cube error (L2, m) over the frames; NaN when the cube was never seen.
    pub fn validation_norm(&self) -> f64 {
        let v: Vec<f64> = self.frames.iter().filter_map(|f| f.validation.map(|d| d.norm)).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    }
}

pub struct Trial {
    pub index: usize,
    pub seed: u64,
    pub runs: Vec<MethodRun>,
}

/// Runs of method `m` that produced an estimate.
pub fn scored<'a>(trials: &'a [Trial], m: usize) -> impl Iterator<Item = &'a Scored> + 'a {
    trials
        .iter()
        .flat_map(|t| &t.runs)
        .filter(move |r| r.method == m)
        .filter_map(|r| r.outcome.as_ref().ok())
}

/// Per-frame values of one axis (0..3: x, y, z; 3: L2) of the validation or whole-scan error.
pub fn frame_values(trials: &[Trial], m: usize, validation: bool, axis: usize) -> Vec<f64> {
    let pick = |d: &DistanceError| if axis < 3 { d.axes[axis] } else { d.norm };
    scored(trials, m)
        .flat_map(|s| &s.frames)
        .filter_map(|f| if validation { f.validation } else { f.scan })
        .map(|d| pick(&d))
        .collect()
}

/// Per-run transform error, axis 0..6: roll, pitch, yaw, x, y, z.
pub fn transform_values(trials: &[Trial], m: usize, axis: usize) -> Vec<f64> {
    scored(trials, m)
        .map(|s| if axis < 3 { s.transform.rpy[axis] } else { s.transform.xyz[axis - 3] })
        .collect()
}

pub fn global(trials: &[Trial], m: usize) -> GlobalError {
    let mut g = GlobalError::new(RANGE_BIN);
    for s in scored(trials, m) {
        g.merge(&s.global);
    }
    g
}

pub fn miscalibrated(trials: &[Trial], m: usize) -> usize {
    let runs = trials.iter().flat_map(|t| &t.runs).filter(|r| r.method == m);
    runs.filter(|r| {
        r.outcome.as_ref().map_or(true, |s| eval::is_miscalibrated(s.validation_norm()))
    })
    .count()
}
