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
        // 1. Config, with the command line taking precedence.
        let label = a.config.display().to_string();
        let text = std::fs::read_to_string(&a.config).map_err(|e| format!("{label}: {e}"))?;
        let config = Config::from_yaml(&text, &label).map_err(|e| e.to_string())?;
        let mut settings = Settings::default();
        config.apply(&mut settings);
        let methods = match &a.method {
            Some(m) => Method::parse_list(m).map_err(|e| e.to_string())?,
            None => {
                config.methods(&label).map_err(|e| e.to_string())?.unwrap_or(vec![settings.method])
            }
        };
        if let Some(k) = a.components {
            settings.components = k;
        }
        if let Some(n) = a.iterations {
            settings.jrmpc.max_iterations = n;
        }
        settings.jrmpc.threads = a.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        });
        let roi = config.roi.ok_or_else(|| format!("{label}: no ROI (min_bound, max_bound)"))?;

        // 2. Scans, and the rig they make with the config.
        let scans = dataset::read_scans(&a.data)?;
        for scan in &scans {
            if !config.nominal.iter().any(|n| n.sensor == scan.sensor) {
                let s = &scan.sensor;
                return Err(format!("{label}: no transform_{s} for the data folder {s}"));
            }
        }
        let reference = a
            .reference
            .clone()
            .or(config.reference.clone())
            .or_else(|| Some(scans[0].sensor.clone()));
        let rig = Rig { scans, nominal: config.nominal_poses(), roi, reference };

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
        };
        // Clear the line first: a frame pair's line is shorter than an iteration's.
        let name = method.name();
        let _ = write!(err, "\r\x1b[K{name}: {what} {}/{}", p.iteration, p.max_iterations);
        let _ = err.flush();
    }
}
