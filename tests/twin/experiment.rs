//! `gmmcalib simulate` and `gmmcalib experiment` end to end: the written twin agrees with its
//! truth through the files, `gmmcalib calibrate` runs on it unchanged and recovers the truth,
//! and a small experiment writes every output with finite numbers, identically on 1 or 2
//! threads.

#![cfg(not(target_arch = "wasm32"))]

use std::fs;
use std::path::Path;
use std::process::Command;

use crate::common::TempDir;
use gmmcalib::io::parse_cloud;
use gmmcalib::se3::{Pose, from_row_major, pose_from_xyz_rpy};
use gmmcalib::twin::Preset;
use nalgebra::Point3;
use serde_json::Value;

fn gmmcalib(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_gmmcalib")).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "gmmcalib {args:?}: exit {:?}: {stderr}", out.status);
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
}

/// A row-major 4x4 matrix, written as 4 rows (truth.json) or 16 numbers (`--json`).
fn matrix(v: &Value) -> Pose {
    let m: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| match r.as_array() {
            Some(row) => row.iter().map(|x| x.as_f64().unwrap()).collect(),
            None => vec![r.as_f64().unwrap()],
        })
        .collect();
    from_row_major(&m.try_into().unwrap())
}

fn max_diff(a: &Pose, b: &Pose) -> f64 {
    (a.to_homogeneous() - b.to_homogeneous()).abs().max()
}

/// `transform_<folder>`'s six numbers from config.yaml, as a pose.
fn config_nominal(config: &str, folder: &str) -> Pose {
    let yaml: serde_norway::Value = serde_norway::from_str(config).unwrap();
    let v: Vec<f64> = yaml[format!("transform_{folder}").as_str()][0]
        .as_sequence()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    pose_from_xyz_rpy([v[3], v[4], v[5]], [v[0], v[1], v[2]])
}

#[test]
fn simulated_files_agree_with_the_truth() {
    let tmp = TempDir::new("truth");
    let dir = tmp.0.to_str().unwrap();
    gmmcalib(&["simulate", "--preset", "paper", "--frames", "2", "--seed", "3", "--out", dir]);
    let truth = json(&tmp.0.join("truth.json"));
    let config = fs::read_to_string(tmp.0.join("config.yaml")).unwrap();
    assert_eq!((truth["preset"].as_str(), truth["seed"].as_u64()), (Some("paper"), Some(3)));
    assert_eq!(truth["reference"], "sensor_1");

    // The same scans, simulated in memory from the same seed (frame by frame, sensor by sensor).
    let preset = Preset::paper();
    let views = preset.simulate(2, 3);
    let sensors = truth["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), preset.sensors.len());
    let mut checked = 0;
    for (i, (s, spec)) in sensors.iter().zip(&preset.sensors).enumerate() {
        let folder = s["folder"].as_str().unwrap();
        assert_eq!(
            (folder, s["name"].as_str().unwrap()),
            (format!("sensor_{}", i + 1).as_str(), spec.name.as_str())
        );
        // Transforms, all f64: truth.json's truth is the preset's mount, config.yaml's nominal
        // is truth.json's, and correction * nominal = truth. Compared to 1e-9 (they agree to a
        // few ulp; a convention error would show at 1e-2).
        let true_mount = matrix(&s["truth"]);
        let nominal = config_nominal(&config, folder);
        let correction = matrix(&s["correction"]);
        assert!(max_diff(&true_mount, &spec.mount) < 1e-9);
        assert!(max_diff(&nominal, &matrix(&s["nominal"])) < 1e-9);
        assert!(max_diff(&(correction * nominal), &true_mount) < 1e-9);
        if i == 0 {
            assert!(max_diff(&nominal, &true_mount) < 1e-12, "the reference keeps its mount");
        } else {
            assert!(max_diff(&nominal, &true_mount) > 1e-3, "the others are miscalibrated");
        }
        for frame in 1..=2 {
            let file = tmp.0.join("data").join(folder).join(format!("{frame}.pcd"));
            let parsed = parse_cloud(&fs::read(&file).unwrap(), "f.pcd").unwrap();
            let view = &views[(frame - 1) * sensors.len() + i];
            // Organized like the scan, misses written as zeros and dropped on reading.
            assert_eq!((parsed.width, parsed.height), (view.width, view.height));
            let hits: Vec<[f32; 3]> =
                view.cloud.points.iter().copied().filter(|p| *p != [0.0; 3]).collect();
            assert_eq!(parsed.dropped, view.cloud.len() - hits.len());
            // Points: the file holds the simulator's f32 values bit for bit, so f32 storage
            // loses nothing between simulation and calibration input.
            assert_eq!(parsed.cloud.points, hits);
            // Through the files: pre-aligned with config.yaml's nominal, then corrected with
            // truth.json's correction, each point lands where the true mount puts it. Both
            // sides map the same f32 point in f64, so 1e-6 m is a real bound (errors are ~1e-14
            // m at 50 m), not one the f32 rounding of the points could hide.
            for p in &parsed.cloud.points {
                let p = Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                let corrected = correction * (nominal * p);
                assert!((corrected - true_mount * p).norm() < 1e-6);
                checked += 1;
            }
        }
    }
    assert!(checked > 50_000, "{checked}");
}

#[test]
fn calibrate_runs_on_a_simulated_folder_and_recovers_the_truth() {
    let tmp = TempDir::new("calibrate");
    let dir = tmp.0.to_str().unwrap();
    gmmcalib(&["simulate", "--frames", "2", "--seed", "11", "--out", dir]);
    let (config, data) = (tmp.0.join("config.yaml"), tmp.0.join("data"));
    let out = tmp.0.join("result.json");
    gmmcalib(&[
        "calibrate",
        "--config",
        config.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--method",
        "gmm",
        "--json",
        out.to_str().unwrap(),
    ]);
    let truth = json(&tmp.0.join("truth.json"));
    let result = json(&out);
    assert_eq!(result["reference"], "sensor_1");
    for s in truth["sensors"].as_array().unwrap() {
        let folder = s["folder"].as_str().unwrap();
        let estimate = result["sensors"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["name"] == folder)
            .map(|r| matrix(&r["extrinsic"]))
            .unwrap();
        let (truth, nominal) = (matrix(&s["truth"]), matrix(&s["nominal"]));
        let error = estimate.inverse() * truth;
        let (angle, shift) = (error.rotation.angle().to_degrees(), error.translation.vector.norm());
        let start = (nominal.inverse() * truth).rotation.angle().to_degrees();
        eprintln!(
            "{folder}: {angle:.3} deg / {:.1} mm (nominal off by {start:.2} deg)",
            shift * 1e3
        );
        // Loose: the twin's scans, 2 frames; the miscalibration is up to 3 deg / 10 cm per axis.
        assert!(angle < 0.2 && shift < 0.02, "{folder}: {angle} deg, {shift} m");
    }
}

/// Every number in `v` finite, no nulls; returns how many numbers it saw.
fn all_finite(v: &Value, at: &str) -> usize {
    match v {
        Value::Null => panic!("{at} is null"),
        Value::Number(n) => {
            assert!(n.as_f64().unwrap().is_finite(), "{at} = {n}");
            1
        }
        Value::Array(a) => {
            a.iter().enumerate().map(|(i, x)| all_finite(x, &format!("{at}[{i}]"))).sum()
        }
        Value::Object(o) => o.iter().map(|(k, x)| all_finite(x, &format!("{at}.{k}"))).sum(),
        _ => 0,
    }
}

#[test]
fn small_experiment_writes_every_output_with_finite_numbers() {
    let tmp = TempDir::new("run");
    let dir = tmp.0.to_str().unwrap();
    let methods = ["gmm", "jrmpc", "p2p", "p2l", "gicp"];
    gmmcalib(&[
        "experiment",
        "--preset",
        "paper",
        "--trials",
        "3",
        "--frames",
        "4",
        "--seed",
        "5",
        "--methods",
        &methods.join(","),
        "--out",
        dir,
    ]);
    let summary = json(&tmp.0.join("summary.json"));
    let numbers = all_finite(&summary, "summary");
    assert_eq!((summary["trials"].as_u64(), summary["frames"].as_u64()), (Some(3), Some(4)));
    assert_eq!(summary["miscalibration_threshold"].as_f64(), Some(0.05));
    let per_method = summary["methods"].as_array().unwrap();
    assert_eq!(per_method.len(), methods.len());
    for (m, name) in per_method.iter().zip(methods) {
        assert_eq!(m["method"], name);
        assert_eq!((m["runs"].as_u64(), m["failed"].as_u64()), (Some(3), Some(0)));
        assert!(m["miscalibrated"].as_u64().unwrap() <= 3);
        for axis in ["roll", "pitch", "yaw", "x", "y", "z"] {
            let s = &m["transform_error"][axis];
            assert_eq!(s["count"].as_u64(), Some(3), "{name} {axis}");
            for k in ["mean", "std", "min", "q1", "median", "q3", "max"] {
                assert!(s[k].as_f64().unwrap() >= 0.0, "{name} {axis} {k}");
            }
        }
        for region in ["validation_error", "scan_error"] {
            for axis in ["x", "y", "z", "norm"] {
                let s = &m[region][axis];
                assert_eq!(s["count"].as_u64(), Some(12), "{name} {region} {axis}");
                assert!(s["q1"].as_f64() <= s["median"].as_f64());
                assert!(s["median"].as_f64() <= s["q3"].as_f64());
            }
        }
        let fit = &m["global_fit"];
        assert!(fit["points"].as_u64().unwrap() > 100_000);
        assert!(fit["slope"].is_f64() && fit["intercept"].is_f64());
    }
    assert!(numbers > 5 * (6 + 8) * 8, "{numbers}");

    // One CSV row per trial, method and frame.
    let csv = fs::read_to_string(tmp.0.join("trials.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    // The summary's miscalibration count is the CSV's: trials flagged in their rows.
    for (m, name) in per_method.iter().zip(methods) {
        let flagged: std::collections::BTreeSet<&str> = lines
            .iter()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|c| c[2] == name && c[20] == "true")
            .map(|c| c[0])
            .collect();
        assert_eq!(m["miscalibrated"].as_u64(), Some(flagged.len() as u64), "{name}");
    }
    assert!(lines[0].starts_with("trial,seed,method,sensor,frame,roll"));
    assert_eq!(lines.len(), 1 + 3 * methods.len() * 4);
    let columns = lines[0].split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == columns));
    // The table sets ours next to the paper's numbers.
    let table = fs::read_to_string(tmp.0.join("table.md")).unwrap();
    for name in methods {
        assert!(table.contains(&format!("| `{name}` | ours |")), "{table}");
    }
    assert!(table.contains("| GICP | paper | 0.0006 | 0.0007 | 0.0139 | 0.072 | 0.179 | 0.009 |"));
    for plot in ["distance_error.svg", "global_error.svg"] {
        let svg = fs::read_to_string(tmp.0.join(plot)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("<rect"), "{plot}");
    }
}

#[test]
fn threads_do_not_change_the_results() {
    let runs: Vec<String> = ["1", "2"]
        .iter()
        .map(|threads| {
            let tmp = TempDir::new(&format!("threads{threads}"));
            gmmcalib(&[
                "experiment",
                "--trials",
                "3",
                "--frames",
                "1",
                "--seed",
                "8",
                "--methods",
                "p2l",
                "--threads",
                threads,
                "--out",
                tmp.0.to_str().unwrap(),
            ]);
            fs::read_to_string(tmp.0.join("trials.csv")).unwrap()
        })
        .collect();
    assert_eq!(runs[0].lines().count(), 4);
    assert_eq!(runs[0], runs[1]);
}
