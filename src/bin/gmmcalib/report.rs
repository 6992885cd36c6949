//! Results for people (text on stdout) and for programs (JSON). Angles: rad in JSON, deg in text.

use std::fmt::Write;

use gmmcalib::calib::{Calibration, FrameNote, SensorResult};
use gmmcalib::se3::{Pose, to_row_major, xyz_rpy};
use serde::Serialize;

type Matrix = [[f64; 4]; 4];

#[derive(Serialize)]
pub struct Report {
    method: &'static str,
    reference: String,
    iterations: usize,
    converged: bool,
    sensors: Vec<Sensor>,
    target: Target,
    skipped: Vec<Note>,
    kept_jrmpc: Vec<Note>,
}

#[derive(Serialize)]
struct Sensor {
    name: String,
    /// `C_ref_s`, row-major.
    correction: Matrix,
    /// Corrected `T_vehicle_sensor`.
    extrinsic: Matrix,
    /// `T_ref_s`.
    relative: Matrix,
    /// Of the corrected extrinsic: m and rad.
    xyz: [f64; 3],
    rpy: [f64; 3],
    spread: Spread,
}

#[derive(Serialize)]
struct Spread {
    xyz: [f64; 3],
    rpy: [f64; 3],
    frames: usize,
}

#[derive(Serialize)]
struct Target {
    means: Vec<[f64; 3]>,
    sigmas: Vec<f64>,
    /// RMS distance (m) of the means from the fitted prior shape; null without a fit.
    rms: Option<f64>,
    /// Fitted target size (m): cube edge or sphere diameter.
    edge: Option<f64>,
}

#[derive(Serialize)]
struct Note {
    sensor: String,
    frame: String,
    reason: String,
}

impl From<&Calibration> for Report {
    fn from(c: &Calibration) -> Self {
        let notes = |n: &[FrameNote]| {
            n.iter()
                .map(|n| Note {
                    sensor: n.sensor.clone(),
                    frame: n.frame.clone(),
                    reason: n.reason.clone(),
                })
                .collect()
        };
        Report {
            method: c.method.name(),
            reference: c.reference.clone(),
            iterations: c.iterations,
            converged: c.converged,
            sensors: c.sensors.iter().map(sensor).collect(),
            target: Target {
                means: c.target.means.clone(),
                sigmas: c.target.sigmas.clone(),
                rms: c.target.fit.map(|f| f.rms),
                edge: c.target.fit.map(|f| f.size),
            },
            skipped: notes(&c.skipped),
            kept_jrmpc: notes(&c.kept_jrmpc),
        }
    }
}

fn sensor(s: &SensorResult) -> Sensor {
    let (xyz, rpy) = xyz_rpy(&s.extrinsic);
    Sensor {
        name: s.name.clone(),
        correction: matrix(&s.correction),
        extrinsic: matrix(&s.extrinsic),
        relative: matrix(&s.relative),
        xyz,
        rpy,
        spread: Spread { xyz: s.spread.xyz, rpy: s.spread.rpy, frames: s.spread.frames },
    }
}

fn matrix(pose: &Pose) -> Matrix {
    let m = to_row_major(pose);
    std::array::from_fn(|r| std::array::from_fn(|c| m[4 * r + c]))
}

/// The human summary of one calibration.
pub fn summary(c: &Calibration) -> String {
    let mut out = String::new();
    let state = if c.converged { "converged" } else { "not converged" };
    let _ = writeln!(
        out,
        "method {}, reference {}, {} iterations, {state}",
        c.method.name(),
        c.reference,
        c.iterations
    );
    for s in &c.sensors {
        let (cx, cr) = xyz_rpy(&s.correction);
        let (ex, er) = xyz_rpy(&s.extrinsic);
        let _ = writeln!(out, "\n{}", s.name);
        let _ = writeln!(out, "  correction  xyz {} m   rpy {} deg", m3(cx), deg3(cr));
        let _ = writeln!(out, "  extrinsic   xyz {} m   rpy {} deg", m3(ex), deg3(er));
        let _ = writeln!(
            out,
            "  spread      xyz {} m   rpy {} deg   ({} frames)",
            m3(s.spread.xyz),
            deg3(s.spread.rpy),
            s.spread.frames
        );
    }
    if let Some(fit) = c.target.fit {
        let _ = writeln!(out, "\ntarget fit: rms {:.4} m, edge {:.4} m", fit.rms, fit.size);
    }
    notes(&mut out, "skipped", &c.skipped);
    notes(&mut out, "refinement rejected, kept the JRMPC correction", &c.kept_jrmpc);
    out
}

/// One table comparing several calibrations of the same frames.
pub fn comparison(results: &[Calibration]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<6} {:<10} {:>26} {:>26} {:>26} {:>26} {:>6}",
        "method",
        "sensor",
        "extrinsic xyz (m)",
        "extrinsic rpy (deg)",
        "spread xyz (m)",
        "spread rpy (deg)",
        "frames"
    );
    for c in results {
        for s in &c.sensors {
            let (xyz, rpy) = xyz_rpy(&s.extrinsic);
            let _ = writeln!(
                out,
                "{:<6} {:<10} {:>26} {:>26} {:>26} {:>26} {:>6}",
                c.method.name(),
                s.name,
                m3(xyz),
                deg3(rpy),
                m3(s.spread.xyz),
                deg3(s.spread.rpy),
                s.spread.frames
            );
        }
    }
    for c in results {
        let label = format!("{}: skipped", c.method.name());
        notes(&mut out, &label, &c.skipped);
        let label = format!("{}: refinement rejected, kept the JRMPC correction", c.method.name());
        notes(&mut out, &label, &c.kept_jrmpc);
    }
    out
}

fn notes(out: &mut String, title: &str, notes: &[FrameNote]) {
    if notes.is_empty() {
        return;
    }
    let _ = writeln!(out, "\n{title}:");
    for n in notes {
        let _ = writeln!(out, "  {}/{}: {}", n.sensor, n.frame, n.reason);
    }
}

fn m3(v: [f64; 3]) -> String {
    format!("{:8.4} {:8.4} {:8.4}", v[0], v[1], v[2])
}

fn deg3(v: [f64; 3]) -> String {
    format!("{:8.3} {:8.3} {:8.3}", v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees())
}
