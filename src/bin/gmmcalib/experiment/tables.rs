//! The experiment's outputs as text: `summary.json`, `trials.csv` and `table.md`.

use std::fmt::Write as _;

use gmmcalib::calib::Method;
use gmmcalib::eval::{self, DistanceError, MISCALIBRATION_THRESHOLD, Stats};
use serde_json::{Value, json};

use super::trials::{MethodRun, Trial, frame_values, global, miscalibrated, transform_values};
use crate::args::ExperimentArgs;

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

pub fn summary(a: &ExperimentArgs, methods: &[Method], trials: &[Trial], seconds: f64) -> Value {
    let per_method: Vec<Value> = methods
        .iter()
        .enumerate()
        .map(|(m, method)| {
            let runs: Vec<&MethodRun> =
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

pub fn csv(methods: &[Method], trials: &[Trial]) -> String {
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
pub fn table(a: &ExperimentArgs, methods: &[Method], trials: &[Trial]) -> String {
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
