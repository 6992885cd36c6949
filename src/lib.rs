//! gmmcalib: multi-LiDAR extrinsic calibration by joint registration of all scans to one
//! floating Gaussian mixture (JRMPC, Evangelidis & Horaud 2018, as used by GMMCalib).
//!
//! Data flows one way: bytes -> [`Cloud`] -> pre-align and crop -> views -> [`jrmpc`] ->
//! [`calib`] -> results. The algorithm modules know nothing of JavaScript; `wasm` is a thin
//! adapter compiled only for `wasm32`.

pub mod calib;
pub mod cloud;
pub mod eval;
pub mod icp;
pub mod io;
pub mod jrmpc;
pub mod report;
pub mod se3;
pub mod sim;
pub mod synth;
pub mod target_fit;

pub use cloud::{Aabb, Cloud};
pub use se3::Pose;

/// The threads a job asking for `requested` runs on here: at least one, and one in wasm32,
/// which spawns none (the page shares work across Web Workers instead).
pub(crate) fn threads_here(requested: usize) -> usize {
    if cfg!(target_arch = "wasm32") { 1 } else { requested.max(1) }
}
#[cfg(target_arch = "wasm32")]
pub mod wasm;
