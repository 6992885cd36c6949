//! ICP baselines: point-to-point (Besl & McKay 1992), point-to-plane (Chen & Medioni 1992) and
//! GICP (Segal et al. 2009), as compared against in the GMMCalib paper.
//!
//! Two tiers, as in small_gicp: [`align`] with an [`IcpSettings`] for most uses; underneath, a
//! [`FixedCloud`] prepared once (kd-tree, normals or covariances) and [`FixedCloud::align`]ed with many
//! sources (or with a [`MovingCloud`] prepared once for several runs), plus the [`KdTree`] and the
//! [`normals`] estimators themselves.
//!
//! Frames: the result `T_target_source` maps source points into the target frame,
//! `p_target = T_target_source * p_source`. Points are f32 metres; all maths is f64.

mod clouds;
mod gicp;
pub mod kdtree;
pub mod normals;
mod plane;
mod point;
mod solver;

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

pub use clouds::{FixedCloud, MovingCloud};
pub use kdtree::{KdTree, Neighbour};
pub use point::kabsch;

use crate::se3::Pose;

/// The registration metric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Metric {
    /// Point-to-point: closed-form SVD step each iteration.
    PointToPoint,
    /// Point-to-plane with PCA normals of the target: Levenberg-Marquardt on SE(3).
    PointToPlane,
    /// Generalized ICP with plane-regularised covariances: Levenberg-Marquardt on SE(3).
    Gicp,
}

impl Metric {
    pub const ALL: [Metric; 3] = [Metric::PointToPoint, Metric::PointToPlane, Metric::Gicp];

    /// Short name: `"p2p"`, `"p2l"` or `"gicp"` (what [`FromStr`] accepts).
    pub fn name(&self) -> &'static str {
        match self {
            Metric::PointToPoint => "p2p",
            Metric::PointToPlane => "p2l",
            Metric::Gicp => "gicp",
        }
    }
}

impl fmt::Display for Metric {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Metric {
    type Err = IcpError;

    /// Parses a short name, ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, IcpError> {
        Metric::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| IcpError::UnknownMetric(s.to_string()))
    }
}

/// Registration settings; defaults follow small_gicp / fast_gicp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IcpSettings {
    /// Source points farther than this (m) from every target point are left out. Default 1 m.
    pub max_correspondence_distance: f64,
    /// Iteration cap (each iteration: match, then one step). Default 64.
    pub max_iterations: usize,
    /// Converged when an update moves by less than this (m) and less than
    /// `rotation_tolerance`. Default 1e-3 m.
    pub translation_tolerance: f64,
    /// Converged when an update rotates by less than this (rad) and moves less than
    /// `translation_tolerance`. Default 0.1 deg.
    pub rotation_tolerance: f64,
    /// Nearest neighbours (count, at least 3) for normals and covariances. Default 20.
    pub neighbours: usize,
    /// Voxel edge (m) to downsample both clouds with before registering; `None` (default)
    /// keeps every point.
    pub voxel: Option<f64>,
    /// Cauchy kernel scale (m) for point-to-plane and GICP residuals: a match `r` away counts
    /// with weight `1 / (1 + (r / scale)^2)`, so the few matches across different surfaces
    /// (an edge, the other side of a thin object) cannot drag the pose. `None` (default):
    /// plain least squares.
    pub robust_scale: Option<f64>,
}

impl Default for IcpSettings {
    fn default() -> Self {
        Self {
            max_correspondence_distance: 1.0,
            max_iterations: 64,
            translation_tolerance: 1e-3,
            rotation_tolerance: 0.1f64.to_radians(),
            neighbours: 20,
            voxel: None,
            robust_scale: None,
        }
    }
}

impl IcpSettings {
    /// `Err(InvalidSettings)` naming the first field out of range.
    pub fn validate(&self) -> Result<(), IcpError> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        let non_negative = |x: f64| x.is_finite() && x >= 0.0;
        let problem = if !positive(self.max_correspondence_distance) {
            "max_correspondence_distance must be a positive number of metres"
        } else if !non_negative(self.translation_tolerance) {
            "translation_tolerance must be a non-negative number of metres"
        } else if !non_negative(self.rotation_tolerance) {
            "rotation_tolerance must be a non-negative number of radians"
        } else if self.neighbours < 3 {
            "neighbours must be at least 3"
        } else if self.voxel.is_some_and(|v| !positive(v)) {
            "voxel must be a positive number of metres when set"
        } else if self.robust_scale.is_some_and(|v| !positive(v)) {
            "robust_scale must be a positive number of metres when set"
        } else {
            return Ok(());
        };
        Err(IcpError::InvalidSettings(problem))
    }
}

/// The result of a registration.
#[derive(Clone, Debug, PartialEq)]
pub struct Alignment {
    /// `T_target_source`: maps source points into the target frame.
    pub target_from_source: Pose,
    /// Iterations run.
    pub iterations: usize,
    /// True when the last update was below both tolerances before `max_iterations`.
    pub converged: bool,
    /// Source points with a target point within `max_correspondence_distance` at the result.
    pub inliers: usize,
    /// Root mean square distance (m) from those inliers to their nearest target points.
    pub rmse: f64,
}

/// Which cloud a problem was found in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Target,
    Source,
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Role::Target => "target",
            Role::Source => "source",
        })
    }
}

/// Why a registration could not produce a pose.
#[derive(Clone, Debug, PartialEq)]
pub enum IcpError {
    /// A setting is out of range; the message names it.
    InvalidSettings(&'static str),
    /// The initial pose has a non-finite component.
    InvalidInitialPose,
    /// A metric name other than `p2p`, `p2l`, `gicp`.
    UnknownMetric(String),
    /// A point has a NaN or infinite coordinate.
    NonFinitePoint { cloud: Role, index: usize },
    /// Fewer points (after downsampling) than a rigid transform needs.
    TooFewPoints { cloud: Role, count: usize, required: usize },
    /// The cloud cannot fix a rotation: its points coincide or lie on one line.
    Degenerate { cloud: Role, reason: &'static str },
    /// Fewer than three source points had a target point within range.
    NoCorrespondences { found: usize, max_distance: f64, iteration: usize },
    /// The correspondences of an iteration did not determine a finite pose.
    IllConditioned { iteration: usize, reason: &'static str },
}

impl fmt::Display for IcpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IcpError::InvalidSettings(problem) => write!(f, "invalid ICP settings: {problem}"),
            IcpError::InvalidInitialPose => {
                write!(f, "the initial pose has a non-finite component")
            }
            IcpError::UnknownMetric(name) => {
                write!(f, "unknown ICP metric '{name}' (expected p2p, p2l or gicp)")
            }
            IcpError::NonFinitePoint { cloud, index } => {
                write!(f, "{cloud} point {index} has a NaN or infinite coordinate")
            }
            IcpError::TooFewPoints { cloud, count, required } => {
                write!(
                    f,
                    "the {cloud} cloud has {count} points; registration needs at least {required}"
                )
            }
            IcpError::Degenerate { cloud, reason } => {
                write!(f, "the {cloud} cloud is degenerate: {reason}")
            }
            IcpError::NoCorrespondences { found, max_distance, iteration } => {
                write!(
                    f,
                    "only {found} source points have a target point within {max_distance} m"
                )?;
                match iteration {
                    0 => write!(f, " at the initial pose: the clouds do not overlap"),
                    n => write!(f, " after {n} iterations: the registration diverged"),
                }
            }
            IcpError::IllConditioned { iteration, reason } => {
                write!(f, "registration is ill-conditioned at iteration {iteration}: {reason}")
            }
        }
    }
}

impl std::error::Error for IcpError {}

/// Registers `source` onto `target` from the initial guess `init` (`T_target_source`) and
/// returns the refined `T_target_source`. Prepares a [`FixedCloud`] and calls [`FixedCloud::align`];
/// prepare the target yourself to reuse it for several sources.
pub fn align(
    target: &[[f32; 3]],
    source: &[[f32; 3]],
    init: &Pose,
    metric: Metric,
    settings: &IcpSettings,
) -> Result<Alignment, IcpError> {
    FixedCloud::new(target, metric, settings)?.align(source, init, settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_round_trip() {
        for m in Metric::ALL {
            assert_eq!(m.name().parse::<Metric>(), Ok(m));
            assert_eq!(m.to_string(), m.name());
        }
        assert_eq!(" GICP".parse::<Metric>(), Ok(Metric::Gicp));
        let err = "ndt".parse::<Metric>().unwrap_err();
        assert!(err.to_string().contains("'ndt'"), "{err}");
    }

    #[test]
    fn defaults_are_valid_and_checked() {
        let d = IcpSettings::default();
        assert_eq!(d.validate(), Ok(()));
        assert!((d.rotation_tolerance.to_degrees() - 0.1).abs() < 1e-12);
        let bad = [
            IcpSettings { max_correspondence_distance: 0.0, ..d.clone() },
            IcpSettings { max_correspondence_distance: f64::NAN, ..d.clone() },
            IcpSettings { translation_tolerance: -1.0, ..d.clone() },
            IcpSettings { rotation_tolerance: f64::INFINITY, ..d.clone() },
            IcpSettings { neighbours: 2, ..d.clone() },
            IcpSettings { voxel: Some(0.0), ..d.clone() },
            IcpSettings { robust_scale: Some(-0.02), ..d.clone() },
        ];
        for (i, s) in bad.iter().enumerate() {
            assert!(matches!(s.validate(), Err(IcpError::InvalidSettings(_))), "case {i}");
        }
    }
}
