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

        // 3. Calibrate by each method, on the same frames.
        let mut results = Vec::new();
        for method in &methods {
            let settings = Settings { method: *method, ..settings.clone() };
            let result = calibrate_one(&rig, &settings).map_err(|e| {
                if methods.len() > 1 { format!("{}: {e}", method.name()) } else { e }
            })?;
            results.push(result);
        }

        // 4. Report.
        if let [one] = results.as_slice() {
            print!("{}", report::summary(one));
        } else {
            print!("{}", report::comparison(&results));
        }
        if let Some(path) = &a.json {
            let reports: Vec<Report> = results.iter().map(Report::from).collect();
            let json = match reports.as_slice() {
                [one] if methods.len() == 1 => serde_json::to_string_pretty(one),
                all => serde_json::to_string_pretty(all),
            }
            .map_err(|e| format!("JSON: {e}"))?;
            std::fs::write(path, json + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
        }
        Ok(())
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
