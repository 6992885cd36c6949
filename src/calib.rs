//! Views from several sensors -> sensor-to-sensor calibration.
//!
//! 1. pre-align each view's raw points with its sensor's nominal `T_vehicle_sensor`;
//! 2. crop to the region of interest (views left with too few points are skipped and reported);
//! 3. register all views jointly (JRMPC), starting from the target prior at the ROI centroid;
//! 4. per frame, `C_ref_s(f) = T_ref,f^-1 T_s,f` maps sensor s's pre-aligned points onto the
//!    reference sensor's; frames that lack either sensor are skipped;
//! 5. average over frames (chordal mean rotation, mean translation) with per-axis spread;
//! 6. fit the prior shape to the reconstructed means as a plausibility check.

use std::fmt;

use nalgebra::Vector3;

use crate::cloud::{Aabb, Cloud};
use crate::jrmpc::{self, Control, JrmpcError, Prior};
use crate::se3::{Pose, mean_pose};
use crate::target_fit::{ShapeFit, fit_prior};

/// One scan: points `x, y, z` in the sensor's own frame (m).
#[derive(Clone, Debug)]
pub struct View {
    pub sensor: String,
    pub frame: String,
    pub points: Vec<[f32; 3]>,
}

/// Everything about the rig the user supplies.
#[derive(Clone, Debug)]
pub struct Rig {
    pub views: Vec<View>,
    /// Nominal `T_vehicle_sensor` per sensor.
    pub nominal: Vec<(String, Pose)>,
    /// Region of interest in the vehicle frame (m), bounds inclusive.
    pub roi: Aabb,
    /// The sensor the others are calibrated to; default: the sensor of the first view.
    pub reference: Option<String>,
}

/// How wide the mixture starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitialSigma {
    /// The references' rule (jrmpc.m, GMMCalib), the default: the diagonal of the bounding box
    /// of all points and means. Every mean collapses onto the data's centroid in the first
    /// iteration and the mixture then unfolds along the data's principal directions; with a
    /// ground patch in the ROI (the usual case) that guides every view, but a ROI holding only
    /// a cube (isotropic second moments) leaves the views free to drift (README, "Initial
    /// width").
    BoundingBox,
    /// The size of the prior (cube edge, sphere diameter): the mixture keeps the prior's shape
    /// and catches the target under a few degrees of mounting error. Right for a ROI that holds
    /// only the target; user-given means fall back to the bounding-box rule.
    PriorSize,
    /// A fixed standard deviation (m).
    Fixed(f64),
}

/// Calibration settings; every default number lives here or in `jrmpc::Settings`.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub prior: Prior,
    /// Number of mixture components K (GMMCalib: about 400).
    pub components: usize,
    /// Seeds the prior sampler.
    pub seed: u64,
    /// Views with fewer points than this inside the ROI are skipped.
    pub min_view_points: usize,
    pub initial_sigma: InitialSigma,
    pub jrmpc: jrmpc::Settings,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            prior: Prior::default(),
            components: 400,
            seed: 0,
            min_view_points: 10,
            initial_sigma: InitialSigma::BoundingBox,
            jrmpc: jrmpc::Settings::default(),
        }
    }
}

/// Per-axis standard deviation of the per-frame corrections around their mean.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    /// Translation, m.
    pub xyz: [f64; 3],
    /// Rotation about x, y, z (rad), from the rotation vector of `mean^-1 C(f)`.
    pub rpy: [f64; 3],
    /// Frames averaged.
    pub frames: usize,
}

#[derive(Clone, Debug)]
pub struct SensorResult {
    pub name: String,
    /// `C_ref_s`: maps this sensor's nominally pre-aligned points onto the reference's.
    pub correction: Pose,
    /// Corrected `T_vehicle_sensor = C_ref_s * T_vehicle_sensor_nominal`.
    pub extrinsic: Pose,
    /// `T_ref_s`: maps points from this sensor's frame into the reference sensor's frame.
    pub relative: Pose,
    pub spread: Spread,
}

/// The reconstructed target: the final mixture, in the vehicle frame.
#[derive(Clone, Debug)]
pub struct Target {
    pub means: Vec<[f64; 3]>,
    /// Standard deviations (m).
    pub sigmas: Vec<f64>,
    pub priors: Vec<f64>,
    /// The prior shape fitted to the means (None for user-given means).
    pub fit: Option<ShapeFit>,
}

#[derive(Clone, Debug)]
pub struct SkippedView {
    pub sensor: String,
    pub frame: String,
    pub reason: String,
}

#[derive(Clone, Debug)]
pub struct Calibration {
    pub reference: String,
    pub sensors: Vec<SensorResult>,
    pub target: Target,
    pub iterations: usize,
    pub converged: bool,
    pub cancelled: bool,
    pub skipped: Vec<SkippedView>,
    pub history: Vec<jrmpc::IterationStats>,
}

/// What the progress callback sees after each EM iteration.
pub struct Progress<'a> {
    pub iteration: usize,
    pub max_iterations: usize,
    pub mean_sigma: f64,
    pub max_change: f64,
    /// Current `C_ref_s` per sensor, in the order of `Calibration::sensors`.
    pub corrections: &'a [Pose],
}

#[derive(Clone, Debug, PartialEq)]
pub enum CalibError {
    TooFewSensors(usize),
    UnknownSensor(String),
    UnknownReference(String),
    NonFiniteNominal(String),
    InvalidRoi,
    NonFinitePoint {
        sensor: String,
        frame: String,
        index: usize,
    },
    /// No usable view of this sensor shares a frame with the reference.
    NoCommonFrames(String),
    NoPointsInRoi(String),
    InvalidSetting(&'static str),
    Registration(JrmpcError),
}

impl fmt::Display for CalibError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooFewSensors(n) => write!(f, "need views from at least 2 sensors, got {n}"),
            Self::UnknownSensor(s) => {
                write!(f, "unknown sensor '{s}': it has views but no nominal extrinsic")
            }
            Self::UnknownReference(s) => write!(f, "unknown reference sensor '{s}'"),
            Self::NonFiniteNominal(s) => {
                write!(f, "nominal extrinsic of sensor '{s}' is not finite")
            }
            Self::InvalidRoi => {
                write!(f, "ROI is empty or not finite (need finite min <= max on every axis)")
            }
            Self::NonFinitePoint { sensor, frame, index } => {
                write!(f, "view {sensor}/{frame}: point {index} is not finite")
            }
            Self::NoCommonFrames(s) => {
                write!(f, "sensor '{s}' has no usable frame in common with the reference")
            }
            Self::NoPointsInRoi(s) => write!(f, "sensor '{s}' has no usable points in the ROI"),
            Self::InvalidSetting(what) => write!(f, "invalid setting: {what}"),
            Self::Registration(e) => write!(f, "registration failed: {e}"),
        }
    }
}

impl std::error::Error for CalibError {}

impl From<JrmpcError> for CalibError {
    fn from(e: JrmpcError) -> Self {
        Self::Registration(e)
    }
}

/// Calibrates every sensor of `rig` to the reference sensor.
pub fn calibrate(
    rig: &Rig,
    settings: &Settings,
    mut progress: impl FnMut(&Progress) -> Control,
) -> Result<Calibration, CalibError> {
    let sensors = sensor_order(rig)?;
    let reference = rig.reference.clone().unwrap_or_else(|| sensors[0].clone());
    if !sensors.contains(&reference) {
        return Err(CalibError::UnknownReference(reference));
    }
    if settings.components == 0 {
        return Err(CalibError::InvalidSetting("components must be at least 1"));
    }
    let nominal = |s: &str| rig.nominal.iter().find(|(n, _)| n == s).map(|(_, p)| *p);

    // 1-2. Pre-align and crop.
    let mut usable = Vec::new(); // (sensor index, frame, cropped cloud)
    let mut skipped = Vec::new();
    for view in &rig.views {
        if let Some(index) = view.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(CalibError::NonFinitePoint {
                sensor: view.sensor.clone(),
                frame: view.frame.clone(),
                index,
            });
        }
        let pose =
            nominal(&view.sensor).ok_or_else(|| CalibError::UnknownSensor(view.sensor.clone()))?;
        let cloud = Cloud::from_points(view.points.clone()).transformed(&pose).cropped(&rig.roi);
        let distinct = cloud.points.iter().any(|p| p != &cloud.points[0]);
        let needed = settings.min_view_points.max(3);
        if cloud.len() < needed || !distinct {
            let reason = if distinct || cloud.is_empty() {
                format!("{} points in the ROI, need {needed}", cloud.len())
            } else {
                "all points in the ROI coincide".to_string()
            };
            skipped.push(SkippedView {
                sensor: view.sensor.clone(),
                frame: view.frame.clone(),
                reason,
            });
            continue;
        }
        let s = sensors.iter().position(|n| n == &view.sensor).unwrap_or(0);
        usable.push((s, view.frame.clone(), cloud));
    }
    for (s, name) in sensors.iter().enumerate() {
        if !usable.iter().any(|(u, _, _)| *u == s) {
            return Err(CalibError::NoPointsInRoi(name.clone()));
        }
    }
    let r = sensors.iter().position(|n| n == &reference).unwrap_or(0);
    let pairs = frame_pairs(&usable, sensors.len(), r);
    for (s, name) in sensors.iter().enumerate() {
        if pairs[s].is_empty() {
            return Err(CalibError::NoCommonFrames(name.clone()));
        }
    }

    // 3. Joint registration from the prior placed at the centroid of the ROI points.
    let all =
        Cloud::from_points(usable.iter().flat_map(|(_, _, c)| c.points.iter().copied()).collect());
    let centre = all.centroid().unwrap_or([0.0; 3]);
    let means = settings.prior.means(settings.components, centre, settings.seed);
    let views: Vec<&[[f32; 3]]> = usable.iter().map(|(_, _, c)| c.points.as_slice()).collect();
    let jrmpc_settings = jrmpc::Settings {
        initial_sigma: match settings.initial_sigma {
            InitialSigma::PriorSize => settings.prior.size(),
            InitialSigma::BoundingBox => None,
            InitialSigma::Fixed(sigma) => Some(sigma),
        },
        ..settings.jrmpc.clone()
    };
    let registration = jrmpc::register(&views, &means, &jrmpc_settings, |p| {
        let corrections: Vec<Pose> =
            (0..sensors.len()).map(|s| average(&pairs[s], p.poses).0).collect();
        progress(&Progress {
            iteration: p.iteration,
            max_iterations: settings.jrmpc.max_iterations,
            mean_sigma: p.mean_sigma,
            max_change: p.max_change,
            corrections: &corrections,
        })
    })?;

    // 4-5. Per-frame corrections, averaged.
    let reference_nominal = nominal(&reference).unwrap_or_default();
    let results = sensors
        .iter()
        .enumerate()
        .map(|(s, name)| {
            let (correction, spread) = average(&pairs[s], &registration.poses);
            let extrinsic = correction * nominal(name).unwrap_or_default();
            SensorResult {
                name: name.clone(),
                correction,
                extrinsic,
                relative: reference_nominal.inverse() * extrinsic,
                spread,
            }
        })
        .collect();

    // 6. Plausibility.
    let mix = &registration.mixture;
    let target = Target {
        means: mix.means.iter().map(|m| [m.x, m.y, m.z]).collect(),
        sigmas: mix.variances.iter().map(|v| v.sqrt()).collect(),
        priors: mix.priors.clone(),
        fit: fit_prior(&settings.prior, &mix.means, &mix.priors),
    };
    Ok(Calibration {
        reference,
        sensors: results,
        target,
        iterations: registration.iterations,
        converged: registration.converged,
        cancelled: registration.cancelled,
        skipped,
        history: registration.history,
    })
}

/// Sensor names in order of first appearance among the views, after checking the nominals.
fn sensor_order(rig: &Rig) -> Result<Vec<String>, CalibError> {
    if !rig.roi.is_valid() {
        return Err(CalibError::InvalidRoi);
    }
    let mut sensors: Vec<String> = Vec::new();
    for view in &rig.views {
        if !sensors.contains(&view.sensor) {
            sensors.push(view.sensor.clone());
        }
    }
    for name in &sensors {
        let (_, pose) = rig
            .nominal
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| CalibError::UnknownSensor(name.clone()))?;
        let m = pose.to_homogeneous();
        if !m.iter().all(|x| x.is_finite()) {
            return Err(CalibError::NonFiniteNominal(name.clone()));
        }
    }
    if sensors.len() < 2 {
        return Err(CalibError::TooFewSensors(sensors.len()));
    }
    Ok(sensors)
}

/// For each sensor, the (reference view, sensor view) index pairs of the frames both have.
fn frame_pairs(
    usable: &[(usize, String, Cloud)],
    sensors: usize,
    r: usize,
) -> Vec<Vec<(usize, usize)>> {
    let mut pairs = vec![Vec::new(); sensors];
    for (i, (s, frame, _)) in usable.iter().enumerate() {
        if let Some(j) = usable.iter().position(|(u, f, _)| *u == r && f == frame) {
            pairs[*s].push((j, i));
        }
    }
    pairs
}

/// Mean of `C(f) = T_ref,f^-1 T_s,f` over the frame pairs, and its per-axis spread.
fn average(pairs: &[(usize, usize)], poses: &[Pose]) -> (Pose, Spread) {
    let per_frame: Vec<Pose> = pairs.iter().map(|&(r, s)| poses[r].inverse() * poses[s]).collect();
    let mean = mean_pose(&per_frame).unwrap_or_default();
    let n = per_frame.len() as f64;
    let (mut xyz, mut rot) = (Vector3::zeros(), Vector3::zeros());
    for c in &per_frame {
        let dt = c.translation.vector - mean.translation.vector;
        let dr = (mean.rotation.inverse() * c.rotation).scaled_axis();
        xyz += dt.component_mul(&dt);
        rot += dr.component_mul(&dr);
    }
    let std = |v: Vector3<f64>| [v.x, v.y, v.z].map(|s| (s / n).sqrt());
    (mean, Spread { xyz: std(xyz), rpy: std(rot), frames: per_frame.len() })
}
