//! gmmcalib: multi-LiDAR extrinsic calibration by joint registration of all scans to one
//! floating Gaussian mixture (JRMPC, Evangelidis & Horaud 2018, as used by GMMCalib).
//!
//! Data flows one way (docs/architecture.md): bytes ([`io`]) -> clouds ([`Cloud`]) -> views
//! ([`calib::Views`]) -> stages ([`calib`], over the engines [`jrmpc`] and [`icp`]) ->
//! [`calib::Calibration`] -> [`report`] (its shape and prose) and [`export`] (every writer). The algorithm modules know nothing of JavaScript and
//! make no prose; `wasm` is a thin adapter compiled only for `wasm32`.

// Primitives.
pub mod cloud;
pub mod lzf;
pub mod mesh;
pub mod plane;
pub mod se3;
// Decoding, and which file is which sensor and frame.
pub mod io;
pub mod layout;
// Engines and the target.
pub mod cad;
pub mod icp;
pub mod jrmpc;
pub mod targets;
// The pipeline.
pub mod calib;
pub mod config;
// Has a sensor moved since a stored calibration?
pub mod drift;
// Truth: the digital twin and the paper's metrics.
pub mod eval;
pub mod twin;
// The edge.
pub mod command;
pub mod export;
pub mod report;
#[cfg(target_arch = "wasm32")]
pub mod wasm;

pub use cloud::{Aabb, Cloud};
pub use se3::Pose;

/// The threads a job asking for `requested` runs on here: at least one, and one in wasm32,
/// which spawns none (the page shares work across Web Workers instead).
pub(crate) fn threads_here(requested: usize) -> usize {
    if cfg!(target_arch = "wasm32") { 1 } else { requested.max(1) }
}

/// `f` of every item, in order, on up to `threads` threads (contiguous slices).
pub(crate) fn on_threads<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    f: impl Fn(&T) -> R + Sync,
) -> Vec<R> {
    if threads <= 1 || items.len() <= 1 {
        return items.iter().map(f).collect();
    }
    let per = items.len().div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(per)
            .map(|chunk| scope.spawn(move || chunk.iter().map(f).collect::<Vec<R>>()))
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a worker thread panicked")).collect()
    })
}
