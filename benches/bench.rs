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
    let rig = rig_of(synth::generate(&spec));
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

/// ICP baselines through the calibration, per frame pair, on the synthetic rig's partial views:
/// the same jobs as the wasm bench.
fn icp_per_pair(points_per_view: usize) {
    let frames = if points_per_view > 10_000 { 1 } else { 5 };
    let spec = RigSpec { frames, points_per_view, partial: true, seed: 2, ..RigSpec::default() };
    let rig = rig_of(synth::generate(&spec));
    for method in ["p2p", "p2l", "gicp"] {
        let settings =
            calib::Settings { method: method.parse().expect("method"), ..Default::default() };
        let started = Instant::now();
        calib::calibrate(&rig, &settings, |_| Control::Continue).expect("calibration");
        let ms = started.elapsed().as_secs_f64() * 1e3 / frames as f64;
        println!("{method:<5} per pair, {points_per_view:>5}-point views {ms:>9.1} ms");
    }
}

fn rig_of(rig: synth::SyntheticRig) -> Rig {
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

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    println!(
        "gmmcalib native bench ({} build)",
        if cfg!(debug_assertions) { "debug" } else { "release" }
    );
    for job in JOBS.iter().take(if quick { 1 } else { JOBS.len() }) {
        run(job);
    }
    for points in if quick { &[2000][..] } else { &[2000, 65_000][..] } {
        icp_per_pair(*points);
    }
    if !quick {
        icp::run();
    }
}
