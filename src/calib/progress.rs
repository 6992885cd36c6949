//! What the progress callback sees while a calibration runs. A leaf: the stages that report
//! progress import it, and it imports none of them.

use crate::se3::Pose;

/// A step of a method's run: what [`Progress`] reports, and what [`super::Run::stage`] says
/// comes next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// The global alignment before the registration: `iteration` sensors aligned of
    /// `max_iterations`; `mean_sigma` and `max_change` are 0.
    Global,
    /// JRMPC's EM: `iteration` of `max_iterations`, with `mean_sigma` and `max_change`.
    Jrmpc,
    /// The frame pairs' ICP (`gmm`'s refinement, the ICP methods): `iteration` pairs done of
    /// `max_iterations`; `mean_sigma` and `max_change` are 0.
    FramePairs,
    /// `cad`'s EM onto the target's model: as [`Stage::Jrmpc`].
    Cad,
}

impl Stage {
    /// `"global"`, `"jrmpc"`, `"framePairs"` or `"cad"`, as JS sees it.
    pub fn name(&self) -> &'static str {
        match self {
            Stage::Global => "global",
            Stage::Jrmpc => "jrmpc",
            Stage::FramePairs => "framePairs",
            Stage::Cad => "cad",
        }
    }
}

/// What the progress callback sees as the global stage begins, after each sensor it aligns,
/// and after each EM iteration and each frame pair.
pub struct Progress<'a> {
    pub stage: Stage,
    pub iteration: usize,
    pub max_iterations: usize,
    pub mean_sigma: f64,
    pub max_change: f64,
    /// Current `C_ref_s` per sensor, in the order of `Calibration::sensors`.
    pub corrections: &'a [Pose],
}
