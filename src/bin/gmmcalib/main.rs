//! `gmmcalib calibrate`: GMMCalib's data folder and YAML config in, calibration out (text on
//! stdout, JSON with `--json`). `gmmcalib simulate`: the digital twin written in that layout.
//! `gmmcalib experiment`: the paper's experiment on the twin. Thin adapters: the library does
//! all the work. Native only; the wasm32 build gets an empty `main` so
//! `cargo test --target wasm32-unknown-unknown` still builds.

#[cfg(not(target_arch = "wasm32"))]
mod args;
#[cfg(not(target_arch = "wasm32"))]
mod config;
#[cfg(not(target_arch = "wasm32"))]
mod dataset;
#[cfg(not(target_arch = "wasm32"))]
mod experiment;
#[cfg(not(target_arch = "wasm32"))]
mod plots;
#[cfg(not(target_arch = "wasm32"))]
mod report;
#[cfg(not(target_arch = "wasm32"))]
mod simulate;
#[cfg(not(target_arch = "wasm32"))]
mod twin;

#[cfg(target_arch = "wasm32")]
fn main() {}

#[cfg(not(target_arch = "wasm32"))]
fn main() -> std::process::ExitCode {
    match cli::run(std::env::args().skip(1)) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gmmcalib: {}", e.replace('\n', " "));
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(not(target_arch = "wasm32"))]
mod cli {
    use std::io::{IsTerminal, Write};

    use gmmcalib::calib::{self, Calibration, Method, Rig, Settings, Stage};
    use gmmcalib::jrmpc::{Control, Prior};
    use gmmcalib::report::Report;

    use crate::args::{self, CalibrateArgs, Command};
    use crate::{config, dataset, report};

    pub fn run(argv: impl IntoIterator<Item = String>) -> Result<(), String> {
        match args::parse(argv)? {
            Command::Help => {
                println!("{}", args::USAGE);
                Ok(())
            }
            Command::Calibrate(a) => calibrate(&a),
            Command::Simulate(a) => crate::simulate::run(&a),
            Command::Experiment(a) => crate::experiment::run(&a),
        }
    }

    fn calibrate(a: &CalibrateArgs) -> Result<(), String> {
        // 1. Config, with the command line taking precedence.
        let label = a.config.display().to_string();
        let text = std::fs::read_to_string(&a.config).map_err(|e| format!("{label}: {e}"))?;
        let cfg = config::parse(&text, &label)?;
        let methods = methods(a.method.as_deref().or(cfg.method.as_deref()))?;
        let mut settings = Settings::default();
        if let Some(k) = a.components.or(cfg.components) {
            settings.components = k;
        }
        if let Some(n) = a.iterations.or(cfg.iterations) {
            settings.jrmpc.max_iterations = n;
        }
        if let Some(edge) = cfg.target_edge {
            settings.prior = Prior::Cube { edge };
        }
        if let Some(sigma) = cfg.initial_sigma {
            settings.initial_sigma = sigma;
        }
        settings.jrmpc.threads = a.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        });

        // 2. Views, and the rig they make with the config.
        let views = dataset::read_views(&a.data)?;
        for view in &views {
            if !cfg.nominal.iter().any(|(n, _)| *n == view.sensor) {
                let s = &view.sensor;
                return Err(format!("{label}: no transform_{s} for the data folder {s}"));
            }
        }
        let reference =
            a.reference.clone().or(cfg.reference).or_else(|| Some(views[0].sensor.clone()));
        let rig = Rig { views, nominal: cfg.nominal, roi: cfg.roi, reference };

        // 3. Calibrate by each method, on the same frames. When comparing, a method that
        // fails is a finding like any other: the others still run and are reported.
        if let [method] = methods.as_slice() {
            let result = calibrate_one(&rig, &Settings { method: *method, ..settings })?;
            print!("{}", report::summary(&result));
            return write_json(a.json.as_deref(), &Report::from(&result));
        }
        let outcomes: Vec<(Method, Result<Calibration, String>)> = methods
            .iter()
            .map(|&method| (method, calibrate_one(&rig, &Settings { method, ..settings.clone() })))
            .collect();
        let failures: Vec<String> = outcomes
            .iter()
            .filter_map(|(m, r)| r.as_ref().err().map(|e| format!("{}: {e}", m.name())))
            .collect();
        if failures.len() == outcomes.len() {
            return Err(failures.join("; "));
        }

        // 4. Report: the successes side by side, then each failure.
        let results: Vec<&Calibration> =
            outcomes.iter().filter_map(|(_, r)| r.as_ref().ok()).collect();
        print!("{}", report::comparison(&results));
        if !failures.is_empty() {
            println!("\nfailed:");
            failures.iter().for_each(|f| println!("  {f}"));
        }
        let entries: Vec<serde_json::Value> = outcomes
            .iter()
            .map(|(method, outcome)| match outcome {
                Ok(c) => serde_json::to_value(Report::from(c)),
                Err(e) => Ok(serde_json::json!({ "method": method.name(), "error": e })),
            })
            .collect::<Result<_, _>>()
            .map_err(|e| format!("JSON: {e}"))?;
        write_json(a.json.as_deref(), &entries)
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

    /// `all` or one method name; the library's default when none is given.
    fn methods(name: Option<&str>) -> Result<Vec<Method>, String> {
        match name {
            None => Ok(vec![Settings::default().method]),
            Some(n) if n.trim().eq_ignore_ascii_case("all") => Ok(Method::ALL.to_vec()),
            Some(n) => n.parse::<Method>().map(|m| vec![m]).map_err(|e| e.to_string()),
        }
    }

    /// One calibration, with a progress line on stderr when it is a terminal: EM's iterations,
    /// then the frame pairs registered.
    fn calibrate_one(rig: &Rig, settings: &Settings) -> Result<Calibration, String> {
        let show = std::io::stderr().is_terminal();
        let name = settings.method.name();
        let result = calib::calibrate(rig, settings, |p| {
            if show {
                let mut err = std::io::stderr();
                let what = match p.stage {
                    Stage::Jrmpc => "JRMPC iteration",
                    Stage::FramePairs => "frame pair",
                };
                // Clear the line first: a frame pair's line is shorter than an iteration's.
                let _ = write!(err, "\r\x1b[K{name}: {what} {}/{}", p.iteration, p.max_iterations);
                let _ = err.flush();
            }
            Control::Continue
        });
        if show {
            eprint!("\r\x1b[K");
        }
        result.map_err(|e| e.to_string())
    }
}
