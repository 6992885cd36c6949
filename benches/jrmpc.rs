//! The JRMPC bench jobs, shared by the native bench and its wasm build (`bench_jrmpc`, which
//! `www/bench/bench.mjs` loads without wasm-bindgen and times from JS).

use gmmcalib::calib::{self, Rig};
use gmmcalib::jrmpc::Control;
use gmmcalib::twin::{Miscalibration, Model, Sampling, Twin};

pub struct Job {
    pub name: &'static str,
    pub frames: usize,
    pub points_per_view: usize,
    pub components: usize,
    /// Iterations the dense reference runs; its time is scaled to 100.
    pub dense_iterations: usize,
}

pub const JOBS: [Job; 2] = [
    Job {
        name: "sample scale: 10 views x 1300 points, K=444",
        frames: 5,
        points_per_view: 1300,
        components: 444,
        dense_iterations: 10,
    },
    Job {
        name: "paper scale: 212 views x 1850 points, K=400",
        frames: 106,
        points_per_view: 1850,
        components: 400,
        dense_iterations: 2,
    },
];

/// What one calibration did.
pub struct Outcome {
    pub points: usize,
    pub iterations: usize,
    /// Gaussian terms the E-steps evaluated.
    pub terms: u64,
}

pub fn rig(job: &Job) -> Rig {
    sampled(job.frames, job.points_per_view, 1)
}

/// The sampled twin's rig: partial views (the faces each sensor sees, 80 % ground), two
/// sensors miscalibrated within the paper's bounds.
pub fn sampled(frames: usize, points_per_view: usize, seed: u64) -> Rig {
    let sampling = Sampling { points_per_view, partial: true, ..Sampling::default() };
    Twin::new(&Model::Sampled(sampling), frames, seed, &Miscalibration::default()).rig()
}

/// Calibrates `rig` with JRMPC for exactly `iterations` (the convergence test off, like the
/// reference), on the fast E-step or the dense reference, with the views on `threads`.
pub fn run(job: &Job, rig: &Rig, dense: bool, iterations: usize, threads: usize) -> Outcome {
    let mut settings = calib::Settings { components: job.components, ..Default::default() };
    settings.jrmpc.tolerance = 0.0;
    settings.jrmpc.max_iterations = iterations;
    settings.jrmpc.exact = dense;
    settings.jrmpc.threads = threads;
    let result = calib::calibrate(rig, calib::Method::Jrmpc, &settings, |_| Control::Continue)
        .expect("calibration");
    Outcome {
        points: rig.scans.iter().map(|v| v.points.len()).sum(),
        iterations: result.iterations,
        terms: result.history.iter().map(|h| h.terms).sum(),
    }
}
