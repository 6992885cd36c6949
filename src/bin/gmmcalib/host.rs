//! The shared command line's [`Host`] natively: `std::fs`, stdout, stderr, and the cores.

use std::io::{IsTerminal, Write};

use gmmcalib::command::{EntryKind, Host};
use gmmcalib::io::recording::{FileSource, ReadAt};

pub struct Native {
    /// Progress lines only on a terminal.
    show: bool,
}

impl Native {
    pub fn new() -> Self {
        Self { show: std::io::stderr().is_terminal() }
    }
}

impl Host for Native {
    fn read(&mut self, path: &str) -> Result<Vec<u8>, String> {
        std::fs::read(path).map_err(|e| e.to_string())
    }

    fn list(&mut self, dir: &str) -> Result<Vec<String>, String> {
        let mut names = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(|e| e.to_string())? {
            let entry = entry.map_err(|e| e.to_string())?;
            names.push(entry.file_name().to_string_lossy().into_owned());
        }
        Ok(names)
    }

    fn kind(&mut self, path: &str) -> EntryKind {
        match std::fs::metadata(path) {
            Ok(m) if m.is_file() => EntryKind::File,
            Ok(m) if m.is_dir() => EntryKind::Dir,
            _ => EntryKind::Other,
        }
    }

    fn write(&mut self, path: &str, bytes: &[u8]) -> Result<(), String> {
        std::fs::write(path, bytes).map_err(|e| e.to_string())
    }

    fn open(&mut self, path: &str) -> Result<Box<dyn ReadAt>, String> {
        Ok(Box::new(FileSource::open(std::path::Path::new(path)).map_err(|e| e.to_string())?))
    }

    fn out(&mut self, text: &str) {
        print!("{text}");
    }

    fn err(&mut self, text: &str) {
        eprint!("{text}");
    }

    fn progress(&mut self, line: &str) {
        if self.show {
            // Clear the line first: a frame pair's line is shorter than an iteration's.
            let mut err = std::io::stderr();
            let _ = write!(err, "\r\x1b[K{line}");
            let _ = err.flush();
        }
    }

    fn threads(&self) -> usize {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    }
}
