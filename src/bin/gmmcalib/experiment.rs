//! `gmmcalib experiment`: the paper's experiment (section V) on the digital twin. Each trial
//! simulates fresh frames under a fresh miscalibration (seed derived from `--seed` and the trial
//! index), runs every method on the same frames, and scores each estimate against the truth
//! with `gmmcalib::eval`. Trials run on worker threads; each is a pure function of its seed, so
//! the results equal a serial run's and are written in trial order.

use std::fmt::Write as _;
use std::fs;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use gmmcalib::calib::{self, Method, Settings};
use gmmcalib::eval::{
    self, DistanceError, GlobalError, MISCALIBRATION_THRESHOLD, Stats, TransformError,
};
use gmmcalib::jrmpc::Control;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};

use crate::args::ExperimentArgs;
use crate::plots;
use crate::twin::{Twin, derive_seed};

/// Range bins of the global error profile (m).
const RANGE_BIN: f64 = 2.0;

/// The paper's Table II (mean errors: roll, pitch, yaw in rad; x, y, z in m).
const PAPER: [(&str, [f64; 6]); 4] = [
    ("GMM", [0.0033, 0.0036, 0.0020, 0.015, 0.027, 0.018]),
    ("point-to-point ICP", [0.0013, 0.0011, 0.0269, 0.088, 0.297, 0.013]),
    ("point-to-plane ICP", [0.0004, 0.0005, 0.0078, 0.034, 0.075, 0.006]),
    ("GICP", [0.0006, 0.0007, 0.0139, 0.072, 0.179, 0.009]),
];

/// The paper's row for one of our methods: GMMCalib's GMM is our `jrmpc`, and `gmm` refines it.
fn paper_row(method: Method) -> &'static (&'static str, [f64; 6]) {
    match method.name() {
        "p2p" => &PAPER[1],
        "p2l" => &PAPER[2],
        "gicp" => &PAPER[3],
        _ => &PAPER[0],
    }
}

/// One frame of a calibrated sensor, scored.
pub struct FrameScore {
    pub frame: String,
    pub validation: Option<DistanceError>,
    pub scan: Option<DistanceError>,
}

/// One method on one non-reference sensor of one trial.
pub struct Run {
    pub method: usize,
    pub sensor: String,
    pub outcome: Result<Scored, String>,
    pub seconds: f64,
}

pub struct Scored {
    pub transform: TransformError,
    pub frames: Vec<FrameScore>,
    pub global: GlobalError,
}

impl Scored {
    /// Mean validation-cube error (L2, m) over the frames; NaN when the cube was never seen.
    fn validation_norm(&self) -> f64 {
        let v: Vec<f64> = self.frames.iter().filter_map(|f| f.validation.map(|d| d.norm)).collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    }
}

pub struct Trial {
    pub index: usize,
    pub seed: u64,
    pub runs: Vec<Run>,
}

pub fn run(a: &ExperimentArgs) -> Result<(), String> {
    let methods = methods(&a.methods)?;
    crate::twin::preset(&a.twin.preset)?;
    fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let started = Instant::now();
    let trials = run_trials(a, &methods)?;
    let seconds = started.elapsed().as_secs_f64();

    let summary = summary(a, &methods, &trials, seconds);
    let write = |name: &str, text: String| {
        let path = a.out.join(name);
        fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
    };
    let json = serde_json::to_string_pretty(&summary).map_err(|e| format!("JSON: {e}"))?;
    write("summary.json", json + "\n")?;
    write("trials.csv", csv(&methods, &trials))?;
    write("table.md", table(a, &methods, &trials))?;
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

/// `gmm,jrmpc,...` or `all`.
fn methods(list: &str) -> Result<Vec<Method>, String> {
    if list.trim().eq_ignore_ascii_case("all") {
        return Ok(Method::ALL.to_vec());
    }
    let methods: Vec<Method> = list
        .split(',')
        .map(|m| m.parse::<Method>().map_err(|e| e.to_string()))
        .collect::<Result<_, _>>()?;
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
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Trial, String>>>> =
        Mutex::new((0..a.trials).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                loop {
                    let index = next.fetch_add(1, Ordering::Relaxed);
                    if index >= a.trials {
                        break;
                    }
                    let trial = run_trial(a, methods, index);
                    let failed = trial.is_err();
                    if let Ok(mut r) = results.lock() {
                        r[index] = Some(trial);
                    }
                    bar.inc(1);
                    if failed {
                        // Stop handing out trials; the error is reported below.
                        next.store(a.trials, Ordering::Relaxed);
                    }
                }
            });
        }
    });
    bar.finish_and_clear();
    let results = results.into_inner().map_err(|_| "a worker thread panicked".to_string())?;
    results
        .into_iter()
        .enumerate()
        .map(|(i, r)| r.unwrap_or_else(|| Err(format!("trial {i} did not run"))))
        .collect()
}

/// One trial: simulate, then every method on the same rig, then score each non-reference sensor.
fn run_trial(a: &ExperimentArgs, methods: &[Method], index: usize) -> Result<Trial, String> {
    let seed = derive_seed(a.twin.seed, index as u64);
    let twin = Twin::new(&a.twin, seed)?;
    let rig = twin.rig();
    let mut runs = Vec::new();
    for (m, method) in methods.iter().enumerate() {
        let settings = Settings { method: *method, ..Settings::default() };
        let started = Instant::now();
        let result = calib::calibrate(&rig, &settings, |_| Control::Continue);
        let seconds = started.elapsed().as_secs_f64();
        for (s, sensor) in twin.sensors.iter().enumerate().skip(1) {
            let outcome = match &result {
                Err(e) => Err(e.to_string()),
                Ok(c) => c
                    .sensors
                    .iter()
                    .find(|r| r.name == sensor.folder)
                    .map(|r| score(&twin, s, &r.extrinsic))
                    .ok_or_else(|| format!("no result for {}", sensor.folder)),
            };
            runs.push(Run { method: m, sensor: sensor.folder.clone(), outcome, seconds });
        }
    }
    Ok(Trial { index, seed, runs })
}

/// Scores an estimated extrinsic of sensor `s` on each of its frames.
fn score(twin: &Twin, s: usize, estimate: &gmmcalib::Pose) -> Scored {
    let truth = &twin.sensors[s].truth;
    let cube = twin.preset.validation_box.map(|i| &twin.preset.scene.boxes[i]);
    let mut global = GlobalError::new(RANGE_BIN);
    let mut frames = Vec::new();
    for view in twin.views.iter().filter(|v| twin.sensor_of(v) == s) {
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

/// Runs of method `m` that produced an estimate.
pub fn scored<'a>(trials: &'a [Trial], m: usize) -> impl Iterator<Item = &'a Scored> + 'a {
    trials
        .iter()
        .flat_map(|t| &t.runs)
        .filter(move |r| r.method == m)
        .filter_map(|r| r.outcome.as_ref().ok())
}

/// Per-frame values of one axis (0..3: x, y, z; 3: L2) of the validation or whole-scan error.
pub fn frame_values(trials: &[Trial], m: usize, validation: bool, axis: usize) -> Vec<f64> {
    let pick = |d: &DistanceError| if axis < 3 { d.axes[axis] } else { d.norm };
    scored(trials, m)
        .flat_map(|s| &s.frames)
        .filter_map(|f| if validation { f.validation } else { f.scan })
        .map(|d| pick(&d))
        .collect()
}

/// Per-run transform error, axis 0..6: roll, pitch, yaw, x, y, z.
fn transform_values(trials: &[Trial], m: usize, axis: usize) -> Vec<f64> {
    scored(trials, m)
        .map(|s| if axis < 3 { s.transform.rpy[axis] } else { s.transform.xyz[axis - 3] })
        .collect()
}

pub fn global(trials: &[Trial], m: usize) -> GlobalError {
    let mut g = GlobalError::new(RANGE_BIN);
    for s in scored(trials, m) {
        g.merge(&s.global);
    }
    g
}

fn miscalibrated(trials: &[Trial], m: usize) -> usize {
    let runs = trials.iter().flat_map(|t| &t.runs).filter(|r| r.method == m);
    runs.filter(|r| {
        r.outcome.as_ref().map_or(true, |s| eval::is_miscalibrated(s.validation_norm()))
    })
    .count()
}

fn stats_json(values: &[f64]) -> Value {
    match eval::stats(values) {
        Some(Stats { count, mean, std, min, q1, median, q3, max }) => json!({
            "count": count, "mean": mean, "std": std, "min": min,
            "q1": q1, "median": median, "q3": q3, "max": max,
        }),
        None => Value::Null,
    }
}

const TRANSFORM_AXES: [&str; 6] = ["roll", "pitch", "yaw", "x", "y", "z"];
const DISTANCE_AXES: [&str; 4] = ["x", "y", "z", "norm"];

fn summary(a: &ExperimentArgs, methods: &[Method], trials: &[Trial], seconds: f64) -> Value {
    let per_method: Vec<Value> = methods
        .iter()
        .enumerate()
        .map(|(m, method)| {
            let runs: Vec<&Run> =
                trials.iter().flat_map(|t| &t.runs).filter(|r| r.method == m).collect();
            let distance = |validation: bool| -> Value {
                DISTANCE_AXES
                    .iter()
                    .enumerate()
                    .map(|(i, k)| {
                        (k.to_string(), stats_json(&frame_values(trials, m, validation, i)))
                    })
                    .collect::<serde_json::Map<_, _>>()
                    .into()
            };
            let transform: serde_json::Map<_, _> = TRANSFORM_AXES
                .iter()
                .enumerate()
                .map(|(i, k)| (k.to_string(), stats_json(&transform_values(trials, m, i))))
                .collect();
            let g = global(trials, m);
            let (slope, intercept) =
                g.fit.line().map_or((Value::Null, Value::Null), |(s, i)| (s.into(), i.into()));
            let secs: Vec<f64> = runs.iter().map(|r| r.seconds).collect();
            json!({
                "method": method.name(),
                "runs": runs.len(),
                "failed": runs.iter().filter(|r| r.outcome.is_err()).count(),
                "miscalibrated": miscalibrated(trials, m),
                "transform_error": transform,
                "validation_error": distance(true),
                "scan_error": distance(false),
                "global_fit": { "slope": slope, "intercept": intercept, "points": g.fit.count() },
                "seconds_per_run": secs.iter().sum::<f64>() / secs.len().max(1) as f64,
            })
        })
        .collect();
    json!({
        "preset": a.twin.preset,
        "trials": a.trials,
        "frames": a.twin.frames,
        "seed": a.twin.seed,
        "max_angle": a.twin.max_angle_deg.to_radians(),
        "max_translation": a.twin.max_translation,
        "miscalibration_threshold": MISCALIBRATION_THRESHOLD,
        "miscalibration_rule": "mean L2 distance error over the validation cube > threshold (m), or the method failed",
        "units": "rad and m; transform_error per run (dT = T_est^-1 T_true), distance errors per frame (paper eq. 5)",
        "global_abscissa": "range of the point from the sensor (m)",
        "seconds": seconds,
        "methods": per_method,
    })
}

fn csv(methods: &[Method], trials: &[Trial]) -> String {
    let mut out = String::from(
        "trial,seed,method,sensor,frame,roll,pitch,yaw,x,y,z,\
         validation_x,validation_y,validation_z,validation_norm,validation_points,\
         scan_x,scan_y,scan_z,scan_norm,miscalibrated,error\n",
    );
    let num = |d: Option<DistanceError>| match d {
        Some(d) => format!("{},{},{},{}", d.axes[0], d.axes[1], d.axes[2], d.norm),
        None => ",,,".to_string(),
    };
    for t in trials {
        for r in &t.runs {
            let head = format!("{},{},{},{}", t.index, t.seed, methods[r.method].name(), r.sensor);
            match &r.outcome {
                Err(e) => {
                    let e = e.replace([',', '\n'], ";");
                    let _ = writeln!(out, "{head},,,,,,,,,,,,,,,,,true,{e}");
                }
                Ok(s) => {
                    let (rpy, xyz) = (s.transform.rpy, s.transform.xyz);
                    let bad = eval::is_miscalibrated(s.validation_norm());
                    for f in &s.frames {
                        let _ = writeln!(
                            out,
                            "{head},{},{},{},{},{},{},{},{},{},{},{bad},",
                            f.frame,
                            rpy[0],
                            rpy[1],
                            rpy[2],
                            xyz[0],
                            xyz[1],
                            xyz[2],
                            num(f.validation),
                            f.validation.map_or(0, |d| d.points),
                            num(f.scan)
                        );
                    }
                }
            }
        }
    }
    out
}

/// Table II, ours next to the paper's, then the distance errors and the miscalibration count.
fn table(a: &ExperimentArgs, methods: &[Method], trials: &[Trial]) -> String {
    let mean = |v: Vec<f64>| eval::stats(&v).map_or(f64::NAN, |s| s.mean);
    let mut out = format!(
        "Mean transform error |dT| (rad, m), dT = T_est^-1 T_true: {} trials x {} frames, preset \
         {}, seed {}.\n\n| algorithm | source | roll | pitch | yaw | x | y | z |\n\
         |---|---|---|---|---|---|---|---|\n",
        a.trials, a.twin.frames, a.twin.preset, a.twin.seed
    );
    for (m, method) in methods.iter().enumerate() {
        let ours: Vec<String> = (0..6)
            .map(|i| {
                let v = mean(transform_values(trials, m, i));
                if i < 3 { format!("{v:.4}") } else { format!("{v:.3}") }
            })
            .collect();
        let (name, paper) = paper_row(*method);
        let paper: Vec<String> = paper
            .iter()
            .enumerate()
            .map(|(i, v)| if i < 3 { format!("{v:.4}") } else { format!("{v:.3}") })
            .collect();
        let _ = writeln!(out, "| `{}` | ours | {} |", method.name(), ours.join(" | "));
        let _ = writeln!(out, "| {name} | paper | {} |", paper.join(" | "));
    }
    let _ = write!(
        out,
        "\nDistance error (paper eq. 5, m): mean per axis over the validation cube and whole \
         scans; miscalibrated: trials whose mean validation-cube error exceeds {:.2} m (or that \
         failed); global: error vs range fit over whole scans.\n\n\
         | method | cube x | cube y | cube z | cube L2 | scan L2 | miscalibrated | global slope (m/m) | global intercept (m) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        MISCALIBRATION_THRESHOLD
    );
    for (m, method) in methods.iter().enumerate() {
        let cube: Vec<String> =
            (0..4).map(|i| format!("{:.4}", mean(frame_values(trials, m, true, i)))).collect();
        let scan = mean(frame_values(trials, m, false, 3));
        let (slope, intercept) = global(trials, m).fit.line().unwrap_or((f64::NAN, f64::NAN));
        let runs = trials.iter().flat_map(|t| &t.runs).filter(|r| r.method == m).count();
        let _ = writeln!(
            out,
            "| `{}` | {} | {scan:.4} | {} / {runs} | {slope:.5} | {intercept:.4} |",
            method.name(),
            cube.join(" | "),
            miscalibrated(trials, m)
        );
    }
    out
}
