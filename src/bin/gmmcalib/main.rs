//! `gmmcalib calibrate`: GMMCalib's data folder and YAML config in, calibration out (text on
//! stdout, JSON with `--json`). `gmmcalib simulate`: the digital twin written in that layout.
//! `gmmcalib experiment`: the paper's experiment on the twin. `gmmcalib study`: accuracy on
//! the twin over many seeds and starts. Thin adapters: the library does all the work. Native
//! only; the wasm32 build gets an empty `main` so `cargo test --target wasm32-unknown-unknown`
//! still builds.

#[cfg(not(target_arch = "wasm32"))]
mod args;
#[cfg(not(target_arch = "wasm32"))]
mod dataset;
#[cfg(not(target_arch = "wasm32"))]
mod experiment;
#[cfg(not(target_arch = "wasm32"))]
mod layout;
#[cfg(not(target_arch = "wasm32"))]
mod parallel;
#[cfg(not(target_arch = "wasm32"))]
mod recording;
#[cfg(not(target_arch = "wasm32"))]
mod simulate;
#[cfg(not(target_arch = "wasm32"))]
mod study;

#[cfg(target_arch = "wasm32")]
fn main() {}

#[cfg(not(target_arch = "wasm32"))]
fn main() -> std::process::ExitCode {
    match cli::run(std::env::args().skip(1)) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("gmmcalib: {}", e.replace('\n', " "));
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(not(target_arch = "wasm32"))]
mod cli {
    use std::io::{IsTerminal, Write};
    use std::process::ExitCode;

    use gmmcalib::calib::{self, Level, Method, Progress, Rig, Settings, Stage};
    use gmmcalib::io::config::Config;
    use gmmcalib::jrmpc::Control;
    use gmmcalib::report::{self, Report};

    use crate::args::{self, CalibrateArgs, Command};
    use crate::dataset;

    /// The exit status when the calibration ran but its verdict is `failed`: do not use the
    /// extrinsic (1 is an error: nothing was calibrated).
    pub const VERDICT_FAILED: u8 = 2;

    pub fn run(argv: impl IntoIterator<Item = String>) -> Result<ExitCode, String> {
        let done = |r: Result<(), String>| r.map(|()| ExitCode::SUCCESS);
        match args::parse(argv)? {
            Command::Help => {
                println!("{}", args::USAGE);
                Ok(ExitCode::SUCCESS)
            }
            Command::Inspect(file) => done(crate::recording::inspect(&file)),
            Command::Calibrate(a) => calibrate(&a),
            Command::Simulate(a) => done(crate::simulate::run(&a)),
            Command::Experiment(a) => done(crate::experiment::run(&a)),
            Command::Study(a) => done(crate::study::run(&a)),
        }
    }

    /// The exit status for results whose verdicts are `levels`: `VERDICT_FAILED` when every
    /// one failed.
    fn status(levels: impl IntoIterator<Item = Level>) -> ExitCode {
        let mut levels = levels.into_iter().peekable();
        let any = levels.peek().is_some();
        if any && levels.all(|l| l == Level::Failed) {
            ExitCode::from(VERDICT_FAILED)
        } else {
            ExitCode::SUCCESS
        }
    }

    fn calibrate(a: &CalibrateArgs) -> Result<ExitCode, String> {
        // 1. The config, if any, with the command line taking precedence.
        let (config, label) = match &a.config {
            Some(path) => {
                let label = path.display().to_string();
                let text = std::fs::read_to_string(path).map_err(|e| format!("{label}: {e}"))?;
                (Some(Config::from_yaml(&text, &label).map_err(|e| e.to_string())?), label)
            }
            None => (None, String::new()),
        };
        let mut settings = Settings::default();
        if let Some(config) = &config {
            config.apply(&mut settings);
        }
        let methods = match (&a.method, &config) {
            (Some(m), _) => Method::parse_list(m).map_err(|e| e.to_string())?,
            (None, Some(c)) => {
                c.methods(&label).map_err(|e| e.to_string())?.unwrap_or(vec![settings.method])
            }
            (None, None) => vec![settings.method],
        };
        if let (Some(config), Some(path)) = (&config, a.config.as_ref()) {
            if let Some(mesh) = &config.target_mesh {
                let dir = path.parent().unwrap_or(std::path::Path::new("."));
                let value = format!("mesh:{mesh}");
                settings.target = args::target(&value, dir).map_err(|e| format!("{label}: {e}"))?;
            }
        }
        if let Some(target) = &a.target {
            settings.target = args::target(target, std::path::Path::new("."))
                .map_err(|e| format!("--target: {e}"))?;
        }
        if let Some(k) = a.components {
            settings.components = k;
        }
        if let Some(n) = a.iterations {
            settings.jrmpc.max_iterations = n;
        }
        settings.align_globally = a.global.or(settings.align_globally);
        settings.jrmpc.threads = a.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        });

        // 2. Scans, and the rig they make with the config: nominals from the config, else the
        // layout's guess, else identity for every sensor.
        // A recording gives scans, nominals and a reference of its own.
        let bag = match &a.bag {
            Some(path) => Some(crate::recording::rig(
                path,
                &crate::recording::BagRequest {
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
            None => dataset::read_dir(&a.data)?,
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
                names.into_iter().map(|n| (n, gmmcalib::Pose::identity())).collect()
            }
        };
        let reference = a
            .reference
            .clone()
            .or(bag.as_ref().map(|b| b.rig.reference.clone()))
            .or(config.as_ref().and_then(|c| c.reference.clone()))
            .or_else(|| scans.first().map(|s| s.sensor.clone()));
        let roi = a
            .roi
            .map(|r| gmmcalib::Aabb::new([r[0], r[1], r[2]], [r[3], r[4], r[5]]))
            .or(config.as_ref().and_then(|c| c.roi));
        let rig = Rig { scans, nominal, roi, reference };

        // 3. Calibrate by each method on the same scans; when comparing, a method that fails
        // is a finding like any other.
        let show = std::io::stderr().is_terminal();
        let outcomes = calib::compare(&rig, &settings, &methods, |method, p| {
            if show {
                progress_line(method, p);
            }
            Control::Continue
        });
        if show {
            eprint!("\r\x1b[K");
        }
        if let [(_, outcome)] = outcomes.as_slice() {
            let result = outcome.as_ref().map_err(|e| e.to_string())?;
            print!("{}", report::summary(result));
            write_json(a.json.as_deref(), &Report::from(result))?;
            if let (Some(format), Some(bag)) = (&a.export, &bag) {
                print!("\n{}", crate::recording::export(format, result, bag)?);
            }
            return Ok(status([result.verdict.level]));
        }
        let failures: Vec<String> = outcomes
            .iter()
            .filter_map(|(m, r)| r.as_ref().err().map(|e| format!("{}: {e}", m.name())))
            .collect();
        if failures.len() == outcomes.len() {
            return Err(failures.join("; "));
        }

        // 4. Report: the successes side by side, then each failure.
        let results: Vec<_> = outcomes.iter().filter_map(|(_, r)| r.as_ref().ok()).collect();
        print!("{}", report::comparison(&results));
        if !failures.is_empty() {
            println!("\nfailed:");
            failures.iter().for_each(|f| println!("  {f}"));
        }
        let entries: Vec<serde_json::Value> = outcomes
            .iter()
            .map(|(method, outcome)| match outcome {
                Ok(c) => serde_json::to_value(Report::from(c)),
                Err(e) => {
                    Ok(serde_json::json!({ "method": method.name(), "error": e.to_string() }))
                }
            })
            .collect::<Result<_, _>>()
            .map_err(|e| format!("JSON: {e}"))?;
        write_json(a.json.as_deref(), &entries)?;
        Ok(status(results.iter().map(|c| c.verdict.level)))
    }

    /// Writes `value` as pretty JSON to `path`, when given.
    fn write_json(
        path: Option<&std::path::Path>,
        value: &impl serde::Serialize,
    ) -> Result<(), String> {
        let Some(path) = path else { return Ok(()) };
        let json = serde_json::to_string_pretty(value).map_err(|e| format!("JSON: {e}"))?;
        std::fs::write(path, json + "\n").map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The progress line on stderr: EM's iterations, then the frame pairs registered.
    fn progress_line(method: Method, p: &Progress) {
        let mut err = std::io::stderr();
        let what = match p.stage {
            Stage::Jrmpc => "JRMPC iteration",
            Stage::FramePairs => "frame pair",
            Stage::Cad => "CAD iteration",
        };
        // Clear the line first: a frame pair's line is shorter than an iteration's.
        let name = method.name();
        let _ = write!(err, "\r\x1b[K{name}: {what} {}/{}", p.iteration, p.max_iterations);
        let _ = err.flush();
    }
}
