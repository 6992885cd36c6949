//! Scans from several sensors -> sensor-to-sensor calibration, as a short list of stages:
//!
//! 1. views ([`Views::new`]): level each sensor's ground onto the reference's and search yaw
//!    and shift from above (`gmm`), pre-align every scan with its sensor's nominal
//!    `T_vehicle_sensor`, crop to the region of interest, pair each sensor's views with the
//!    reference's of the same frame;
//! 2. JRMPC (`gmm`, `jrmpc`): register every view jointly to one floating mixture that starts
//!    as the target's surface; `C_ref_s(f) = T_ref,f^-1 T_s,f`;
//! 3. frame pairs ([`FramePairs`]): ICP of each frame onto the reference's — `gmm`'s
//!    refinement of JRMPC's corrections, or the ICP methods from the nominal;
//! 4. the joint plane adjustment (`gmm`): one motion per sensor over all frames;
//! 5. average over frames (chordal mean rotation, mean translation) with per-axis spread,
//!    leaving out and noting frames far from the others; then the reconstruction, with the
//!    target's shape fitted to it.
//!
//! The method is resolved once into the [`Stages`] that run; [`Run`] is the state machine
//! that runs them, for one method or several compared, driven natively ([`calibrate`],
//! [`calibrate_each`]) or by the page's workers.

mod average;
mod bev;
mod cad_registration;
pub mod correlate;
mod error;
mod evidence;
mod finish;
pub mod global;
mod grounds;
mod input;
mod judge;
mod left_out;
mod level;
mod loops;
mod notes;
mod pairs;
mod placed;
mod planes;
mod progress;
mod reconstruction;
pub mod region;
mod result;
mod rig;
mod run;
pub mod select;
mod settings;
mod shifts;
pub mod up;
pub mod verdict;
mod views;

pub use bev::{BevAlignment, BevSettings};
pub use error::CalibError;
pub use evidence::{Agreement, Observability, SensorEvidence};
pub use global::{
    GlobalAlignment, GlobalJob, GlobalReference, GlobalSettings, GlobalSkip, GlobalStage,
};
pub use input::{Methods, SettingsInput, TargetChoice, mesh_path};
pub use level::GroundSettings;
pub use loops::LoopGap;
pub use notes::{BevWarning, LevellingSkipped, Note, NoteKind, SearchRange};
pub use pairs::{
    FramePair, FramePairs, PairCorrections, PairFailure, PairIcp, PairSettings, PairStart, align,
    fixed_cloud,
};
pub use planes::{PlaneSettings, Precision};
pub use progress::{Progress, Stage};
pub use result::{Calibration, Levelling, Reconstruction, SensorResult, Spread};
pub use rig::{Rig, Scan};
pub use run::{MethodOutcome, Run};
pub use select::{
    GroundAgreement, Hypothesis, SelectSettings, SensorScore, SensorSelection, Source,
};
pub use settings::{EmProfile, InitialSigma, Method, Settings, Stages};
pub use verdict::{Axis, Level, Reason, ReasonKind, SensorVerdict, Verdict};
pub use views::{JrmpcInput, Views};

use std::borrow::Cow;

use crate::jrmpc::Control;

/// Calibrates every sensor of `rig` to the reference sensor by `method`; `progress` sees every
/// EM iteration and frame pair, and may stop the run.
pub fn calibrate(
    rig: &Rig,
    method: Method,
    settings: &Settings,
    mut progress: impl FnMut(&Progress) -> Control,
) -> Result<Calibration, CalibError> {
    let mut run = Run::new(Cow::Borrowed(rig), settings, &[method]);
    run.drive(settings.jrmpc.threads, &mut |_, p| progress(p));
    let (_, outcome) = run.into_outcomes().pop().expect("a run of one method has its outcome");
    outcome
}

/// Calibrates `rig` by each of `methods` on the same scans: every method's outcome, in
/// order. A method that fails is a finding like any other: the others still run.
pub fn calibrate_each(
    rig: &Rig,
    settings: &Settings,
    methods: &[Method],
    mut progress: impl FnMut(Method, &Progress) -> Control,
) -> Vec<MethodOutcome> {
    let mut run = Run::new(Cow::Borrowed(rig), settings, methods);
    run.drive(settings.jrmpc.threads, &mut progress);
    run.into_outcomes()
}
