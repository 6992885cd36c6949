//! Benchmarks (not tests): `cargo run --release --bin bench [-- --quick] [--fast-only]`
//! (`--quick`: the sample-scale job and small ICP views only; `--fast-only`: JRMPC's fast
//! E-step alone, one thread, no dense reference, no ICP).
//! For each JRMPC job docs/benchmarks.md reports: wall time, Gaussian terms evaluated, dense-equivalent
//! terms per second and the speed-up over the exact dense E-step, then peak memory; then the
//! ICP baselines' per-pair times. The wasm twin is `www/bench/bench.mjs`: the same jobs under
//! Node, through the JS API and through this file built for wasm32 (`bench_jrmpc` below).

mod global;
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
    jrmpc::run(job, &jrmpc::rig(job), dense != 0, iterations as usize, 1).terms as f64
}

/// Runs the global stage on OpenCalib's scene 0001; returns the sensors it aligned. JS times
/// the call (the first call also parses the scans; JS times a second one).
#[cfg(target_arch = "wasm32")]
#[unsafe(no_mangle)]
pub extern "C" fn bench_global() -> u32 {
    global::run(&global::scene()) as u32
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

    use super::jrmpc::{self, JOBS, Job};

    pub fn main() {
        let quick = std::env::args().any(|a| a == "--quick");
        let fast_only = std::env::args().any(|a| a == "--fast-only");
        // The global stage and the targets (cube, CAD model, none) alone.
        if std::env::args().any(|a| a == "--targets") {
            global_stage();
            targets();
            return;
        }
        println!(
            "gmmcalib native bench ({} build; CPU time in brackets, the machine may be shared)",
            if cfg!(debug_assertions) { "debug" } else { "release" },
        );
        for job in JOBS.iter().take(if quick { 1 } else { JOBS.len() }) {
            run(job, fast_only);
        }
        if fast_only {
            return;
        }
        for job in JOBS.iter().take(if quick { 1 } else { JOBS.len() }) {
            gmm(job);
        }
        for points in if quick { &[2000][..] } else { &[2000, 65_000][..] } {
            icp_per_pair(*points);
        }
        if !quick {
            super::icp::run();
        }
        global_stage();
        targets();
    }

    /// Targets of any shape (issue 20): `gmm` and `cad` at the sample scale (the cube twin of
    /// the first job) and on the chair twin with its CAD model; `gmm` without a target on
    /// OpenCalib's road scene from its guess.
    fn targets() {
        use gmmcalib::twin::{Miscalibration, Model, Preset, Twin};
        let sample = jrmpc::rig(&JOBS[0]);
        let chairs = Model::RayCast(Preset::paper_chair());
        let chair_twin = Twin::new(&chairs, 3, 1, &Miscalibration::default());
        // `cad` needs a target: `none` is `gmm`'s alone.
        let (both, gmm) =
            (&[calib::Method::Gmm, calib::Method::Cad][..], &[calib::Method::Gmm][..]);
        let cases = [
            ("sample scale (cube)", sample.clone(), gmmcalib::targets::Target::default(), both),
            ("sample scale (target none)", sample, gmmcalib::targets::Target::None, gmm),
            ("chair twin, 3 frames (CAD model)", chair_twin.rig(), chairs.target(), both),
        ];
        for (name, rig, target, methods) in &cases {
            for &method in *methods {
                let settings = calib::Settings { target: target.clone(), ..Default::default() };
                let (result, wall, cpu) =
                    timed(|| calib::calibrate(rig, method, &settings, |_| Control::Continue));
                let iterations = result.as_ref().map_or(0, |r| r.iterations);
                println!(
                    "{} {name}: {wall:.2} s [{cpu:.2} s CPU], {iterations} iterations",
                    method.name()
                );
            }
        }
        let scene = super::global::scene();
        let rig = super::global::rig(&scene);
        let settings =
            calib::Settings { target: gmmcalib::targets::Target::None, ..Default::default() };
        let (result, wall, cpu) =
            timed(|| calib::calibrate(&rig, calib::Method::Gmm, &settings, |_| Control::Continue));
        let verdict = result.map_or("error".into(), |r| format!("{:?}", r.verdict.level));
        println!(
            "gmm OpenCalib 0001, target none: {wall:.2} s [{cpu:.2} s CPU], verdict {verdict}"
        );
    }

    /// The global stage on OpenCalib's road scene, per aligned sensor.
    fn global_stage() {
        let scene = super::global::scene();
        let (aligned, wall, cpu) = timed(|| super::global::run(&scene));
        println!(
            "global stage, OpenCalib 0001 ({} sensors aligned onto top): {:.2} s [{cpu:.2} s CPU], {:.2} s per sensor",
            aligned,
            wall,
            wall / aligned.max(1) as f64
        );
    }

    /// Wall and CPU seconds of `f`.
    fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
        let (started, cpu) = (Instant::now(), cpu_seconds());
        let out = f();
        (out, started.elapsed().as_secs_f64(), cpu_seconds() - cpu)
    }

    /// User + system time of this process, from /proc (10 ms ticks).
    fn cpu_seconds() -> f64 {
        let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
        let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
        let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
        (ticks(11) + ticks(12)) / 100.0
    }

    fn run(job: &Job, fast_only: bool) {
        let rig = jrmpc::rig(job);
        let (fast, seconds, cpu) = timed(|| jrmpc::run(job, &rig, false, 100, 1));
        if fast_only {
            let dense_terms = (fast.points * job.components * fast.iterations) as f64;
            println!(
                "jrmpc {}: fast {seconds:.2} s ({cpu:.2}), {:.1} M terms ({:.1} % of dense)",
                job.name,
                fast.terms as f64 / 1e6,
                100.0 * fast.terms as f64 / dense_terms
            );
            return;
        }
        let (_, seconds_2, cpu_2) = timed(|| jrmpc::run(job, &rig, false, 100, 2));
        let (dense, dense_seconds, dense_cpu) =
            timed(|| jrmpc::run(job, &rig, true, job.dense_iterations, 1));
        let scale = 100.0 / dense.iterations as f64;
        let (dense_seconds, dense_cpu) = (dense_seconds * scale, dense_cpu * scale);
        let dense_terms = (fast.points * job.components * fast.iterations) as f64;
        println!("jrmpc {} ({} points, {} iterations)", job.name, fast.points, fast.iterations);
        println!(
            "  fast   {seconds:>8.2} s ({cpu:.2})  {:>7.1} M terms evaluated ({:.1} % of dense)  \
             {:>7.1} M dense-equivalent terms/s",
            fast.terms as f64 / 1e6,
            100.0 * fast.terms as f64 / dense_terms,
            dense_terms / seconds / 1e6
        );
        println!("  fast, 2 threads {seconds_2:>8.2} s ({cpu_2:.2})");
        println!(
            "  dense  {dense_seconds:>8.2} s ({dense_cpu:.2})  (exact E-step, {} iterations \
             timed, scaled to 100)  speed-up {:.1}x wall, {:.1}x CPU",
            dense.iterations,
            dense_seconds / seconds,
            dense_cpu / cpu
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

    /// `gmm`, the default, end to end on 1 and 2 threads, as users run it: JRMPC (100
    /// iterations here: this rig never meets the convergence test), then the frame pairs' GICP,
    /// the plane adjustment and the target fit (their share is the time after EM's last
    /// progress).
    fn gmm(job: &Job) {
        let rig = jrmpc::rig(job);
        // Every point (the default) on 1 and 2 threads, then multi-resolution EM on 1.
        for (threads, multiresolution) in [(1, false), (2, false), (1, true)] {
            let mut settings = calib::Settings { components: job.components, ..Default::default() };
            settings.jrmpc.threads = threads;
            settings.gmm_em.multiresolution = multiresolution;
            let started = Instant::now();
            let mut em_ended = started;
            let result = calib::calibrate(&rig, calib::Method::Gmm, &settings, |p| {
                if p.mean_sigma > 0.0 {
                    em_ended = Instant::now();
                }
                Control::Continue
            })
            .expect("calibration");
            let (em, rest) = (em_ended - started, em_ended.elapsed());
            let terms: u64 = result.history.iter().map(|h| h.terms).sum();
            println!(
                "gmm {} on {threads} thread{}{}: {:.2} s; JRMPC {:.2} s ({} iterations, {:.0} M \
                 terms), then {:.2} s (frame pairs, plane adjustment, target fit)",
                job.name,
                if threads > 1 { "s" } else { "" },
                if multiresolution { ", multi-resolution" } else { "" },
                (em + rest).as_secs_f64(),
                em.as_secs_f64(),
                result.iterations,
                terms as f64 / 1e6,
                rest.as_secs_f64()
            );
        }
    }

    /// ICP baselines through the calibration, per frame pair, on the synthetic rig's partial
    /// views: the same jobs as the wasm bench.
    fn icp_per_pair(points_per_view: usize) {
        let frames = if points_per_view > 10_000 { 1 } else { 5 };
        let rig = jrmpc::sampled(frames, points_per_view, 2);
        for name in ["p2p", "p2l", "gicp"] {
            let (method, settings) = (name.parse().expect("method"), calib::Settings::default());
            let started = Instant::now();
            calib::calibrate(&rig, method, &settings, |_| Control::Continue).expect("calibration");
            let ms = started.elapsed().as_secs_f64() * 1e3 / frames as f64;
            println!("{name:<5} per pair, {points_per_view:>5}-point views {ms:>9.1} ms");
        }
    }
}
