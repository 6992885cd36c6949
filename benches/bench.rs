//! Benchmarks (not tests): `cargo run --release --bin bench [-- --quick]`.
//! Prints wall time, iterations and Gaussian terms evaluated per second for the JRMPC jobs the
//! README reports (the wasm twin is `www/bench/bench.mjs`, same jobs under Node), then the ICP
//! baselines' per-pair times.

use std::time::Instant;

#[path = "icp.rs"]
mod icp;

use gmmcalib::calib::{self, Rig, View};
use gmmcalib::jrmpc::Control;
use gmmcalib::synth::{self, RigSpec};

struct Job {
    name: &'static str,
    frames: usize,
    points_per_view: usize,
    components: usize,
}

const JOBS: [Job; 2] = [
    Job {
        name: "sample scale: 10 views x 1300 points, K=444",
        frames: 5,
        points_per_view: 1300,
        components: 444,
    },
    Job {
        name: "paper scale: 212 views x 1850 points, K=400",
        frames: 106,
        points_per_view: 1850,
        components: 400,
    },
];

fn run(job: &Job) {
    let spec = RigSpec {
        frames: job.frames,
        points_per_view: job.points_per_view,
        partial: true,
        ..RigSpec::default()
    };
    let rig = synth::generate(&spec);
    let rig = Rig {
        views: rig
            .views
            .into_iter()
            .map(|v| View { sensor: v.sensor, frame: v.frame, points: v.points })
            .collect(),
        nominal: rig.nominal,
        roi: rig.roi,
        reference: None,
    };
    let mut settings = calib::Settings {
        method: calib::Method::Jrmpc,
        components: job.components,
        ..Default::default()
    };
    settings.jrmpc.tolerance = 0.0; // always the full 100 iterations, like the reference
    let points: usize = rig.views.iter().map(|v| v.points.len()).sum();
    let started = Instant::now();
    let result = calib::calibrate(&rig, &settings, |_| Control::Continue).expect("calibration");
    let seconds = started.elapsed().as_secs_f64();
    let terms = (points * job.components * result.iterations) as f64;
    println!(
        "jrmpc {:<46} {:>8.2} s  {:>3} iterations  {:>7.1} M terms/s  ({} points)",
        job.name,
        seconds,
        result.iterations,
        terms / seconds / 1e6,
        points
    );
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    println!(
        "gmmcalib native bench ({} build)",
        if cfg!(debug_assertions) { "debug" } else { "release" }
    );
    for job in JOBS.iter().take(if quick { 1 } else { JOBS.len() }) {
        run(job);
    }
    icp::run();
}
