//! Command-line arguments: `calibrate`, `simulate`, `experiment`, `study`; `--flag VALUE` or
//! `--flag=VALUE`.

use std::path::PathBuf;

pub const USAGE: &str = "\
usage: gmmcalib calibrate --data DIR [--config CONFIG.yaml]
                          [--method gmm|jrmpc|p2p|p2l|gicp|all] [--reference NAME]
                          [--target cube:EDGE|box:W,D,H|sphere:DIAMETER|mesh:PATH|none]
                          [--roi XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX] [--global on|off]
                          [--iterations N] [--components K] [--threads T]
                          [--json OUT.json]
       gmmcalib calibrate --bag FILE [--topics /a,/b] [--reference /a] [--base-frame base_link]
                          [--frames N] [--urdf FILE] [--export ros1|ros2|tf-yaml|urdf|autoware|kitti]
                          (and the options above)
       gmmcalib inspect FILE
       gmmcalib simulate --out DIR [--preset paper|paper-roof|paper-chair|...] [--frames F]
                          [--seed S] [--max-angle-deg 3] [--max-translation 0.1]
       gmmcalib experiment --out DIR [--preset paper|...] [--trials N] [--frames F]
                          [--seed S] [--methods gmm,jrmpc,p2p,p2l,gicp] [--threads T]
                          [--max-angle-deg 3] [--max-translation 0.1]
       gmmcalib study [--preset paper|paper-roof|...] [--seeds 20] [--starts 5] [--frames 5]
                          [--max-angle-deg 3] [--max-yaw-deg DEG] [--max-translation 0.1]
                          [--method gmm] [--target cube:0.5|...|mesh:PATH|none] [--components K]
                          [--iterations N] [--tolerance T]
                          [--bev on|off] [--planes on|off] [--level on|off] [--global on|off] [--noise M]
                          [--columns N] [--threads T] [--notes] [--poses]

  calibrate: prints the verdict first (good, check or failed, with the reasons); exit status
  0 when it calibrated, 2 when it calibrated but the verdict is failed (every method's, with
  --method all): do not use that extrinsic; 1 on an error.
  DIR holds one folder per sensor (sensor_1, sensor_2, ...), each with frames
  1.pcd, 2.pcd, ... (.pcd, .ply or .bin); frames pair across sensors by file stem. Or
  OpenCalib's layout: lidar_cloud_path.txt naming each device's file, and its guess
  initial_extrinsic.txt. Nominals come from CONFIG.yaml (6 numbers [roll, pitch, yaw, x, y,
  z], 7 [x, y, z, qx, qy, qz, qw] or 16, a 4x4 row-major), else from OpenCalib's guess, else
  identity for every sensor: the global alignment (on for gmm) finds the rest. Without a ROI
  the region where the clouds overlap is used. Flags override CONFIG.yaml. --threads: threads
  sharing JRMPC's E-step and the frame pairs (default: the available cores; the result does
  not depend on it).
  --bag: a recording (MCAP, ROS 1 .bag, rosbag2 .db3) instead of --data: sensors are its
  PointCloud2 topics (default: all), frames are N instants (default 10) spread over it where
  every topic has a scan within 20 ms of the reference's (the first topic unless --reference).
  Nominals T_base_frame come from --urdf (joint origins) or /tf_static, resolved for each
  topic's frame_id to --base-frame (default base_link, else the tree's root). --export prints
  the corrected extrinsics (parent the base frame, child each frame id) in that form; urdf
  edits the --urdf file's joint origins in place when one was given.
  inspect: a recording's topics (count, rate, frame id, type) and its /tf_static tree.
  Presets: paper, paper-roof (3 sensors), os1-128, sampled, paper-chair and paper-board (a
  chair / a board on a stand as the target), street (no target: walls, poles, cars).
  simulate: writes the digital twin in that layout (DIR/config.yaml with miscalibrated nominal
  extrinsics, DIR/data/sensor_N/F.pcd) plus DIR/truth.json; the first sensor is the reference
  and keeps its true mount.
  experiment: the paper's experiment; every method on the same frames of each trial; writes
  DIR/summary.json, trials.csv, table.md and SVG plots.
  study: accuracy on the twin: seeds 1..=N of the scans, each calibrated from --starts wrong
  nominals (start k of seed s draws from seed 1000 s + k); prints the error distributions,
  per trial, per sensor, and the precision claimed against the errors.";

/// What the user asked for.
#[derive(Debug)]
pub enum Command {
    Help,
    Inspect(PathBuf),
    Calibrate(CalibrateArgs),
    Simulate(SimulateArgs),
    Experiment(ExperimentArgs),
    Study(StudyArgs),
}

#[derive(Debug, Default)]
pub struct CalibrateArgs {
    pub config: Option<PathBuf>,
    pub data: PathBuf,
    pub target: Option<String>,
    pub roi: Option<[f64; 6]>,
    pub global: Option<bool>,
    /// A method name or `all`.
    pub method: Option<String>,
    pub reference: Option<String>,
    pub iterations: Option<usize>,
    pub components: Option<usize>,
    /// Threads sharing JRMPC's E-step; default: the available cores.
    pub threads: Option<usize>,
    pub json: Option<PathBuf>,
    /// A recording instead of `data`, and what to take from it.
    pub bag: Option<PathBuf>,
    pub topics: Option<String>,
    pub base_frame: Option<String>,
    pub frames: Option<usize>,
    pub urdf: Option<PathBuf>,
    pub export: Option<String>,
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
            max_angle_deg: gmmcalib::twin::MAX_MISCALIBRATION_ANGLE.to_degrees(),
            max_translation: gmmcalib::twin::MAX_MISCALIBRATION_TRANSLATION,
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

#[derive(Debug, Clone, PartialEq)]
pub struct StudyArgs {
    pub preset: String,
    pub seeds: u64,
    pub starts: u64,
    pub frames: usize,
    pub max_angle_deg: f64,
    /// Yaw's bound when it differs from the other axes'.
    pub max_yaw_deg: Option<f64>,
    pub max_translation: f64,
    pub method: String,
    pub components: Option<usize>,
    pub iterations: Option<usize>,
    /// JRMPC's convergence tolerance (rad and m per iteration).
    pub tolerance: Option<f64>,
    pub bev: bool,
    pub planes: bool,
    /// Ground levelling on or off; default: the method's.
    pub level: Option<bool>,
    /// Global alignment first: `None`, the method's default.
    pub global: Option<bool>,
    /// The target (`Target`'s short form): `None`, the preset's cube.
    pub target: Option<String>,
    /// The LiDARs' range noise (m).
    pub noise: Option<f64>,
    /// The LiDARs' columns over 360 deg.
    pub columns: Option<usize>,
    pub threads: Option<usize>,
    /// Print each trial's notes (plane adjustment, refinement guards, bird's-eye overlap).
    pub notes: bool,
    /// Print each trial's error per sensor in full (rotation about the vehicle axes in mdeg,
    /// position in mm), to compare two runs trial by trial.
    pub poses: bool,
}

impl Default for StudyArgs {
    fn default() -> Self {
        Self {
            preset: "paper".into(),
            seeds: 20,
            starts: 5,
            frames: 5,
            max_angle_deg: 3.0,
            max_yaw_deg: None,
            max_translation: 0.1,
            method: "gmm".into(),
            components: None,
            iterations: None,
            tolerance: None,
            bev: true,
            planes: true,
            level: None,
            global: None,
            target: None,
            noise: None,
            columns: None,
            threads: None,
            notes: false,
            poses: false,
        }
    }
}

/// Parses the arguments after the program name.
pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Command, String> {
    let mut args = args.into_iter();
    let command = match args.next().as_deref() {
        None | Some("-h" | "--help" | "help") => return Ok(Command::Help),
        Some("inspect") => {
            return match (args.next(), args.next()) {
                (Some(file), None) if !file.starts_with('-') => Ok(Command::Inspect(file.into())),
                (Some(h), _) if h == "-h" || h == "--help" => Ok(Command::Help),
                _ => Err("usage: gmmcalib inspect FILE".into()),
            };
        }
        Some(c @ ("calibrate" | "simulate" | "experiment" | "study")) => c.to_string(),
        Some(other) => {
            return Err(format!(
                "unknown command '{other}' (expected calibrate, inspect, simulate, experiment or study)"
            ));
        }
    };
    let Some(flags) = flags(args)? else { return Ok(Command::Help) };
    match command.as_str() {
        "calibrate" => calibrate(flags),
        "simulate" => simulate(flags),
        "study" => study(flags),
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
        // The flags without a value.
        if arg == "--notes" || arg == "--poses" {
            out.push((arg, "on".into()));
            continue;
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
            "--target" => out.target = Some(value),
            "--roi" => out.roi = Some(six(&flag, &value)?),
            "--global" => out.global = Some(on_off(&flag, &value)?),
            "--iterations" => out.iterations = Some(positive(&flag, &value)?),
            "--components" => out.components = Some(positive(&flag, &value)?),
            "--threads" => out.threads = Some(positive(&flag, &value)?),
            "--json" => out.json = Some(PathBuf::from(value)),
            "--bag" => out.bag = Some(PathBuf::from(value)),
            "--topics" => out.topics = Some(value),
            "--base-frame" => out.base_frame = Some(value),
            "--frames" => out.frames = Some(positive(&flag, &value)?),
            "--urdf" => out.urdf = Some(PathBuf::from(value)),
            "--export" => out.export = Some(value),
            _ => return Err(unknown(&flag)),
        }
    }
    out.config = config;
    match (data, &out.bag) {
        (Some(_), Some(_)) => {
            return Err("calibrate takes --data DIR or --bag FILE, not both".into());
        }
        (Some(d), None) => out.data = d,
        (None, Some(_)) => {}
        (None, None) => return Err("calibrate needs --data DIR or --bag FILE".into()),
    }
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

fn study(flags: Vec<(String, String)>) -> Result<Command, String> {
    let mut out = StudyArgs::default();
    for (flag, value) in flags {
        let number = |v: &str| non_negative(&flag, v);
        match flag.as_str() {
            "--preset" => out.preset = value,
            "--seeds" => out.seeds = positive(&flag, &value)? as u64,
            "--starts" => out.starts = positive(&flag, &value)? as u64,
            "--frames" => out.frames = positive(&flag, &value)?,
            "--max-angle-deg" => out.max_angle_deg = number(&value)?,
            "--max-yaw-deg" => out.max_yaw_deg = Some(number(&value)?),
            "--max-translation" => out.max_translation = number(&value)?,
            "--method" => out.method = value,
            "--components" => out.components = Some(positive(&flag, &value)?),
            "--iterations" => out.iterations = Some(positive(&flag, &value)?),
            "--tolerance" => out.tolerance = Some(number(&value)?),
            "--bev" => out.bev = on_off(&flag, &value)?,
            "--planes" => out.planes = on_off(&flag, &value)?,
            "--level" => out.level = Some(on_off(&flag, &value)?),
            "--global" => out.global = Some(on_off(&flag, &value)?),
            "--target" => out.target = Some(value),
            "--noise" => out.noise = Some(number(&value)?),
            "--columns" => out.columns = Some(positive(&flag, &value)?),
            "--threads" => out.threads = Some(positive(&flag, &value)?),
            "--notes" => out.notes = true,
            "--poses" => out.poses = true,
            _ => return Err(unknown(&flag)),
        }
    }
    Ok(Command::Study(out))
}

/// Six comma-separated finite numbers.
fn six(flag: &str, value: &str) -> Result<[f64; 6], String> {
    let numbers: Vec<f64> = value
        .split(',')
        .filter_map(|x| x.trim().parse().ok())
        .filter(|x: &f64| x.is_finite())
        .collect();
    numbers.try_into().map_err(|_| {
        format!("{flag} expects six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX, got '{value}'")
    })
}

fn on_off(flag: &str, value: &str) -> Result<bool, String> {
    match value {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("{flag} expects on or off, got '{value}'")),
    }
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

/// A target in its short form (`Target`'s), or `mesh:PATH` with PATH (relative to `dir`) read
/// here: the library parses the bytes.
pub fn target(value: &str, dir: &std::path::Path) -> Result<gmmcalib::target::Target, String> {
    match gmmcalib::io::config::mesh_path(value) {
        Some(path) => {
            let path = dir.join(path);
            let label = path.display().to_string();
            let bytes = std::fs::read(&path).map_err(|e| format!("{label}: {e}"))?;
            gmmcalib::target::Target::from_mesh_file(&bytes, &label).map_err(|e| e.to_string())
        }
        None => value.parse(),
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
        assert_eq!(a.config, Some(PathBuf::from("c.yaml")));
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
        assert!(parse(args("calibrate --config c")).unwrap_err().contains("--data"));
        assert!(parse(args("calibrate --data d --roi 1,2,3")).unwrap_err().contains("six numbers"));
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
        assert!(parse(args("study --bev maybe")).unwrap_err().contains("on or off"));
    }

    #[test]
    fn parses_study() {
        let Ok(Command::Study(s)) =
            parse(args("study --preset paper-roof --seeds 3 --max-yaw-deg 8 --planes off --notes"))
        else {
            panic!("expected study");
        };
        assert_eq!((s.preset.as_str(), s.seeds, s.starts), ("paper-roof", 3, 5));
        assert_eq!((s.max_yaw_deg, s.planes, s.bev, s.notes), (Some(8.0), false, true, true));
    }
}
