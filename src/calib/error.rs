//! Why a calibration could not run.

use std::fmt;

use crate::jrmpc::JrmpcError;

#[derive(Clone, Debug, PartialEq)]
pub enum CalibError {
    TooFewSensors(usize),
    UnknownSensor(String),
    UnknownReference(String),
    NonFiniteNominal(String),
    InvalidRoi,
    /// No region of interest was given, and the sensors' clouds share none.
    NoOverlap,
    NonFinitePoint {
        sensor: String,
        frame: String,
        index: usize,
    },
    /// No usable view of this sensor shares a frame with the reference.
    NoCommonFrames(String),
    NoPointsInRoi(String),
    /// No region of interest was given, and the region found where the scans overlap at the
    /// sensors' starts holds none of this sensor's points, though it has points.
    OutsideOverlap(String),
    InvalidSetting(&'static str),
    UnknownMethod(String),
    Registration(JrmpcError),
    /// A stage's work failed where it ran (a worker that crashed, say): its message.
    StageFailed(String),
    /// Every frame of this sensor failed to register.
    FramesFailed {
        sensor: String,
    },
    /// `cad` without a target: it registers onto the target's model.
    NoTargetModel,
    /// `cad`: the target's model was found standing nowhere in the reference's points.
    TargetNotFound(String),
    /// The CAD model (its file's name) is larger across (m) than the region of interest.
    TargetLargerThanRoi {
        target: String,
        size: f64,
        roi: f64,
    },
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
            Self::NoOverlap => write!(
                f,
                "no region of interest was given, and the sensors' clouds overlap nowhere \
                 under their nominals: give a ROI, or nominals that place the sensors"
            ),
            Self::NonFinitePoint { sensor, frame, index } => {
                write!(f, "view {sensor}/{frame}: point {index} is not finite")
            }
            Self::NoCommonFrames(s) => {
                write!(f, "sensor '{s}' has no usable frame in common with the reference")
            }
            Self::NoPointsInRoi(s) => write!(f, "sensor '{s}' has no usable points in the ROI"),
            Self::OutsideOverlap(s) => write!(
                f,
                "sensor '{s}' has no usable points in the ROI found where the scans overlap: at \
                 its start (its nominal, or the global alignment's placement of it) it overlaps \
                 no other sensor's scans; give a closer nominal, or a ROI around what it and \
                 the reference both see"
            ),
            Self::InvalidSetting(what) => write!(f, "invalid setting: {what}"),
            Self::UnknownMethod(m) => {
                write!(f, "unknown method '{m}' (expected gmm, jrmpc, cad, p2p, p2l or gicp)")
            }
            Self::Registration(e) => write!(f, "registration failed: {e}"),
            Self::StageFailed(message) => write!(f, "the calculation failed: {message}"),
            Self::FramesFailed { sensor } => {
                write!(f, "no frame of sensor '{sensor}' could be registered: every frame failed")
            }
            Self::NoTargetModel => write!(
                f,
                "the cad method registers onto the target's model: give a target (cube, box, \
                 sphere or a CAD model), not none"
            ),
            Self::TargetNotFound(target) => write!(
                f,
                "the target ({target}) was found standing nowhere in the reference's points in \
                 the region of interest: check the target's shape and size, and the ROI"
            ),
            Self::TargetLargerThanRoi { target, size, roi } => write!(
                f,
                "target {target}: the model is {size:.2} m across, larger than the region of \
                 interest ({roi:.2} m): is the file in millimetres, or the ROI too small?"
            ),
        }
    }
}

impl std::error::Error for CalibError {}

impl From<JrmpcError> for CalibError {
    fn from(e: JrmpcError) -> Self {
        Self::Registration(e)
    }
}
