//! The command line that the native CLI (`src/bin/gmmcalib`) and the Node command (`npx
//! gmmcalib`, through `wasm::command`) share: `gmmcalib calibrate` and `gmmcalib drift`, from
//! the arguments to the exit status. Files and output go through a [`Host`], so the same code
//! reads a folder through `std::fs` natively and through Node's `fs` in wasm, and both give
//! the same results, the same JSON and the same errors. An edge module: it makes prose.

pub mod args;
mod calibrate;
mod dataset;
mod drift;
mod recording;

pub use crate::layout::natural;
pub use args::{CalibrateArgs, CommandArgs, DriftArgs};
pub use calibrate::{VERDICT_FAILED, calibrate};
pub use drift::{DRIFT, drift};
pub use recording::resolve as recording_file;

use crate::io::recording::ReadAt;

/// What a path names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EntryKind {
    File,
    Dir,
    /// Nothing there, or something else (a socket, a broken link).
    Other,
}

/// The file system and the terminal. A file error is the system's reason without the path
/// (`No such file or directory (os error 2)`); the commands name the file.
pub trait Host {
    fn read(&mut self, path: &str) -> Result<Vec<u8>, String>;
    /// The names in the folder `dir`, in any order.
    fn list(&mut self, dir: &str) -> Result<Vec<String>, String>;
    /// What `path` names, following links.
    fn kind(&mut self, path: &str) -> EntryKind;
    fn write(&mut self, path: &str, bytes: &[u8]) -> Result<(), String>;
    /// Random access to a (possibly huge) recording.
    fn open(&mut self, path: &str) -> Result<Box<dyn ReadAt>, String>;
    /// Standard output.
    fn out(&mut self, text: &str);
    /// Standard error.
    fn err(&mut self, text: &str);
    /// A transient progress line (empty: clear it); shown only on a terminal.
    fn progress(&mut self, line: &str);
    /// Threads the calibration may use (the result does not depend on it).
    fn threads(&self) -> usize;
}

/// The text of the file at `path`, errors naming it.
fn read_text(host: &mut dyn Host, path: &str) -> Result<String, String> {
    let bytes = host.read(path).map_err(|e| format!("{path}: {e}"))?;
    String::from_utf8(bytes).map_err(|_| format!("{path}: stream did not contain valid UTF-8"))
}

/// `dir/name`, as `Path::join` writes it on Unix.
pub(crate) fn join(dir: &str, name: &str) -> String {
    if dir.is_empty() || name.starts_with('/') {
        name.to_string()
    } else if dir.ends_with('/') {
        format!("{dir}{name}")
    } else {
        format!("{dir}/{name}")
    }
}

/// The folder holding `path` (empty for a bare file name).
pub(crate) fn parent(path: &str) -> &str {
    match path.rfind('/') {
        Some(0) => "/",
        Some(i) => &path[..i],
        None => "",
    }
}

/// Runs the command in `argv` (without the program's name): `calibrate`, `drift` or help.
/// Returns the exit status; an error is one line on standard error, status 1.
pub fn run(argv: &[String], host: &mut dyn Host) -> u8 {
    let outcome = match args::parse(argv) {
        Ok(CommandArgs::Help) => {
            host.out(&format!("{}\n", args::USAGE));
            Ok(0)
        }
        Ok(CommandArgs::Calibrate(a)) => calibrate(&a, host),
        Ok(CommandArgs::Drift(a)) => drift(&a, host),
        Err(e) => Err(e),
    };
    outcome.unwrap_or_else(|e| {
        host.err(&format!("gmmcalib: {}\n", e.replace('\n', " ")));
        1
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_join_as_the_native_path_does() {
        assert_eq!(join("data", "sensor_1"), "data/sensor_1");
        assert_eq!(join("data/", "sensor_1"), "data/sensor_1");
        assert_eq!(join("", "target.obj"), "target.obj");
        assert_eq!(join("a", "/abs/t.obj"), "/abs/t.obj");
        assert_eq!((parent("a/b/c.yaml"), parent("c.yaml"), parent("/c")), ("a/b", "", "/"));
    }
}
