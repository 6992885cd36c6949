//! The arguments of `calibrate` and `drift`, `--flag VALUE` or `--flag=VALUE`, and the
//! checks every command's flags share.

use crate::calib::SettingsInput;
use crate::drift::{DEFAULT_ROTATION_TOLERANCE, DEFAULT_TRANSLATION_TOLERANCE, Tolerance};

pub const USAGE: &str = "\
usage: gmmcalib calibrate --data DIR [--config CONFIG.yaml]
                          [--method gmm|jrmpc|cad|p2p|p2l|gicp|all] [--reference NAME]
                          [--target cube:EDGE|box:W,D,H|sphere:DIAMETER|mesh:PATH|none]
                          [--roi XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX] [--global on|off]
                          [--level on|off] [--bev on|off] [--refine]
                          [--iterations N] [--components K] [--threads T] [--exact]
                          [--json OUT.json]
       gmmcalib calibrate --bag FILE [--topics /a,/b] [--reference /a] [--base-frame base_link]
                          [--frames N] [--urdf FILE] [--export ros1|ros2|tf-yaml|urdf|autoware|kitti]
                          (and the options above)
       gmmcalib drift STORED NEW [--rotation-deg 0.1] [--translation 0.01] [--sigmas K]
                          [--json OUT.json]";

/// What `drift` and `calibrate` do, said once for both command lines.
pub const HELP: &str = "\
  calibrate: prints the verdict first (good, check or failed, with the reasons); exit status
  0 when it calibrated, 2 when it calibrated but the verdict is failed (every method's, with
  --method all): do not use that extrinsic; 1 on an error.
  DIR holds one folder per sensor (sensor_1/, or any name: up/, down/), each with frames
  1.pcd, 2.pcd, ... (.pcd, .ply or .bin), or loose files <sensor>_<frame>.pcd; frames pair
  across sensors by file stem, else by the nearest timestamp (stems that are numbers). Or
  OpenCalib's layout: lidar_cloud_path.txt naming each device's file, and its guess
  initial_extrinsic.txt. Nominals come from CONFIG.yaml (6 numbers [roll, pitch, yaw, x, y,
  z], 7 [x, y, z, qx, qy, qz, qw] or 16, a 4x4 row-major), else from OpenCalib's guess, else
  identity for every sensor: the global alignment (on for gmm) finds the rest. Without a ROI
  the region around the targets found is used (a target of known shape), else where the
  clouds overlap. Flags override CONFIG.yaml. --threads: threads
  sharing JRMPC's E-step and the frame pairs (default: the available cores; the result does
  not depend on it). --exact: JRMPC's E-step as the paper states it, every point against
  every component in double precision (config: exact: true); 7-13x slower, and within
  1e-5 rad of the default's calibration on the twin rigs.
  --bag: a recording (MCAP, ROS 1 .bag, rosbag2 .db3, or a rosbag2 bag's folder) instead
  of --data: sensors are its point-cloud topics (PointCloud2 or Livox CustomMsg; default:
  all), frames are N instants (default 10) spread over it where every topic has a scan
  within 20 ms of the reference's (the first topic unless --reference).
  Nominals T_base_frame come from --urdf (joint origins) or /tf_static, resolved for each
  topic's frame_id to --base-frame (default base_link, else the tree's root). --export prints
  the corrected extrinsics (parent the base frame, child each frame id) in that form; urdf
  edits the --urdf file's joint origins in place when one was given.
  drift (compare, its first name, still works): has a sensor moved? STORED is a calibration
  kept from before (calibrate's --json, or a URDF or /tf_static YAML it exported), NEW
  calibrate's --json of a new recording. Each
  sensor's pose relative to the reference is compared; it has moved when the rotation
  changed by more than --rotation-deg (default 0.1) or the position by more than
  --translation (m, default 0.01), or with --sigmas K when a change on any axis is beyond K
  times the combined one-sigma precision (sensors without a precision keep the fixed limits).
  Exit status 0 when none moved, 3 when one moved or went missing (named on stderr), 1 on an
  error.";

/// The shared commands. One is parsed per run, so the size difference does not matter.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub enum CommandArgs {
    Help,
    Calibrate(CalibrateArgs),
    Drift(DriftArgs),
}

#[derive(Debug, Default, PartialEq)]
pub struct CalibrateArgs {
    pub config: Option<String>,
    pub data: String,
    /// The settings the flags set (`--method`, `--target`, `--global`, `--level`, `--bev`,
    /// `--refine`, `--iterations`, `--components`, `--threads`, `--exact`): over the config's.
    pub settings: SettingsInput,
    pub roi: Option<[f64; 6]>,
    pub reference: Option<String>,
    pub json: Option<String>,
    /// A recording instead of `data`, and what to take from it.
    pub bag: Option<String>,
    pub topics: Option<String>,
    pub base_frame: Option<String>,
    pub frames: Option<usize>,
    pub urdf: Option<String>,
    pub export: Option<String>,
}

#[derive(Debug, PartialEq)]
pub struct DriftArgs {
    pub stored: String,
    pub new: String,
    pub tolerance: Tolerance,
    pub json: Option<String>,
}

/// Parses `calibrate ...`, `drift ...` (or `compare ...`, its first name) or help.
pub fn parse(argv: &[String]) -> Result<CommandArgs, String> {
    let mut args = argv.iter().cloned();
    match args.next().as_deref() {
        None | Some("-h" | "--help" | "help") => Ok(CommandArgs::Help),
        Some("calibrate") => Ok(match flags(args)? {
            Some(f) => CommandArgs::Calibrate(calibrate(f)?),
            None => CommandArgs::Help,
        }),
        Some("drift" | "compare") => Ok(match drift(args)? {
            Some(c) => CommandArgs::Drift(c),
            None => CommandArgs::Help,
        }),
        Some(other) => Err(format!("unknown command '{other}' (expected calibrate or drift)")),
    }
}

/// `(flag, value)` pairs; `None` when help was asked for. `--notes`, `--poses` and `--exact`
/// take no value.
pub fn flags(args: impl Iterator<Item = String>) -> Result<Option<Vec<(String, String)>>, String> {
    let mut args = args.peekable();
    let mut out = Vec::new();
    while let Some(arg) = args.next() {
        if arg == "-h" || arg == "--help" {
            return Ok(None);
        }
        if !arg.starts_with("--") {
            return Err(format!("unknown argument '{arg}' (see gmmcalib --help)"));
        }
        if ["--notes", "--poses", "--exact", "--refine"].contains(&arg.as_str()) {
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

pub fn calibrate(flags: Vec<(String, String)>) -> Result<CalibrateArgs, String> {
    let mut out = CalibrateArgs::default();
    let mut data = None;
    for (flag, value) in flags {
        match flag.as_str() {
            "--config" => out.config = Some(value),
            "--data" => data = Some(value),
            "--method" => out.settings.method = Some(value.parse()?),
            "--reference" => out.reference = Some(value),
            "--target" => {
                out.settings.target = Some(value.parse().map_err(|e| format!("--target: {e}"))?)
            }
            "--roi" => out.roi = Some(six(&flag, &value)?),
            "--global" => out.settings.global = Some(on_off(&flag, &value)?),
            "--level" => out.settings.level = Some(on_off(&flag, &value)?),
            "--bev" => out.settings.bev = Some(on_off(&flag, &value)?),
            "--refine" => out.settings.refine = Some(true),
            "--iterations" => out.settings.iterations = Some(positive(&flag, &value)?),
            "--components" => out.settings.components = Some(positive(&flag, &value)?),
            "--threads" => out.settings.threads = Some(positive(&flag, &value)?),
            "--exact" => out.settings.exact = Some(true),
            "--json" => out.json = Some(value),
            "--bag" => out.bag = Some(value),
            "--topics" => out.topics = Some(value),
            "--base-frame" => out.base_frame = Some(value),
            "--frames" => out.frames = Some(positive(&flag, &value)?),
            "--urdf" => out.urdf = Some(value),
            "--export" => out.export = Some(value),
            _ => return Err(unknown(&flag)),
        }
    }
    match (data, &out.bag) {
        (Some(_), Some(_)) => Err("calibrate takes --data DIR or --bag FILE, not both".into()),
        (Some(d), None) => {
            out.data = d;
            Ok(out)
        }
        (None, Some(_)) => Ok(out),
        (None, None) => Err("calibrate needs --data DIR or --bag FILE".into()),
    }
}

/// `drift STORED NEW [flags]`; `None` when help was asked for.
fn drift(args: impl Iterator<Item = String>) -> Result<Option<DriftArgs>, String> {
    let (mut files, mut rest) = (Vec::new(), Vec::new());
    let mut args = args.peekable();
    while let Some(arg) = args.next() {
        if arg.starts_with('-') {
            // A flag and, unless written with '=', its value.
            let takes_value = !arg.contains('=') && arg != "-h" && arg != "--help";
            rest.push(arg);
            if takes_value {
                rest.extend(args.next());
            }
        } else {
            files.push(arg);
        }
    }
    let Some(flags) = flags(rest.into_iter())? else { return Ok(None) };
    let [stored, new]: [String; 2] = files.try_into().map_err(|f: Vec<String>| {
        format!("drift takes two files, STORED and NEW, got {}", f.len())
    })?;
    let (mut rotation, mut translation) =
        (DEFAULT_ROTATION_TOLERANCE, DEFAULT_TRANSLATION_TOLERANCE);
    let (mut sigmas, mut json) = (None, None);
    for (flag, value) in flags {
        match flag.as_str() {
            "--rotation-deg" => rotation = non_negative(&flag, &value)?.to_radians(),
            "--translation" => translation = non_negative(&flag, &value)?,
            "--sigmas" => sigmas = Some(non_negative(&flag, &value)?),
            "--json" => json = Some(value),
            _ => return Err(unknown(&flag)),
        }
    }
    let tolerance = match sigmas {
        Some(sigmas) => Tolerance::Precision { sigmas, rotation, translation },
        None => Tolerance::Fixed { rotation, translation },
    };
    Ok(Some(DriftArgs { stored, new, tolerance, json }))
}

/// Six comma-separated finite numbers.
pub fn six(flag: &str, value: &str) -> Result<[f64; 6], String> {
    let numbers: Vec<f64> = value
        .split(',')
        .filter_map(|x| x.trim().parse().ok())
        .filter(|x: &f64| x.is_finite())
        .collect();
    numbers.try_into().map_err(|_| {
        format!("{flag} expects six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX, got '{value}'")
    })
}

pub fn on_off(flag: &str, value: &str) -> Result<bool, String> {
    match value {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("{flag} expects on or off, got '{value}'")),
    }
}

pub fn unknown(flag: &str) -> String {
    format!("unknown argument '{flag}' (see gmmcalib --help)")
}

pub fn positive(flag: &str, value: &str) -> Result<usize, String> {
    match value.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{flag} expects a positive integer, got '{value}'")),
    }
}

pub fn non_negative(flag: &str, value: &str) -> Result<f64, String> {
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
        let Ok(CommandArgs::Calibrate(a)) =
            parse(&args("calibrate --config c.yaml --data=d --method all --iterations=7"))
        else {
            panic!("expected calibrate");
        };
        assert_eq!((a.config.as_deref(), a.data.as_str()), (Some("c.yaml"), "d"));
        let s = &a.settings;
        assert_eq!(s.method, Some(crate::calib::Methods(crate::calib::Method::ALL.to_vec())));
        assert_eq!((s.iterations, s.components, s.exact), (Some(7), None, None));
        let Ok(CommandArgs::Calibrate(a)) = parse(&args("calibrate --exact --data d")) else {
            panic!("expected calibrate");
        };
        assert!(a.settings.exact == Some(true) && a.data == "d", "--exact takes no value");
    }

    #[test]
    fn parses_drift_and_its_first_name() {
        let Ok(CommandArgs::Drift(c)) =
            parse(&args("drift old.json --sigmas 3 new.json --rotation-deg=0.2"))
        else {
            panic!("expected drift");
        };
        assert_eq!((c.stored.as_str(), c.new.as_str()), ("old.json", "new.json"));
        let Tolerance::Precision { sigmas, rotation, translation } = c.tolerance else { panic!() };
        assert_eq!((sigmas, translation), (3.0, 0.01));
        assert!((rotation.to_degrees() - 0.2).abs() < 1e-12);
        let Ok(CommandArgs::Drift(c)) = parse(&args("compare a b")) else { panic!() };
        assert_eq!(c.tolerance, Tolerance::default());
    }

    #[test]
    fn rejects_bad_input() {
        let err = |s: &str| parse(&args(s)).unwrap_err();
        assert!(err("calibrate --config c").contains("--data"));
        assert!(err("calibrate --data d --roi 1,2,3").contains("six numbers"));
        assert!(err("calibrate --config c --data d --iterations 0").contains("positive"));
        assert!(err("calibrate --config c --data d --bogus x").contains("bogus"));
        assert!(err("calibrate --config").contains("needs a value"));
        assert!(err("frobnicate").contains("unknown command"));
        assert!(err("drift a").contains("two files"));
        assert!(err("drift a b c").contains("got 3"));
        assert!(err("drift a b --sigmas -1").contains("--sigmas"));
        assert!(err("drift a b --tolerance 1").contains("unknown argument '--tolerance'"));
        assert!(matches!(parse(&args("")), Ok(CommandArgs::Help)));
        assert!(matches!(parse(&args("drift --help")), Ok(CommandArgs::Help)));
    }
}
