//! The JRMPC bench jobs, shared by the native bench and its wasm build (`bench_jrmpc`, which
//! `www/bench/bench.mjs` loads without wasm-bindgen and times from JS).

use gmmcalib::calib::{self, Rig, View};
use gmmcalib::jrmpc::Control;
use gmmcalib::synth::{self, RigSpec};

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
    let spec = RigSpec {
        frames: job.frames,
        points_per_view: job.points_per_view,
        partial: true,
        ..RigSpec::default()
    };
    rig_of(synth::generate(&spec))
}

/// Calibrates `rig` with JRMPC for exactly `iterations` (the convergence test off, like the
/// reference), on the fast E-step or the dense reference, with the views on `threads`.
pub fn run(job: &Job, rig: &Rig, dense: bool, iterations: usize, threads: usize) -> Outcome {
    let mut settings = calib::Settings {
        method: calib::Method::Jrmpc,
        components: job.components,
        ..Default::default()
    };
    settings.jrmpc.tolerance = 0.0;
    settings.jrmpc.max_iterations = iterations;
    settings.jrmpc.dense = dense;
    settings.jrmpc.threads = threads;
    let result = calib::calibrate(rig, &settings, |_| Control::Continue).expect("calibration");
    Outcome {
        points: rig.views.iter().map(|v| v.points.len()).sum(),
        iterations: result.iterations,
        terms: result.history.iter().map(|h| h.terms).sum(),
    }
}

pub fn rig_of(rig: synth::SyntheticRig) -> Rig {
    Rig {
        views: rig
            .views
            .into_iter()
            .map(|v| View { sensor: v.sensor, frame: v.frame, points: v.points })
            .collect(),
        nominal: rig.nominal,
        roi: rig.roi,
        reference: None,
    }
}
