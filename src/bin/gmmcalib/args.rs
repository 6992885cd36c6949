//! Command-line arguments: `calibrate`, `simulate`, `experiment`; `--flag VALUE` or
//! `--flag=VALUE`.

use std::path::PathBuf;

pub const USAGE: &str = "\
usage: gmmcalib calibrate --config CONFIG.yaml --data DIR
                          [--method gmm|jrmpc|p2p|p2l|gicp|all] [--reference NAME]
                          [--iterations N] [--components K] [--threads T]
                          [--json OUT.json]
       gmmcalib simulate --out DIR [--preset paper|os1-128] [--frames F] [--seed S]
                          [--max-angle-deg 3] [--max-translation 0.1]
       gmmcalib experiment --out DIR [--preset paper|os1-128] [--trials N] [--frames F]
                          [--seed S] [--methods gmm,jrmpc,p2p,p2l,gicp] [--threads T]
                          [--max-angle-deg 3] [--max-translation 0.1]

  calibrate: DIR holds one folder per sensor (sensor_1, sensor_2, ...), each with frames
  1.pcd, 2.pcd, ... (.pcd, .ply or .bin); frames pair across sensors by file stem. Flags
  override CONFIG.yaml. --threads: threads sharing JRMPC's E-step and the refinement's frame
  pairs (default: the available cores; the result does not depend on it).
  simulate: writes the digital twin in that layout (DIR/config.yaml with miscalibrated nominal
  extrinsics, DIR/data/sensor_N/F.pcd) plus DIR/truth.json; the first sensor is the reference
  and keeps its true mount.
  experiment: the paper's experiment; every method on the same frames of each trial; writes
  DIR/summary.json, trials.csv, table.md and SVG plots.";

/// What the user asked for.
#[derive(Debug)]
pub enum Command {
    Help,
    Calibrate(CalibrateArgs),
    Simulate(SimulateArgs),
    Experiment(ExperimentArgs),
}

#[derive(Debug, Default)]
pub struct CalibrateArgs {
    pub config: PathBuf,
    pub data: PathBuf,
    /// A method name or `all`.
    pub method: Option<String>,
    pub reference: Option<String>,
    pub iterations: Option<usize>,
    pub components: Option<usize>,
    /// Threads sharing JRMPC's E-step; default: the available cores.
    pub threads: Option<usize>,
    pub json: Option<PathBuf>,
}

/// The twin and its miscalibration, shared by `simulate` and `experiment`.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinArgs {
    pub preset: String,
    pub frames: usize,
    pub seed: u64,
    /// Miscalibration bound per rotation axis (deg).
    pub max_angle_deg: f64,
    /// Miscalibration bound per translation axis (m).
    pub max_translation: f64,
}

impl Default for TwinArgs {
    fn default() -> Self {
        // The paper's bounds (gmmcalib::sim's defaults), in the units the flags take.
        Self {
            preset: "paper".into(),
            frames: 5,
            seed: 0,
            max_angle_deg: gmmcalib::sim::MAX_MISCALIBRATION_ANGLE.to_degrees(),
            max_translation: gmmcalib::sim::MAX_MISCALIBRATION_TRANSLATION,
        }
    }
}

#[derive(Debug)]
pub struct SimulateArgs {
    pub twin: TwinArgs,
    pub out: PathBuf,
}

#[derive(Debug)]
pub struct ExperimentArgs {
    pub twin: TwinArgs,
    pub trials: usize,
    /// Comma-separated method names.
    pub methods: String,
    /// Worker threads; default: the available cores.
    pub threads: Option<usize>,
    pub out: PathBuf,
}

/// Parses the arguments after the program name.
pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Command, String> {
    let mut args = args.into_iter();
    let command = match args.next().as_deref() {
        None | Some("-h" | "--help" | "help") => return Ok(Command::Help),
        Some(c @ ("calibrate" | "simulate" | "experiment")) => c.to_string(),
        Some(other) => {
            return Err(format!(
                "unknown command '{other}' (expected calibrate, simulate or experiment)"
            ));
        }
    };
    let Some(flags) = flags(args)? else { return Ok(Command::Help) };
    match command.as_str() {
        "calibrate" => calibrate(flags),
        "simulate" => simulate(flags),
        _ => experiment(flags),
    }
}

/// `(flag, value)` pairs; `None` when help was asked for.
fn flags(args: impl Iterator<Item = String>) -> Result<Option<Vec<(String, String)>>, String> {
    let mut args = args.peekable();
    let mut out = Vec::new();
    while let Some(arg) = args.next() {
        if arg == "-h" || arg == "--help" {
            return Ok(None);
        }
        if !arg.starts_with("--") {
            return Err(format!("unknown argument '{arg}' (see gmmcalib --help)"));
        }
        let (flag, value) = match arg.split_once('=') {
            Some((f, v)) => (f.to_string(), v.to_string()),
            None => {
                let value = args.next().ok_or_else(|| format!("{arg} needs a value"))?;
                (arg, value)
            }
        };
        out.push((flag, value));
    }
    Ok(Some(out))
}

fn calibrate(flags: Vec<(String, String)>) -> Result<Command, String> {
    let mut out = CalibrateArgs::default();
    let (mut config, mut data) = (None, None);
    for (flag, value) in flags {
        match flag.as_str() {
            "--config" => config = Some(PathBuf::from(value)),
            "--data" => data = Some(PathBuf::from(value)),
            "--method" => out.method = Some(value),
            "--reference" => out.reference = Some(value),
            "--iterations" => out.iterations = Some(positive(&flag, &value)?),
            "--components" => out.components = Some(positive(&flag, &value)?),
            "--threads" => out.threads = Some(positive(&flag, &value)?),
            "--json" => out.json = Some(PathBuf::from(value)),
            _ => return Err(unknown(&flag)),
        }
    }
    out.config = config.ok_or("calibrate needs --config CONFIG.yaml")?;
    out.data = data.ok_or("calibrate needs --data DIR")?;
    Ok(Command::Calibrate(out))
}

/// A flag of [`TwinArgs`]; false when `flag` is not one.
fn twin_flag(twin: &mut TwinArgs, flag: &str, value: &str) -> Result<bool, String> {
    match flag {
        "--preset" => twin.preset = value.to_string(),
        "--frames" => twin.frames = positive(flag, value)?,
        "--seed" => {
            twin.seed = value
                .parse()
                .map_err(|_| format!("{flag} expects a non-negative integer, got '{value}'"))?
        }
        "--max-angle-deg" => twin.max_angle_deg = non_negative(flag, value)?,
        "--max-translation" => twin.max_translation = non_negative(flag, value)?,
        _ => return Ok(false),
    }
    Ok(true)
}

fn simulate(flags: Vec<(String, String)>) -> Result<Command, String> {
    let (mut twin, mut out) = (TwinArgs::default(), None);
    for (flag, value) in flags {
        if !twin_flag(&mut twin, &flag, &value)? {
            match flag.as_str() {
                "--out" => out = Some(PathBuf::from(value)),
                _ => return Err(unknown(&flag)),
            }
        }
    }
    let out = out.ok_or("simulate needs --out DIR")?;
    Ok(Command::Simulate(SimulateArgs { twin, out }))
}

fn experiment(flags: Vec<(String, String)>) -> Result<Command, String> {
    let mut twin = TwinArgs::default();
    let (mut trials, mut methods, mut threads, mut out) =
        (100, "gmm,jrmpc,p2p,p2l,gicp".to_string(), None, None);
    for (flag, value) in flags {
        if !twin_flag(&mut twin, &flag, &value)? {
            match flag.as_str() {
                "--trials" => trials = positive(&flag, &value)?,
                "--methods" => methods = value,
                "--threads" => threads = Some(positive(&flag, &value)?),
                "--out" => out = Some(PathBuf::from(value)),
                _ => return Err(unknown(&flag)),
            }
        }
    }
    let out = out.ok_or("experiment needs --out DIR")?;
    Ok(Command::Experiment(ExperimentArgs { twin, trials, methods, threads, out }))
}

fn unknown(flag: &str) -> String {
    format!("unknown argument '{flag}' (see gmmcalib --help)")
}

fn positive(flag: &str, value: &str) -> Result<usize, String> {
    match value.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{flag} expects a positive integer, got '{value}'")),
    }
}

fn non_negative(flag: &str, value: &str) -> Result<f64, String> {
    match value.parse::<f64>() {
        Ok(x) if x >= 0.0 && x.is_finite() => Ok(x),
        _ => Err(format!("{flag} expects a non-negative number, got '{value}'")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn parses_flags_in_both_spellings() {
        let Ok(Command::Calibrate(a)) =
            parse(args("calibrate --config c.yaml --data=d --method all --iterations=7"))
        else {
            panic!("expected calibrate");
        };
        assert_eq!(a.config, PathBuf::from("c.yaml"));
        assert_eq!(a.data, PathBuf::from("d"));
        assert_eq!(a.method.as_deref(), Some("all"));
        assert_eq!(a.iterations, Some(7));
        assert_eq!(a.components, None);
    }

    #[test]
    fn parses_simulate_and_experiment() {
        let Ok(Command::Simulate(s)) =
            parse(args("simulate --out o --frames=3 --seed 9 --max-angle-deg 1.5"))
        else {
            panic!("expected simulate");
        };
        assert_eq!((s.out, s.twin.frames, s.twin.seed), (PathBuf::from("o"), 3, 9));
        assert_eq!((s.twin.preset.as_str(), s.twin.max_angle_deg), ("paper", 1.5));
        assert!((s.twin.max_translation - 0.1).abs() < 1e-12);
        let Ok(Command::Experiment(e)) =
            parse(args("experiment --out o --trials 3 --methods p2p,gicp --preset os1-128"))
        else {
            panic!("expected experiment");
        };
        assert_eq!(
            (e.trials, e.methods.as_str(), e.twin.preset.as_str()),
            (3, "p2p,gicp", "os1-128")
        );
        assert!((e.twin.max_angle_deg - 3.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_input() {
        assert!(parse(args("calibrate --data d")).unwrap_err().contains("--config"));
        assert!(parse(args("calibrate --config c --data d --iterations 0")).is_err());
        assert!(
            parse(args("calibrate --config c --data d --bogus x")).unwrap_err().contains("bogus")
        );
        assert!(parse(args("calibrate --config")).unwrap_err().contains("needs a value"));
        assert!(parse(args("frobnicate")).is_err());
        assert!(matches!(parse(args("")), Ok(Command::Help)));
        assert!(parse(args("simulate --frames 2")).unwrap_err().contains("--out"));
        assert!(parse(args("simulate --out o --seed -1")).unwrap_err().contains("--seed"));
        assert!(parse(args("experiment --out o --max-translation -1")).is_err());
        assert!(parse(args("experiment --out o --trials 0")).is_err());
    }
}
