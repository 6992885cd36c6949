//! `gmmcalib calibrate`: GMMCalib's data folder (or OpenCalib's, or a recording) and YAML
//! config in, calibration out (text on stdout, JSON with `--json`).

use super::args::CalibrateArgs;
use super::recording::{self, BagRequest};
use super::{Host, dataset, parent, read_text};
use crate::calib::{self, Level, Method, Progress, Rig, Settings, Stage};
use crate::config::Config;
use crate::jrmpc::Control;
use crate::report::{self, Report};
use crate::targets::Target;

/// The exit status when the calibration ran but its verdict is `failed`: do not use the
/// extrinsic (1 is an error: nothing was calibrated).
pub const VERDICT_FAILED: u8 = 2;

/// The exit status for results whose verdicts are `levels`: `VERDICT_FAILED` when every
/// one failed.
fn status(levels: impl IntoIterator<Item = Level>) -> u8 {
    let mut levels = levels.into_iter().peekable();
    let any = levels.peek().is_some();
    if any && levels.all(|l| l == Level::Failed) { VERDICT_FAILED } else { 0 }
}

/// A `mesh:PATH` target's model, PATH relative to `dir`, read here: the library parses the
/// bytes.
fn target_mesh(host: &mut dyn Host, path: &str, dir: &str) -> Result<Target, String> {
    let path = super::join(dir, path);
    let bytes = host.read(&path).map_err(|e| format!("{path}: {e}"))?;
    Target::from_mesh_file(&bytes, &path).map_err(|e| e.to_string())
}

/// JRMPC's settings with the host's threads (`--threads` overrides them).
fn host_threads(host: &dyn Host) -> crate::jrmpc::EmSettings {
    crate::jrmpc::EmSettings { threads: host.threads(), ..Default::default() }
}

pub fn calibrate(a: &CalibrateArgs, host: &mut dyn Host) -> Result<u8, String> {
    // 1. The config, if any, with the command line taking precedence. A model file is read
    // relative to where it was named: the config's folder, or here.
    let (config, label) = match &a.config {
        Some(path) => {
            let text = read_text(host, path)?;
            (Some(Config::from_yaml(&text, path).map_err(|e| e.to_string())?), path.clone())
        }
        None => (None, String::new()),
    };
    let mut flags = a.settings.clone();
    flags.resolve_mesh(|path| target_mesh(host, path, "")).map_err(|e| format!("--target: {e}"))?;
    let mut input = flags;
    if let Some(config) = &config {
        let mut from_file = config.settings.clone();
        if input.target.is_none() {
            from_file
                .resolve_mesh(|path| target_mesh(host, path, parent(&label)))
                .map_err(|e| format!("{label}: target: {e}"))?;
        }
        input = input.or(from_file);
    }
    let mut settings = Settings { jrmpc: host_threads(host), ..Settings::default() };
    let methods = input.apply(&mut settings)?;

    // 2. Scans, and the rig they make with the config: nominals from the config, else the
    // layout's guess, else identity for every sensor. A recording gives scans, nominals and a
    // reference of its own.
    let bag = match &a.bag {
        Some(path) => Some(recording::rig(
            host,
            path,
            &BagRequest {
                topics: a.topics.as_deref(),
                reference: a.reference.as_deref(),
                base_frame: a.base_frame.as_deref().unwrap_or("base_link"),
                frames: a.frames.unwrap_or(10),
                urdf: a.urdf.as_deref(),
            },
        )?),
        None => None,
    };
    let dataset::Dataset { scans, guess } = match &bag {
        Some(b) => {
            dataset::Dataset { scans: b.rig.scans.clone(), guess: Some(b.rig.nominal.clone()) }
        }
        None => dataset::read_dir(host, &a.data)?,
    };
    let nominal = match (&config, guess) {
        (_, Some(guess)) if bag.is_some() => guess,
        (Some(c), _) if !c.nominal.is_empty() => {
            for scan in &scans {
                if !c.nominal.iter().any(|n| n.sensor == scan.sensor) {
                    let s = &scan.sensor;
                    return Err(format!("{label}: no transform_{s} for the data folder {s}"));
                }
            }
            c.nominal_poses()
        }
        (_, Some(guess)) => guess,
        _ => {
            let mut names: Vec<String> = scans.iter().map(|s| s.sensor.clone()).collect();
            names.dedup();
            names.into_iter().map(|n| (n, crate::Pose::identity())).collect()
        }
    };
    // A reference the user names (for a recording, a topic: the sensor it makes), else the
    // config's, else the library's default.
    let reference = match &bag {
        Some(b) if a.reference.is_some() => Some(b.rig.reference.clone()),
        _ => a.reference.clone(),
    }
    .or(config.as_ref().and_then(|c| c.reference.clone()));
    let roi = a
        .roi
        .map(|r| crate::Aabb::new([r[0], r[1], r[2]], [r[3], r[4], r[5]]))
        .or(config.as_ref().and_then(|c| c.roi));
    let rig = Rig { scans, nominal, roi, reference };

    // 3. Calibrate by each method on the same scans; when comparing, a method that fails
    // is a finding like any other.
    let outcomes = calib::calibrate_each(&rig, &settings, &methods, |method, p| {
        host.progress(&progress_line(method, p));
        Control::Continue
    });
    host.progress("");
    if let [(method, outcome)] = outcomes.as_slice() {
        let result = outcome.as_ref().map_err(|e| advised(e, *method, &settings))?;
        host.out(&report::summary(result));
        write_json(host, a.json.as_deref(), &Report::from(result))?;
        if let (Some(format), Some(bag)) = (&a.export, &bag) {
            host.out(&format!("\n{}", recording::export(format, result, bag)?));
        }
        return Ok(status([result.verdict.level]));
    }
    let failures: Vec<String> = outcomes
        .iter()
        .filter_map(|(m, r)| {
            r.as_ref().err().map(|e| format!("{}: {}", m.name(), advised(e, *m, &settings)))
        })
        .collect();
    if failures.len() == outcomes.len() {
        return Err(failures.join("; "));
    }

    // 4. Report: the successes side by side, then each failure.
    let results: Vec<_> = outcomes.iter().filter_map(|(_, r)| r.as_ref().ok()).collect();
    host.out(&report::comparison(&results));
    if !failures.is_empty() {
        host.out("\nfailed:\n");
        failures.iter().for_each(|f| host.out(&format!("  {f}\n")));
    }
    let entries: Vec<serde_json::Value> = outcomes
        .iter()
        .map(|(method, outcome)| match outcome {
            Ok(c) => serde_json::to_value(Report::from(c)),
            Err(e) => {
                let error = advised(e, *method, &settings);
                Ok(serde_json::json!({ "method": method.name(), "error": error }))
            }
        })
        .collect::<Result<_, _>>()
        .map_err(|e| format!("JSON: {e}"))?;
    write_json(host, a.json.as_deref(), &entries)?;
    Ok(status(results.iter().map(|c| c.verdict.level)))
}

/// The error's text; where a sensor found no place in the region and `method`'s global
/// alignment, which would have searched for one, was switched off, the flag that switches it
/// on.
fn advised(e: &calib::CalibError, method: Method, settings: &Settings) -> String {
    use calib::CalibError::{NoPointsInRoi, OutsideOverlap};
    let stages = calib::Stages::of(method, settings);
    let searches = matches!(method, Method::Gmm | Method::Cad);
    match e {
        NoPointsInRoi(_) | OutsideOverlap(_) if searches && stages.global.is_none() => {
            let flag = if settings.refine_only { "leave out --refine" } else { "--global on" };
            format!("{e}; the global alignment, off here, searches for where it sits: {flag}")
        }
        _ => e.to_string(),
    }
}

/// Writes `value` as pretty JSON to `path`, when given.
pub(super) fn write_json(
    host: &mut dyn Host,
    path: Option<&str>,
    value: &impl serde::Serialize,
) -> Result<(), String> {
    let Some(path) = path else { return Ok(()) };
    let json = crate::export::json(value).map_err(|e| format!("JSON: {e}"))?;
    host.write(path, json.as_bytes()).map_err(|e| format!("{path}: {e}"))
}

/// The progress line: the sensors aligned globally, the views prepared, EM's iterations, the
/// frame pairs registered, then the result made.
fn progress_line(method: Method, p: &Progress) -> String {
    let what = match p.stage {
        Stage::Global => "sensors aligned globally",
        Stage::Views => return format!("{}: levelling, bird's-eye search, crop", method.name()),
        Stage::Jrmpc => "JRMPC iteration",
        Stage::FramePairs => "frame pair",
        Stage::Cad => "CAD iteration",
        Stage::Finish => return format!("{}: plane adjustment, selection, verdict", method.name()),
    };
    format!("{}: {what} {}/{}", method.name(), p.iteration, p.max_iterations)
}
