//! What the user chooses: the method ([`Method`]; a run's list of them is the only place one is
//! kept), the target and how wide the mixture starts, and the settings of every stage. Every
//! default number lives here or in the stage it belongs to. [`Stages::of`] resolves a method
//! under the settings, once, into the stages that run.

use std::str::FromStr;

use super::CalibError;
use super::bev::BevSettings;
use super::global::GlobalSettings;
use super::level::GroundSettings;
use super::pairs::{PairSettings, PairStart};
use super::planes::PlaneSettings;
use super::progress::Stage;
use super::select::SelectSettings;
use crate::cad::CadSettings;
use crate::icp::{self, IcpSettings};
use crate::jrmpc;
use crate::targets::Target;

/// How the per-frame corrections are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Levelling, the bird's-eye search, JRMPC, GICP of each frame pair, the joint plane
    /// adjustment: the product's default.
    Gmm,
    /// Plain JRMPC, as GMMCalib computes it.
    Jrmpc,
    /// GMMCalib's CADCalib: every sensor registered onto fixed components on the target's
    /// model (a CAD mesh, or the cube's, box's or sphere's surface), placed from the data.
    Cad,
    /// An ICP baseline from the nominal pre-alignment.
    Icp(icp::Metric),
}

impl Method {
    pub const ALL: [Method; 6] = [
        Method::Gmm,
        Method::Jrmpc,
        Method::Cad,
        Method::Icp(icp::Metric::PointToPoint),
        Method::Icp(icp::Metric::PointToPlane),
        Method::Icp(icp::Metric::Gicp),
    ];

    /// `gmm`, `jrmpc`, `cad`, `p2p`, `p2l` or `gicp`.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Gmm => "gmm",
            Method::Jrmpc => "jrmpc",
            Method::Cad => "cad",
            Method::Icp(m) => m.name(),
        }
    }

    /// `all` (every method, compared) or one method's name.
    pub fn parse_list(s: &str) -> Result<Vec<Method>, CalibError> {
        if s.trim().eq_ignore_ascii_case("all") {
            return Ok(Method::ALL.to_vec());
        }
        s.split(',').map(str::parse).collect()
    }
}

impl Default for Method {
    /// `gmm`, the product's.
    fn default() -> Self {
        Method::Gmm
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
    /// a cube (isotropic second moments) leaves the views free to drift (docs/method.md,
    /// "Initial width").
    BoundingBox,
    /// The target's size (cube edge, sphere diameter): the mixture keeps the target's shape
    /// and catches it under a few degrees of mounting error. Right for a ROI that holds only
    /// the target.
    TargetSize,
    /// A fixed standard deviation (m).
    Fixed(f64),
}

impl InitialSigma {
    /// What a setting of the initial width may be, in words.
    pub const EXPECTED: &str = "expected a positive number (m), \"prior\" or \"bbox\"";

    /// `"prior"` (the target's size) or `"bbox"` (the bounding box).
    pub fn from_rule(rule: &str) -> Result<Self, String> {
        match rule {
            "prior" => Ok(InitialSigma::TargetSize),
            "bbox" => Ok(InitialSigma::BoundingBox),
            _ => Err(Self::EXPECTED.to_string()),
        }
    }

    /// A fixed width (m): positive and finite.
    pub fn fixed(sigma: f64) -> Result<Self, String> {
        if sigma.is_finite() && sigma > 0.0 {
            Ok(InitialSigma::Fixed(sigma))
        } else {
            Err(Self::EXPECTED.to_string())
        }
    }
}

/// Calibration settings; every default number lives here or in the settings of its stage.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub target: Target,
    /// Number of mixture components K (GMMCalib: about 400).
    pub components: usize,
    /// Seeds every random choice (the target's surface samples, RANSAC).
    pub seed: u64,
    /// Views with fewer points than this inside the ROI are skipped.
    pub min_view_points: usize,
    /// Views with more points than this after cropping are thinned to voxel centroids until
    /// they fit: dense accumulated scans (a solid-state unit integrated for seconds holds 300k
    /// points) cost the registrations time without adding what a calibration needs.
    pub max_view_points: usize,
    pub initial_sigma: InitialSigma,
    pub jrmpc: jrmpc::EmSettings,
    /// For the ICP methods.
    pub icp: IcpSettings,
    /// For `gmm`'s frame pairs (the refinement of JRMPC's corrections).
    pub refine: PairSettings,
    /// For the joint plane adjustment after `gmm`'s refinement and `cad`'s registration;
    /// `None`: off.
    pub planes: Option<PlaneSettings>,
    /// Level each sensor's ground onto the reference's before cropping (docs/method.md,
    /// "Where the bias comes from"); `None`: only for `gmm` (the paper's methods run as
    /// published).
    pub level_ground: Option<bool>,
    pub ground: GroundSettings,
    /// After levelling, search yaw and in-plane shift from above (docs/method.md, "Beyond the
    /// spec"); `None`: off.
    pub bev: Option<BevSettings>,
    /// Before everything, align each sensor globally from a far-off nominal (any yaw, steep
    /// tilts, metres off; docs/method.md, "Global alignment"); `None`: for `gmm` and `cad`.
    pub align_globally: Option<bool>,
    pub global: GlobalSettings,
    /// For `cad`'s registration onto the target's model.
    pub cad: CadSettings,
    /// JRMPC inside `gmm`: its own convergence test and multi-resolution; plain `jrmpc` keeps
    /// those of `jrmpc`.
    pub gmm_em: EmProfile,
    /// The selection among every stage's hypotheses (docs/method.md, "Selection").
    pub select: SelectSettings,
    /// Refine only: trust the nominal, run no global stage, levelling, search from above or
    /// JRMPC, and refine each frame pair from the nominal (then the plane adjustment and the
    /// selection), so the result stays in the nominal's basin.
    pub refine_only: bool,
}

/// How a method runs JRMPC's EM beyond what every method shares (`jrmpc`'s iterations, E-step
/// and threads): one profile per method that overrides them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmProfile {
    /// The convergence test (rad or m per iteration; [`jrmpc::EmSettings::tolerance`]); 0 runs
    /// every iteration. Inside `gmm`, JRMPC only finds the basin and the refinement and plane
    /// adjustment set the accuracy, so it stops early (1e-4; figures in
    /// docs/lab/benchmarks-log.md).
    pub tolerance: f64,
    /// Multi-resolution EM ([`jrmpc::EmSettings::multiresolution`]): the wide iterations take
    /// each view's points merged in cubes. Off inside `gmm`: on a board trial started beyond
    /// the spec it lands 0.25 deg off where the exact path does not (docs/lab/benchmarks-log.md).
    pub multiresolution: bool,
}

impl Default for EmProfile {
    /// `gmm`'s.
    fn default() -> Self {
        Self { tolerance: 1e-4, multiresolution: false }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            target: Target::default(),
            components: 400,
            seed: 0,
            min_view_points: 10,
            max_view_points: 60_000,
            initial_sigma: InitialSigma::BoundingBox,
            jrmpc: jrmpc::EmSettings::default(),
            icp: IcpSettings::default(),
            refine: PairSettings::default(),
            planes: Some(PlaneSettings::default()),
            level_ground: None,
            ground: GroundSettings::default(),
            bev: Some(BevSettings::default()),
            align_globally: None,
            global: GlobalSettings::default(),
            cad: CadSettings::default(),
            gmm_em: EmProfile::default(),
            select: SelectSettings::default(),
            refine_only: false,
        }
    }
}

impl Settings {
    /// Errors in settings no stage can run with.
    pub(super) fn check(&self) -> Result<(), CalibError> {
        if self.components == 0 {
            return Err(CalibError::InvalidSetting("components must be at least 1"));
        }
        if self.planes.as_ref().is_some_and(|p| p.ground_windows.is_empty()) {
            return Err(CalibError::InvalidSetting(
                "the plane adjustment needs at least one ground window (planes.ground_windows)",
            ));
        }
        self.global.check().map_err(CalibError::InvalidSetting)
    }
}

/// The stages a method runs, decided once from the settings: nothing downstream asks which
/// method it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Stages {
    pub method: Method,
    /// Align each sensor globally first (its ground from the data, yaw and shift over the
    /// whole range).
    pub global: Option<GlobalSettings>,
    /// Level each sensor's ground onto the reference's, then (when set) search yaw and shift
    /// from above.
    pub level: bool,
    pub bev: Option<BevSettings>,
    /// Register every view jointly to one mixture; its reconstruction is fitted to the target.
    pub jrmpc: bool,
    /// Register every sensor onto fixed components on the placed target model (`cad`).
    pub cad: Option<CadSettings>,
    /// JRMPC's convergence test and multi-resolution: `gmm_em` for `gmm`, else `jrmpc`'s.
    pub em: EmProfile,
    /// Register each frame pair by ICP: from JRMPC's corrections (`gmm`) or the nominal.
    pub pairs: Option<PairSettings>,
    /// The starts each frame pair registers from: for `gmm` and `cad` the registration's
    /// correction, the chosen start and the nominal, each a hypothesis for the selection; for
    /// the ICP methods the pre-alignment alone, as published.
    pub pair_starts: Vec<PairStart>,
    /// The frame pairs' reference points near its ground take the ground's normal (`gmm`).
    pub ground_normals: bool,
    /// The joint plane adjustment of every sensor over all frames.
    pub planes: Option<PlaneSettings>,
    /// The selection decides among the stages' hypotheses (`gmm`, `cad`); the paper's methods
    /// keep their own result as published, scored for the verdict.
    pub select: bool,
}

impl Stages {
    /// What `method` runs under `settings`.
    pub fn of(method: Method, settings: &Settings) -> Self {
        let refine = settings.refine_only;
        // `cad` places its model on the reference's ground, as `gmm` levels onto it.
        let level =
            !refine && settings.level_ground.unwrap_or(matches!(method, Method::Gmm | Method::Cad));
        let pairs = match method {
            Method::Gmm => Some(settings.refine.clone()),
            Method::Icp(metric) => Some(PairSettings::from_nominal(metric, &settings.icp)),
            Method::Jrmpc | Method::Cad => None,
        };
        // `cad` finds its basin as `gmm` does: its EM alone holds no more than a few degrees.
        let global = !refine
            && settings.align_globally.unwrap_or(matches!(method, Method::Gmm | Method::Cad));
        Self {
            method,
            global: global.then(|| settings.global.clone()),
            level,
            bev: settings.bev.clone().filter(|_| level),
            // Without a target, JRMPC's mixture on a whole scene is no basin worth its cost for
            // `gmm` (OpenCalib's road: the scenes then disagree by degrees); the global stage
            // and the refinement do the work. Plain `jrmpc` still runs it, on the scene.
            jrmpc: match method {
                Method::Gmm => settings.target != Target::None && !refine,
                Method::Jrmpc => true,
                Method::Cad | Method::Icp(_) => false,
            },
            em: match method {
                Method::Gmm => settings.gmm_em,
                _ => EmProfile {
                    tolerance: settings.jrmpc.tolerance,
                    multiresolution: settings.jrmpc.multiresolution,
                },
            },
            // One knob for the most EM iterations, JRMPC's or cad's.
            cad: (method == Method::Cad).then(|| CadSettings {
                max_iterations: settings.jrmpc.max_iterations,
                ..settings.cad.clone()
            }),
            pairs,
            pair_starts: match method {
                Method::Gmm | Method::Cad => {
                    vec![PairStart::Registration, PairStart::Start, PairStart::Nominal]
                }
                Method::Jrmpc | Method::Icp(_) => vec![PairStart::Start],
            },
            ground_normals: method == Method::Gmm,
            planes: settings.planes.clone().filter(|_| matches!(method, Method::Gmm | Method::Cad)),
            select: matches!(method, Method::Gmm | Method::Cad),
        }
    }

    /// The stages a run of these goes through, in order, as progress reports them: what a
    /// progress bar shares out. A stage may still end up not running (a global stage with
    /// nothing to align, frame pairs a scene does not have).
    pub fn plan(&self) -> Vec<Stage> {
        let registration =
            if self.cad.is_some() { Some(Stage::Cad) } else { self.jrmpc.then_some(Stage::Jrmpc) };
        self.global
            .as_ref()
            .map(|_| Stage::Global)
            .into_iter()
            .chain([Stage::Views])
            .chain(registration)
            .chain(self.pairs.as_ref().map(|_| Stage::FramePairs))
            .chain([Stage::Finish])
            .collect()
    }
}
