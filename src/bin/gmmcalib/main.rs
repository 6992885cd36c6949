//! `gmmcalib calibrate`: GMMCalib's data folder and YAML config in, calibration out (text on
//! stdout, JSON with `--json`); `gmmcalib drift`: the drift check. Both live in the library
//! (`gmmcalib::command`), shared with the Node command. `gmmcalib simulate`: the digital twin
//! written in that layout. `gmmcalib experiment`: the paper's experiment on the twin.
//! `gmmcalib study`: accuracy on the twin over many seeds and starts. Thin adapters: the library does all the work. Native
//! only; the wasm32 build gets an empty `main` so `cargo test --target wasm32-unknown-unknown`
//! still builds.

#[cfg(not(target_arch = "wasm32"))]
mod args;
#[cfg(not(target_arch = "wasm32"))]
mod experiment;
#[cfg(not(target_arch = "wasm32"))]
mod host;
#[cfg(not(target_arch = "wasm32"))]
mod layout;
#[cfg(not(target_arch = "wasm32"))]
mod parallel;
#[cfg(not(target_arch = "wasm32"))]
mod recording;
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
    use std::process::ExitCode;

    use gmmcalib::command;

    use crate::args::{self, Command};
    use crate::host::Native;

    pub fn run(argv: impl IntoIterator<Item = String>) -> Result<ExitCode, String> {
        let done = |r: Result<(), String>| r.map(|()| ExitCode::SUCCESS);
        match args::parse(argv)? {
            Command::Help => {
                println!("{}", args::usage());
                Ok(ExitCode::SUCCESS)
            }
            Command::Inspect(file) => done(crate::recording::inspect(&file)),
            // The commands the Node command shares, in the library.
            Command::Calibrate(a) => command::calibrate(&a, &mut Native::new()).map(ExitCode::from),
            Command::Drift(a) => command::drift(&a, &mut Native::new()).map(ExitCode::from),
            Command::Simulate(a) => done(crate::simulate::run(&a)),
            Command::Experiment(a) => done(crate::experiment::run(&a)),
            Command::Study(a) => done(crate::study::run(&a)),
        }
    }
}
