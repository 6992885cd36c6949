//! Command-line arguments: `calibrate`, `simulate`, `experiment`, `study`; `--flag VALUE` or
//! `--flag=VALUE`.

use std::path::PathBuf;

use gmmcalib::command::args::{
    self as shared, CalibrateArgs, DriftArgs, flags, non_negative, on_off, positive, unknown,
};

/// The native CLI's usage: the shared commands' (`gmmcalib::command::args`), then its own.
pub fn usage() -> String {
    format!("{}\n{OWN_USAGE}\n{}\n{OWN_HELP}", shared::USAGE, shared::HELP)
}

const OWN_USAGE: &str = "\
       gmmcalib inspect FILE|BAG_FOLDER
       gmmcalib simulate --out DIR [--preset paper|paper-roof|paper-chair|...] [--frames F]
                          [--seed S] [--start K] [--max-angle-deg 3] [--max-yaw-deg DEG]
                          [--max-translation 0.1] [--move SENSOR:ROLL,PITCH,YAW,X,Y,Z]
       gmmcalib experiment --out DIR [--preset paper|...] [--trials N] [--frames F]
                          [--seed S] [--methods gmm,jrmpc,p2p,p2l,gicp] [--threads T]
                          [--max-angle-deg 3] [--max-yaw-deg DEG] [--max-translation 0.1]
       gmmcalib study [--preset paper|paper-roof|...] [--seeds 20] [--starts 5] [--frames 5]
                          [--max-angle-deg 3] [--max-yaw-deg DEG] [--max-translation 0.1]
                          [--method gmm] [--target cube:0.5|...|mesh:PATH|none] [--components K]
                          [--iterations N] [--tolerance T]
                          [--bev on|off] [--planes on|off] [--multiresolution on|off] [--exact] [--jitter ULPS] [--level on|off] [--global on|off] [--noise M]
                          [--columns N] [--threads T] [--notes] [--poses]
";

const OWN_HELP: &str = "\
  inspect: a recording's topics (count, rate, frame id, type) and its /tf_static tree; a rosbag2
  bag may be named by its folder (metadata.yaml beside the .mcap or .db3).
  Presets: paper, paper-roof (3 sensors), os1-128, sampled, paper-chair and paper-board (a
  chair / a board on a stand as the target), street (no target: walls, poles, cars); the rig
  zoo, no target either: stacked (a mast of two 32-beam LiDARs, the lower upside-down, float16
  points), sideways (on its side, pitched 50 deg down), mid100 (Livox Mid-100: three rosette
  units), surround (a Pandar64 and four PandarQT), moving (a car driving through the street).
  Nominals are wrong by up to --max-angle-deg (yaw: --max-yaw-deg) and --max-translation per
  axis; a tape measure: --max-angle-deg 45 --max-yaw-deg 180 --max-translation 1.
  simulate: writes the digital twin in that layout (DIR/config.yaml with miscalibrated nominal
  extrinsics, DIR/data/sensor_N/F.pcd) plus DIR/truth.json; the first sensor is the reference
  and keeps its true mount. --move turns and shifts a sensor's true mount in its own frame
  (deg, m), as a sensor knocked out of place: the drift check's test rig. --start K: the
  nominals of the study's start K of seed S (drawn from seed 1000 S + K), to look at one trial.
  experiment: the paper's experiment; every method on the same frames of each trial; writes
  DIR/summary.json, trials.csv, table.md and SVG plots.
  study: accuracy on the twin: seeds 1..=N of the scans, each calibrated from --starts wrong
  nominals (start k of seed s draws from seed 1000 s + k); prints the error distributions,
  per trial, per sensor, and the precision claimed against the errors. --poses: each
  trial's error in full, with the precision it claimed, to compare two runs trial by trial.
  --exact: JRMPC's exact E-step, the reference for the fast path. --jitter ULPS: every scan
  coordinate moved up or down by ULPS f32 units in the last place (1 um at 10 m), far below
  the LiDARs' noise: how much each trial rests on digits its data do not hold.";

/// What the user asked for. One is parsed per run, so the size difference does not matter.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub enum Command {
    Help,
    Inspect(PathBuf),
    Calibrate(CalibrateArgs),
    Drift(DriftArgs),
    Simulate(SimulateArgs),
    Experiment(ExperimentArgs),
    Study(StudyArgs),
}

/// The twin and its miscalibration, shared by `simulate` and `experiment`.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinArgs {
    pub preset: String,
    pub frames: usize,
    pub seed: u64,
    /// The study's start whose nominals to draw (from seed `1000 seed + start`); `None`: the
    /// scans' seed draws them.
    pub start: Option<u64>,
    /// Miscalibration bound per rotation axis (deg).
    pub max_angle_deg: f64,
    /// Yaw's bound (deg) when it differs from the other axes'.
    pub max_yaw_deg: Option<f64>,
    /// Miscalibration bound per translation axis (m).
    pub max_translation: f64,
    /// Sensors whose true mount is moved: `(sensor_N, [roll, pitch, yaw (deg), x, y, z (m)])`,
    /// applied in the sensor's own frame.
    pub moves: Vec<(String, [f64; 6])>,
}

impl Default for TwinArgs {
    fn default() -> Self {
        // The paper's bounds (gmmcalib::sim's defaults), in the units the flags take.
        Self {
            preset: "paper".into(),
            frames: 5,
            seed: 0,
            start: None,
            max_angle_deg: gmmcalib::twin::MAX_MISCALIBRATION_ANGLE.to_degrees(),
            max_yaw_deg: None,
            max_translation: gmmcalib::twin::MAX_MISCALIBRATION_TRANSLATION,
            moves: Vec::new(),
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
    /// `gmm`'s multi-resolution EM (`Settings::gmm_em`).
    pub multiresolution: bool,
    /// JRMPC's exact E-step (`EmSettings::exact`), the reference the fast path is judged by.
    pub exact: bool,
    /// Every scan coordinate moved by this many f32 units in the last place, up or down.
    pub jitter: u32,
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
            multiresolution: false,
            exact: false,
            jitter: 0,
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
                _ => Err("usage: gmmcalib inspect FILE|BAG_FOLDER".into()),
            };
        }
        Some(c @ ("calibrate" | "drift" | "compare")) => {
            // The commands the Node command shares: parsed by the library.
            let argv: Vec<String> = std::iter::once(c.to_string()).chain(args).collect();
            return Ok(match shared::parse(&argv)? {
                shared::CommandArgs::Calibrate(a) => Command::Calibrate(a),
                shared::CommandArgs::Drift(a) => Command::Drift(a),
                shared::CommandArgs::Help => Command::Help,
            });
        }
        Some(c @ ("simulate" | "experiment" | "study")) => c.to_string(),
        Some(other) => {
            return Err(format!(
                "unknown command '{other}' (expected calibrate, drift, inspect, simulate, experiment or study)"
            ));
        }
    };
    let Some(flags) = flags(args)? else { return Ok(Command::Help) };
    match command.as_str() {
        "simulate" => simulate(flags),
        "study" => study(flags),
        _ => experiment(flags),
    }
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
        "--start" => {
            twin.start = Some(
                value
                    .parse()
                    .map_err(|_| format!("{flag} expects a non-negative integer, got '{value}'"))?,
            )
        }
        "--max-angle-deg" => twin.max_angle_deg = non_negative(flag, value)?,
        "--max-yaw-deg" => twin.max_yaw_deg = Some(non_negative(flag, value)?),
        "--max-translation" => twin.max_translation = non_negative(flag, value)?,
        "--move" => {
            let bad =
                || format!("{flag} expects SENSOR:ROLL,PITCH,YAW,X,Y,Z (deg, m), got '{value}'");
            let (sensor, numbers) = value.split_once(':').ok_or_else(bad)?;
            let numbers: Vec<f64> = numbers
                .split(',')
                .map(|x| x.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<_>>()
                .ok_or_else(bad)?;
            twin.moves.push((sensor.to_string(), numbers.try_into().map_err(|_| bad())?));
        }
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

/// `--jitter`'s largest move: 2^16 ulps is 0.06 m at 10 m, beyond any LiDAR's noise.
const MAX_JITTER: u32 = 1 << 16;

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
            "--multiresolution" => out.multiresolution = on_off(&flag, &value)?,
            "--level" => out.level = Some(on_off(&flag, &value)?),
            "--global" => out.global = Some(on_off(&flag, &value)?),
            "--target" => out.target = Some(value),
            "--noise" => out.noise = Some(number(&value)?),
            "--columns" => out.columns = Some(positive(&flag, &value)?),
            "--threads" => out.threads = Some(positive(&flag, &value)?),
            "--notes" => out.notes = true,
            "--poses" => out.poses = true,
            "--exact" => out.exact = true,
            "--jitter" => {
                out.jitter = u32::try_from(positive(&flag, &value)?)
                    .ok()
                    .filter(|&u| u <= MAX_JITTER)
                    .ok_or_else(|| format!("{flag}: at most {MAX_JITTER} ulps"))?
            }
            _ => return Err(unknown(&flag)),
        }
    }
    Ok(Command::Study(out))
}

/// A target in its short form (`Target`'s), or `mesh:PATH` with PATH (relative to `dir`) read
/// here: the library parses the bytes.
pub fn target(value: &str, dir: &std::path::Path) -> Result<gmmcalib::targets::Target, String> {
    match gmmcalib::calib::mesh_path(value) {
        Some(path) => {
            let path = dir.join(path);
            let label = path.display().to_string();
            let bytes = std::fs::read(&path).map_err(|e| format!("{label}: {e}"))?;
            gmmcalib::targets::Target::from_mesh_file(&bytes, &label).map_err(|e| e.to_string())
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
    fn shared_commands_go_to_the_library() {
        let Ok(Command::Calibrate(a)) = parse(args("calibrate --data=d --iterations=7")) else {
            panic!("expected calibrate");
        };
        assert_eq!((a.data.as_str(), a.settings.iterations), ("d", Some(7)));
        assert!(matches!(parse(args("compare a.json b.json")), Ok(Command::Drift(_))));
    }

    #[test]
    fn parses_simulate_and_experiment() {
        let Ok(Command::Simulate(s)) =
            parse(args("simulate --out o --frames=3 --seed 9 --start 1 --max-angle-deg 1.5"))
        else {
            panic!("expected simulate");
        };
        assert_eq!((s.out, s.twin.frames, s.twin.seed), (PathBuf::from("o"), 3, 9));
        assert_eq!(s.twin.start, Some(1));
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
        assert!(parse(args("frobnicate")).is_err());
        assert!(matches!(parse(args("")), Ok(Command::Help)));
        assert!(parse(args("simulate --frames 2")).unwrap_err().contains("--out"));
        assert!(parse(args("simulate --out o --seed -1")).unwrap_err().contains("--seed"));
        assert!(parse(args("simulate --out o --start x")).unwrap_err().contains("--start"));
        assert!(parse(args("experiment --out o --max-translation -1")).is_err());
        assert!(parse(args("experiment --out o --trials 0")).is_err());
        assert!(parse(args("study --bev maybe")).unwrap_err().contains("on or off"));
        assert!(
            parse(args("simulate --out o --move sensor_2:1,2")).unwrap_err().contains("--move")
        );
        let Ok(Command::Simulate(s)) =
            parse(args("simulate --out o --move sensor_2:0,0,0.5,0,0,0"))
        else {
            panic!("expected simulate");
        };
        assert_eq!(s.twin.moves, [("sensor_2".to_string(), [0.0, 0.0, 0.5, 0.0, 0.0, 0.0])]);
    }

    #[test]
    fn parses_study() {
        let Ok(Command::Study(s)) = parse(args(
            "study --preset paper-roof --seeds 3 --max-yaw-deg 8 --planes off --notes \
                        --multiresolution on --exact --jitter 16",
        )) else {
            panic!("expected study");
        };
        assert_eq!((s.preset.as_str(), s.seeds, s.starts), ("paper-roof", 3, 5));
        assert_eq!((s.max_yaw_deg, s.planes, s.bev, s.notes), (Some(8.0), false, true, true));
        assert!(s.multiresolution && s.exact);
        assert_eq!(s.jitter, 16);
        assert!(parse(args("study --jitter 0")).is_err());
        assert!(parse(args("study --jitter 70000")).is_err());
    }

    /// A tape measure's nominals: any heading, roll and pitch within 45 deg, 1 m per axis.
    #[test]
    fn parses_tape_measure_bounds() {
        let flags = "--preset stacked --max-angle-deg 45 --max-yaw-deg 180 --max-translation 1";
        let Ok(Command::Study(s)) = parse(args(&format!("study {flags}"))) else {
            panic!("expected study");
        };
        assert_eq!((s.max_angle_deg, s.max_yaw_deg, s.max_translation), (45.0, Some(180.0), 1.0));
        let Ok(Command::Simulate(t)) = parse(args(&format!("simulate --out o {flags}"))) else {
            panic!("expected simulate");
        };
        let twin = &t.twin;
        assert_eq!((twin.preset.as_str(), twin.max_yaw_deg), ("stacked", Some(180.0)));
        assert_eq!((twin.max_angle_deg, twin.max_translation), (45.0, 1.0));
        assert_eq!(TwinArgs::default().max_yaw_deg, None, "yaw bound like the others");
        assert!(parse(args("simulate --out o --max-yaw-deg -1")).is_err());
    }
}
