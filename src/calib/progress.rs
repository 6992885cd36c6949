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
    /// The views prepared (each sensor's ground levelled, the bird's-eye search, the crop to
    /// the ROI, the targets found), done by the run itself as it advances: one step,
    /// reported as it begins (`iteration` 0 of 1).
    Views,
    /// JRMPC's EM: `iteration` of `max_iterations`, with `mean_sigma` and `max_change`.
    Jrmpc,
    /// The frame pairs' ICP (`gmm`'s refinement, the ICP methods): `iteration` pairs done of
    /// `max_iterations`; `mean_sigma` and `max_change` are 0.
    FramePairs,
    /// `cad`'s EM onto the target's model: as [`Stage::Jrmpc`].
    Cad,
    /// The method's result made (the plane adjustment, the selection, the verdict's
    /// evidence): as [`Stage::Views`].
    Finish,
}

impl Stage {
    /// `"global"`, `"views"`, `"jrmpc"`, `"framePairs"`, `"cad"` or `"finish"`, as JS sees it.
    pub fn name(&self) -> &'static str {
        match self {
            Stage::Global => "global",
            Stage::Views => "views",
            Stage::Finish => "finish",
            Stage::Jrmpc => "jrmpc",
            Stage::FramePairs => "framePairs",
            Stage::Cad => "cad",
        }
    }
}

/// What the progress callback sees as each stage begins, after each sensor the global stage
/// aligns, and after each EM iteration and each frame pair.
pub struct Progress<'a> {
    pub stage: Stage,
    pub iteration: usize,
    pub max_iterations: usize,
    pub mean_sigma: f64,
    pub max_change: f64,
    /// Current `C_ref_s` per sensor, in the order of `Calibration::sensors`.
    pub corrections: &'a [Pose],
}
