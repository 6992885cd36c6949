//! Command-line arguments: `calibrate` and its flags, `--flag VALUE` or `--flag=VALUE`.

use std::path::PathBuf;

pub const USAGE: &str = "\
usage: gmmcalib calibrate --config CONFIG.yaml --data DIR
                          [--method gmm|jrmpc|p2p|p2l|gicp|all] [--reference NAME]
                          [--iterations N] [--components K] [--json OUT.json]

  DIR holds one folder per sensor (sensor_1, sensor_2, ...), each with frames 1.pcd, 2.pcd, ...
  (.pcd, .ply or .bin); frames pair across sensors by file stem. Flags override CONFIG.yaml.";

/// What the user asked for.
#[derive(Debug)]
pub enum Command {
    Help,
    Calibrate(CalibrateArgs),
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
    pub json: Option<PathBuf>,
}

/// Parses the arguments after the program name.
pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Command, String> {
    let mut args = args.into_iter();
    match args.next().as_deref() {
        None | Some("-h" | "--help" | "help") => return Ok(Command::Help),
        Some("calibrate") => {}
        Some(other) => return Err(format!("unknown command '{other}' (expected calibrate)")),
    }
    let mut out = CalibrateArgs::default();
    let (mut config, mut data) = (None, None);
    while let Some(arg) = args.next() {
        if arg == "-h" || arg == "--help" {
            return Ok(Command::Help);
        }
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (arg.clone(), None),
        };
        let mut value = || {
            inline.clone().or_else(|| args.next()).ok_or_else(|| format!("{flag} needs a value"))
        };
        match flag.as_str() {
            "--config" => config = Some(PathBuf::from(value()?)),
            "--data" => data = Some(PathBuf::from(value()?)),
            "--method" => out.method = Some(value()?),
            "--reference" => out.reference = Some(value()?),
            "--iterations" => out.iterations = Some(positive(&flag, &value()?)?),
            "--components" => out.components = Some(positive(&flag, &value()?)?),
            "--json" => out.json = Some(PathBuf::from(value()?)),
            _ => return Err(format!("unknown argument '{arg}' (see gmmcalib --help)")),
        }
    }
    out.config = config.ok_or("calibrate needs --config CONFIG.yaml")?;
    out.data = data.ok_or("calibrate needs --data DIR")?;
    Ok(Command::Calibrate(out))
}

fn positive(flag: &str, value: &str) -> Result<usize, String> {
    match value.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{flag} expects a positive integer, got '{value}'")),
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
    fn rejects_bad_input() {
        assert!(parse(args("calibrate --data d")).unwrap_err().contains("--config"));
        assert!(parse(args("calibrate --config c --data d --iterations 0")).is_err());
        assert!(
            parse(args("calibrate --config c --data d --bogus")).unwrap_err().contains("bogus")
        );
        assert!(parse(args("calibrate --config")).unwrap_err().contains("needs a value"));
        assert!(parse(args("frobnicate")).is_err());
        assert!(matches!(parse(args("")), Ok(Command::Help)));
    }
}
