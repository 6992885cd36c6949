//! Benchmarks (not tests): `cargo run --release --bin bench [-- --quick]`.
//! For each JRMPC job the README reports: wall time, Gaussian terms evaluated, dense-equivalent
//! terms per second and the speed-up over the exact dense E-step, then peak memory; then the
//! ICP baselines' per-pair times. The wasm twin is `www/bench/bench.mjs`: the same jobs under
//! Node, through the JS API and through this file built for wasm32 (`bench_jrmpc` below).

#[cfg(not(target_arch = "wasm32"))]
#[path = "icp.rs"]
mod icp;
#[allow(dead_code)] // rig_of is only used natively
mod jrmpc;

/// Runs JRMPC job `job` (index into `JOBS`) for `iterations`, dense (1) or fast (0); returns
/// the Gaussian terms evaluated. JS times the call.
#[cfg(target_arch = "wasm32")]
#[unsafe(no_mangle)]
pub extern "C" fn bench_jrmpc(job: u32, dense: u32, iterations: u32) -> f64 {
    let job = &jrmpc::JOBS[job as usize];
    jrmpc::run(job, &jrmpc::rig(job), dense != 0, iterations as usize).terms as f64
}

#[cfg(target_arch = "wasm32")]
fn main() {}

#[cfg(not(target_arch = "wasm32"))]
fn main() {
    native::main();
}

#[cfg(not(target_arch = "wasm32"))]
mod native {
    use std::time::Instant;

    use gmmcalib::calib::{self};
    use gmmcalib::jrmpc::Control;
    use gmmcalib::synth::{self, RigSpec};

    use super::jrmpc::{self, JOBS, Job};

    pub fn main() {
        let quick = std::env::args().any(|a| a == "--quick");
        println!(
            "gmmcalib native bench ({} build, {} thread(s))",
            if cfg!(debug_assertions) { "debug" } else { "release" },
            1
        );
        for job in JOBS.iter().take(if quick { 1 } else { JOBS.len() }) {
            run(job);
        }
        for points in if quick { &[2000][..] } else { &[2000, 65_000][..] } {
            icp_per_pair(*points);
        }
        if !quick {
            super::icp::run();
        }
    }

    fn run(job: &Job) {
        let rig = jrmpc::rig(job);
        let started = Instant::now();
        let fast = jrmpc::run(job, &rig, false, 100);
        let seconds = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let dense = jrmpc::run(job, &rig, true, job.dense_iterations);
        let dense_seconds = started.elapsed().as_secs_f64() * 100.0 / dense.iterations as f64;
        let dense_terms = (fast.points * job.components * fast.iterations) as f64;
        println!("jrmpc {} ({} points, {} iterations)", job.name, fast.points, fast.iterations);
        println!(
            "  fast   {seconds:>8.2} s  {:>7.1} M terms evaluated ({:.1} % of dense)  \
             {:>7.1} M dense-equivalent terms/s",
            fast.terms as f64 / 1e6,
            100.0 * fast.terms as f64 / dense_terms,
            dense_terms / seconds / 1e6
        );
        println!(
            "  dense  {dense_seconds:>8.2} s  (exact f64 E-step, {} iterations timed, scaled to \
             100)  speed-up {:.1}x",
            dense.iterations,
            dense_seconds / seconds
        );
        println!("  peak memory of the process so far (VmHWM) {}", peak_memory());
    }

    fn peak_memory() -> String {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                s.lines().find(|l| l.starts_with("VmHWM:")).map(|l| l[6..].trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into())
    }

    /// ICP baselines through the calibration, per frame pair, on the synthetic rig's partial
    /// views: the same jobs as the wasm bench.
    fn icp_per_pair(points_per_view: usize) {
        let frames = if points_per_view > 10_000 { 1 } else { 5 };
        let spec =
            RigSpec { frames, points_per_view, partial: true, seed: 2, ..RigSpec::default() };
        let rig = jrmpc::rig_of(synth::generate(&spec));
        for method in ["p2p", "p2l", "gicp"] {
            let settings =
                calib::Settings { method: method.parse().expect("method"), ..Default::default() };
            let started = Instant::now();
            calib::calibrate(&rig, &settings, |_| Control::Continue).expect("calibration");
            let ms = started.elapsed().as_secs_f64() * 1e3 / frames as f64;
            println!("{method:<5} per pair, {points_per_view:>5}-point views {ms:>9.1} ms");
        }
    }
}
