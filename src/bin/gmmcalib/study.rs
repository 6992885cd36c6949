//! `gmmcalib study`: accuracy on the digital twin. Seeds `1..=seeds` of the scans, each
//! calibrated from `starts` wrong nominals (start `k` of seed `s` draws its miscalibration from
//! seed `1000 s + k`); prints the error distributions, every trial, each sensor's own, and the
//! precision the calibrations claimed against their errors. Trials run on worker threads and
//! are printed in order: the output does not depend on the thread count.

use std::time::Instant;

use gmmcalib::calib::{Level, Method, Settings};
use gmmcalib::eval::{self, SensorError};
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::xyz_rpy;
use gmmcalib::twin::{self, Miscalibration, Model, Twin};

use crate::args::StudyArgs;
use crate::layout::{model, start_seed};
use crate::parallel::on_threads;

/// One trial: the errors per non-reference sensor, and what the run cost and said.
struct Trial {
    errors: Vec<SensorError>,
    /// The result's overall verdict.
    verdict: Level,
    micros: u128,
    iterations: usize,
    /// Gaussian terms JRMPC's E-steps evaluated.
    terms: u64,
    warnings: usize,
    notes: Vec<String>,
    /// The largest reconstructed target's fit: RMS (m) and size (m).
    target: Option<(f64, f64)>,
}

pub fn run(a: &StudyArgs) -> Result<(), String> {
    let mut model = model(&a.preset)?;
    if let Model::RayCast(preset) = &mut model {
        for s in &mut preset.sensors {
            // Columns are a spinning LiDAR's; a rosette keeps its shots.
            if let (Some(spinning), Some(columns)) = (s.lidar.spinning_mut(), a.columns) {
                spinning.horizontal_steps = columns;
            }
            if let Some(noise) = a.noise {
                *s.lidar.range_noise_mut() = noise;
            }
        }
    }
    let method = a.method.parse::<Method>().map_err(|e| e.to_string())?;
    let mut settings = settings(a)?;
    // The scene's own target unless the flag names another.
    if a.target.is_none() {
        settings.target = model.target();
    }
    let angle = a.max_angle_deg.to_radians();
    let yaw = a.max_yaw_deg.map_or(angle, f64::to_radians);
    let translation = a.max_translation;
    let jobs: Vec<(u64, u64)> =
        (1..=a.seeds).flat_map(|s| (0..a.starts).map(move |k| (s, k))).collect();
    let trials = on_threads(
        jobs.len(),
        a.threads,
        || {},
        |j| {
            let (seed, start) = jobs[j];
            let draw = Miscalibration {
                angle: [angle, angle, yaw],
                translation: [translation; 3],
                seed: Some(start_seed(seed, start)),
            };
            // A calibration that fails is a finding of the study, not the end of it.
            Ok(trial(&model, a.frames, seed, &draw, (method, &settings), a.notes, a.jitter))
        },
    )?;
    let mut done = Vec::new();
    let mut failed = 0;
    for (&(seed, start), t) in jobs.iter().zip(trials) {
        match t {
            Ok(t) => {
                for note in &t.notes {
                    println!("seed {seed} start {start}: {note}");
                }
                done.push(((seed, start), t));
            }
            Err(e) => {
                println!("seed {seed} start {start}: error: {e}");
                failed += 1;
            }
        }
    }
    let (jobs, trials): (Vec<_>, Vec<_>) = done.into_iter().unzip();
    if !trials.is_empty() {
        report(&jobs, &trials, a.poses);
    }
    println!("calibrations that ended in an error: {failed} of {}", jobs.len() + failed);
    Ok(())
}

/// The settings the flags make.
fn settings(a: &StudyArgs) -> Result<Settings, String> {
    let mut settings = Settings::default();
    if let Some(k) = a.components {
        settings.components = k;
    }
    if let Some(n) = a.iterations {
        settings.jrmpc.max_iterations = n;
    }
    if let Some(t) = a.tolerance {
        (settings.jrmpc.tolerance, settings.gmm_em.tolerance) = (t, t);
    }
    if !a.bev {
        settings.bev = None;
    }
    if !a.planes {
        settings.planes = None;
    }
    settings.gmm_em.multiresolution = a.multiresolution;
    settings.jrmpc.exact = a.exact;
    settings.level_ground = a.level;
    settings.align_globally = a.global;
    if let Some(target) = &a.target {
        settings.target = crate::args::target(target, std::path::Path::new("."))
            .map_err(|e| format!("--target: {e}"))?;
    }
    Ok(settings)
}

/// One trial: `frames` scans of `model` from `seed`, nominals drawn by `draw`, calibrated by
/// `method` under `settings`.
fn trial(
    model: &Model,
    frames: usize,
    seed: u64,
    draw: &Miscalibration,
    (method, settings): (Method, &Settings),
    notes: bool,
    jitter_ulps: u32,
) -> Result<Trial, String> {
    let twin = Twin::new(model, frames, seed, draw);
    let mut rig = twin.rig();
    if jitter_ulps > 0 {
        eval::jitter(&mut rig, jitter_ulps, twin::derive_seed(draw.seed.unwrap_or(seed), 1));
    }
    let clock = Instant::now();
    let result = gmmcalib::calib::calibrate(&rig, method, settings, |_| Control::Continue)
        .map_err(|e| format!("seed {seed}: {e}"))?;
    let micros = clock.elapsed().as_micros();
    let errors = eval::sensor_errors(&twin, &result)
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| format!("seed {seed}: a sensor has no result"))?;
    let mut said = Vec::new();
    if notes {
        for note in &result.plane_adjustment {
            said.push(format!("{}: {}", note.sensor, note.kind));
        }
        for s in &result.selection {
            let h = s.chosen();
            let score = 100.0 * h.score.value();
            said.push(format!("{}: chose {} ({score:.1} %)", s.sensor, h.source.name()));
        }
        // Why a trial is not good: the reasons at its level.
        let level = result.verdict.level;
        let sensors = result.verdict.sensors.iter().map(|s| (s.sensor.as_str(), &s.reasons));
        for (sensor, reasons) in std::iter::once(("all", &result.verdict.reasons)).chain(sensors) {
            for r in reasons.iter().filter(|r| r.level == level && level != Level::Good) {
                said.push(format!("{sensor}: verdict {}: {}", level.name(), r.kind));
            }
        }
        for l in &result.levelling {
            if let Some(b) = &l.bev {
                let share = b.score / b.points as f64;
                said.push(format!("{}: bird's-eye overlap {share:.3}", l.sensor));
            }
            if let Some(w) = &l.warning {
                said.push(format!("{}: warning: {w}", l.sensor));
            }
        }
    }
    Ok(Trial {
        errors,
        verdict: result.verdict.level,
        micros,
        iterations: result.iterations,
        terms: result.history.iter().map(|h| h.terms).sum(),
        warnings: result.levelling.iter().filter(|l| l.warning.is_some()).count(),
        notes: said,
        target: result.reconstruction.fits.first().map(|f| (f.rms, f.size)),
    })
}

/// Prints the study's figures.
fn report(jobs: &[(u64, u64)], trials: &[Trial], poses: bool) {
    let errors: Vec<&SensorError> = trials.iter().flat_map(|t| &t.errors).collect();
    for line in precision_check(&errors) {
        println!("{line}");
    }
    // Coverage over the results a user would take (not `failed`): the wrong ones fail.
    let taken: Vec<&SensorError> =
        (trials.iter().filter(|t| t.verdict != Level::Failed)).flat_map(|t| &t.errors).collect();
    let (claimed, shares) = eval::precision_coverage(taken.iter().copied());
    let percent = |s: &[f64]| s.iter().map(|v| format!("{:.0}", v * 1e2)).collect::<Vec<_>>();
    println!(
        "one-sigma coverage over the {claimed} results not failed (honest: about 68 %): \
         rotation x y z {} %, position x y z {} %",
        percent(&shares[..3]).join(" "),
        percent(&shares[3..]).join(" ")
    );
    // Per error: |roll, pitch, yaw| (deg) and |x, y, z| (mm).
    let axes: Vec<[f64; 6]> = errors
        .iter()
        .map(|e| {
            let (xyz, rpy) = xyz_rpy(&e.error);
            [0, 1, 2, 3, 4, 5]
                .map(|i| if i < 3 { rpy[i].to_degrees().abs() } else { xyz[i - 3].abs() * 1e3 })
        })
        .collect();
    let mean_axis = |i: usize| axes.iter().map(|a| a[i]).sum::<f64>() / axes.len() as f64;
    println!(
        "mean |roll pitch yaw| (deg) {:.4} {:.4} {:.4}, |x y z| (mm) {:.2} {:.2} {:.2}",
        mean_axis(0),
        mean_axis(1),
        mean_axis(2),
        mean_axis(3),
        mean_axis(4),
        mean_axis(5)
    );
    // Signed means: a bias shows here, seed noise averages out.
    let signed: Vec<[f64; 2]> = errors
        .iter()
        .map(|e| {
            let (xyz, rpy) = xyz_rpy(&e.error);
            [rpy[2].to_degrees(), xyz[1] * 1e3]
        })
        .collect();
    let n = signed.len() as f64;
    println!(
        "signed mean yaw {:.4} deg, y {:.2} mm",
        signed.iter().map(|s| s[0]).sum::<f64>() / n,
        signed.iter().map(|s| s[1]).sum::<f64>() / n
    );
    for ((seed, start), t) in jobs.iter().zip(trials) {
        let cells: Vec<String> = t
            .errors
            .iter()
            .map(SensorError::deg_m)
            .map(|(a, m)| format!("{a:.4} deg {:.2} mm", m * 1e3))
            .collect();
        println!("seed {seed} start {start}: {} | verdict {}", cells.join(" | "), t.verdict.name());
        if poses {
            for e in &t.errors {
                let r = e.rotation.map(|a| a.to_degrees() * 1e3);
                let p = e.position * 1e3;
                // What the calibration claimed, to weigh a move between two runs against.
                let claimed = e.precision.as_ref().map_or(String::new(), |c| {
                    let r = c.rotation.map(|a| a.to_degrees() * 1e3);
                    let p = c.position.map(|m| m * 1e3);
                    format!(
                        "; claimed {:.2} {:.2} {:.2} mdeg, {:.3} {:.3} {:.3} mm",
                        r[0], r[1], r[2], p[0], p[1], p[2]
                    )
                });
                println!(
                    "seed {seed} start {start} pose: rotation {:.5} {:.5} {:.5} mdeg, position {:.5} {:.5} {:.5} mm{claimed}",
                    r.x, r.y, r.z, p.x, p.y, p.z
                );
            }
            if let Some((rms, size)) = t.target {
                println!(
                    "seed {seed} start {start} target: rms {:.3} mm, size {:.4} m",
                    rms * 1e3,
                    size
                );
            }
        }
    }
    let all: Vec<(f64, f64)> = errors.iter().map(|e| e.deg_m()).collect();
    let columns = |errors: &[(f64, f64)]| -> (Vec<f64>, Vec<f64>) {
        errors.iter().map(|(a, t)| (*a, t * 1e3)).unzip()
    };
    let (angles, shifts) = columns(&all);
    let good = all.iter().filter(|(a, t)| *a <= 0.1 && *t <= 0.01).count();
    println!("rotation (deg): {}", summary(&angles));
    println!("translation (mm): {}", summary(&shifts));
    println!("within 0.1 deg & 1 cm: {good} of {}", all.len());
    // Did the verdict flag the trials outside? A trial is outside when any sensor is.
    let outside = |t: &Trial| t.errors.iter().any(|e| e.deg_m().0 > 0.1 || e.deg_m().1 > 0.01);
    let count = |level: Level, out: bool| {
        trials.iter().filter(|t| t.verdict == level && outside(t) == out).count()
    };
    println!(
        "verdict of the trials within: {} good, {} check, {} failed; outside: {} good, {} check, {} failed",
        count(Level::Good, false),
        count(Level::Check, false),
        count(Level::Failed, false),
        count(Level::Good, true),
        count(Level::Check, true),
        count(Level::Failed, true)
    );
    // With several non-reference sensors, each one's own distribution.
    let sensors = trials.first().map_or(0, |t| t.errors.len());
    for s in (0..sensors).filter(|_| sensors > 1) {
        let own: Vec<(f64, f64)> = trials.iter().map(|t| t.errors[s].deg_m()).collect();
        let (angles, shifts) = columns(&own);
        println!("sensor {}: {} deg, {} mm", s + 1, summary(&angles), summary(&shifts));
    }
    let count = trials.len().max(1) as f64;
    let seconds = trials.iter().map(|t| t.micros).sum::<u128>() as f64 * 1e-6;
    println!("calibration: {:.2} s each (trials run in parallel)", seconds / count);
    let iterations = trials.iter().map(|t| t.iterations).sum::<usize>() as f64;
    println!("JRMPC iterations: {:.1} each", iterations / count);
    let terms = trials.iter().map(|t| t.terms as f64).sum::<f64>();
    println!("JRMPC's Gaussian terms: {:.2} M each", terms / count * 1e-6);
    println!("levelling warnings: {}", trials.iter().map(|t| t.warnings).sum::<usize>());
    // The reconstruction's convergence: its largest target's fit.
    let (rms, sizes): (Vec<f64>, Vec<f64>) =
        trials.iter().filter_map(|t| t.target).map(|(r, s)| (r * 1e3, s)).unzip();
    if !rms.is_empty() {
        println!("largest target's fit: rms (mm) {}; size (m) {}", summary(&rms), summary(&sizes));
    }
}

/// Median and maximum.
fn summary(values: &[f64]) -> String {
    match eval::stats(values) {
        Some(s) => format!("median {:.4}, max {:.4}", s.median, s.max),
        None => "none".into(),
    }
}

/// The RMS error over `errors` against the RMS of the one-sigma precision claimed, per axis.
fn precision_check(errors: &[&SensorError]) -> Vec<String> {
    let (claimed, axes) = eval::precision_rms(errors.iter().copied());
    let mut lines =
        vec![format!("precision claimed by {claimed} of {} calibrations", errors.len())];
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let (error, claim) = axes[i];
        lines.push(format!(
            "rotation about {axis}: RMS error {:.4} deg, claimed {:.4} deg (ratio {:.2})",
            error.to_degrees(),
            claim.to_degrees(),
            error / claim
        ));
    }
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        let (error, claim) = axes[3 + i];
        lines.push(format!(
            "position {axis}: RMS error {:.2} mm, claimed {:.2} mm (ratio {:.2})",
            error * 1e3,
            claim * 1e3,
            error / claim
        ));
    }
    lines
}
