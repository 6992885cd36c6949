//! What the user chooses: the method, the prior and how wide the mixture starts, and the
//! settings of every stage. Every default number lives here or in the stage it belongs to.

use std::str::FromStr;

use super::CalibError;
use super::bev::BevSettings;
use super::level::GroundSettings;
use super::planes::PlaneSettings;
use super::refine::RefineSettings;
use crate::icp::{self, IcpSettings};
use crate::jrmpc::{self, Prior};

/// How the per-frame corrections are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// JRMPC, then per-frame point-to-plane refinement: the product's default.
    Gmm,
    /// Plain JRMPC, as GMMCalib computes it.
    Jrmpc,
    /// An ICP baseline from the nominal pre-alignment.
    Icp(icp::Method),
}

impl Method {
    pub const ALL: [Method; 5] = [
        Method::Gmm,
        Method::Jrmpc,
        Method::Icp(icp::Method::PointToPoint),
        Method::Icp(icp::Method::PointToPlane),
        Method::Icp(icp::Method::Gicp),
    ];

    /// `gmm`, `jrmpc`, `p2p`, `p2l` or `gicp`.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Gmm => "gmm",
            Method::Jrmpc => "jrmpc",
            Method::Icp(m) => m.name(),
        }
    }

    pub fn uses_jrmpc(&self) -> bool {
        matches!(self, Method::Gmm | Method::Jrmpc)
    }
}

impl FromStr for Method {
    type Err = CalibError;

    fn from_str(s: &str) -> Result<Self, CalibError> {
        Method::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| CalibError::UnknownMethod(s.to_string()))
    }
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
    pub method: Method,
    pub prior: Prior,
    /// Number of mixture components K (GMMCalib: about 400).
    pub components: usize,
    /// Seeds the prior sampler.
    pub seed: u64,
    /// Views with fewer points than this inside the ROI are skipped.
    pub min_view_points: usize,
    pub initial_sigma: InitialSigma,
    pub jrmpc: jrmpc::Settings,
    /// For the ICP baselines.
    pub icp: IcpSettings,
    /// For `gmm`'s refinement.
    pub refine: RefineSettings,
    /// For `gmm`'s joint plane adjustment after the refinement; `None`: off.
    pub planes: Option<PlaneSettings>,
    /// Level each sensor's ground onto the reference's before cropping (README, "Where the
    /// bias comes from"); `None`: only for `gmm` (the paper's methods run as published).
    pub level_ground: Option<bool>,
    pub ground: GroundSettings,
    /// After levelling, search yaw and in-plane shift from above (README, "Beyond the spec");
    /// `None`: off.
    pub bev: Option<BevSettings>,
}

impl Settings {
    /// Whether ground levelling runs.
    pub fn levels_ground(&self) -> bool {
        self.level_ground.unwrap_or(self.method == Method::Gmm)
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            method: Method::Gmm,
            prior: Prior::default(),
            components: 400,
            seed: 0,
            min_view_points: 10,
            initial_sigma: InitialSigma::BoundingBox,
            jrmpc: jrmpc::Settings::default(),
            icp: IcpSettings::default(),
            refine: RefineSettings::default(),
            planes: Some(PlaneSettings::default()),
            level_ground: None,
            ground: GroundSettings::default(),
            bev: Some(BevSettings::default()),
        }
    }
}
