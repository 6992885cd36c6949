//! `gmmcalib experiment`: the paper's experiment (section V) on the digital twin. Each trial
//! simulates fresh frames under a fresh miscalibration (seed derived from `--seed` and the trial
//! index), runs every method on the same frames, and scores each estimate against the truth
//! with `gmmcalib::eval`. Trials run on worker threads; each is a pure function of its seed, so
//! the results equal a serial run's and are written in trial order. Then: run, score, write.

mod plots;
mod tables;
mod trials;

use std::fs;
use std::time::Instant;

use gmmcalib::calib::{self, Method, Settings};
use gmmcalib::eval::{self, GlobalError};
use gmmcalib::jrmpc::Control;
use gmmcalib::twin::{Model, derive_seed};
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::ExperimentArgs;
use crate::layout::{TwinFiles, model};
use crate::parallel::on_threads;
use trials::{FrameScore, MethodRun, RANGE_BIN, Scored, Trial};

pub fn run(a: &ExperimentArgs) -> Result<(), String> {
    let methods = methods(&a.methods)?;
    model(&a.twin.preset)?;
    fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let started = Instant::now();
    let trials = run_trials(a, &methods)?;
    let seconds = started.elapsed().as_secs_f64();

    let summary = tables::summary(a, &methods, &trials, seconds);
    let write = |name: &str, text: String| {
        let path = a.out.join(name);
        fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    let json = gmmcalib::export::json(&summary).map_err(|e| format!("JSON: {e}"))?;
    write("summary.json", json)?;
    write("trials.csv", tables::csv(&methods, &trials))?;
    write("table.md", tables::table(a, &methods, &trials))?;
    plots::distance_boxes(&a.out.join("distance_error.svg"), &methods, &trials)?;
    plots::global_error(&a.out.join("global_error.svg"), &methods, &trials)?;
    eprintln!(
        "{} trials x {} frames x {} methods in {seconds:.0} s; results in {}",
        a.trials,
        a.twin.frames,
        methods.len(),
        a.out.display()
    );
    Ok(())
}

/// `gmm,jrmpc,...` or `all`, each once.
fn methods(list: &str) -> Result<Vec<Method>, String> {
    let methods = Method::parse_list(list).map_err(|e| e.to_string())?;
    for (i, m) in methods.iter().enumerate() {
        if methods[..i].contains(m) {
            return Err(format!("--methods names {} twice", m.name()));
        }
    }
    Ok(methods)
}

/// Every trial, on `--threads` workers pulling trial indices, returned in trial order.
fn run_trials(a: &ExperimentArgs, methods: &[Method]) -> Result<Vec<Trial>, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = a.threads.unwrap_or(cores).clamp(1, a.trials);
    let bar = ProgressBar::new(a.trials as u64).with_style(
        ProgressStyle::with_template(
            "{msg} [{bar:30}] {pos}/{len} trials, {elapsed} elapsed, ETA {eta}",
        )
        .map_err(|e| e.to_string())?
        .progress_chars("=> "),
    );
    bar.set_message("experiment");
    let trials = on_threads(a.trials, Some(threads), || bar.inc(1), |i| run_trial(a, methods, i));
    bar.finish_and_clear();
    trials
}

/// One trial: simulate, then every method on the same rig, then score each non-reference sensor.
fn run_trial(a: &ExperimentArgs, methods: &[Method], index: usize) -> Result<Trial, String> {
    let seed = derive_seed(a.twin.seed, index as u64);
    let files = TwinFiles::new(&a.twin, seed)?;
    let rig = files.rig();
    let mut runs = Vec::new();
    for (m, method) in methods.iter().enumerate() {
        let started = Instant::now();
        let result = calib::calibrate(&rig, *method, &Settings::default(), |_| Control::Continue);
        let seconds = started.elapsed().as_secs_f64();
        for (s, folder) in files.folders.iter().enumerate().skip(1) {
            let outcome = match &result {
                Err(e) => Err(e.to_string()),
                Ok(c) => c
                    .sensors
                    .iter()
                    .find(|r| &r.name == folder)
                    .map(|r| score(&files, s, &r.extrinsic))
                    .ok_or_else(|| format!("no result for {folder}")),
            };
            runs.push(MethodRun { method: m, sensor: folder.clone(), outcome, seconds });
        }
    }
    Ok(Trial { index, seed, runs })
}

/// Scores an estimated extrinsic of sensor `s` on each of its frames.
fn score(files: &TwinFiles, s: usize, estimate: &gmmcalib::Pose) -> Scored {
    let twin = &files.twin;
    let truth = &twin.truth[s].1;
    let cube = match &files.model {
        Model::RayCast(preset) => preset.validation_box.map(|i| &preset.scene.boxes[i]),
        Model::Sampled(_) => None,
    };
    let mut global = GlobalError::new(RANGE_BIN);
    let mut frames = Vec::new();
    for view in twin.scans.iter().filter(|v| files.sensor_of(&v.sensor) == s) {
        let points = &view.cloud.points;
        global.add_scan(points, estimate, truth);
        frames.push(FrameScore {
            frame: view.frame.clone(),
            validation: cube
                .and_then(|c| eval::distance_error(points, estimate, truth, eval::on_box(c))),
            scan: eval::distance_error(points, estimate, truth, |_| true),
        });
    }
    Scored { transform: eval::transform_error(estimate, truth), frames, global }
}
