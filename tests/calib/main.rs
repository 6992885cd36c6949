//! Tests of `src/calib`, one module per concern (one test binary: one link).

#[path = "../common/mod.rs"]
mod common;

/// The pipeline end to end on synthetic rigs.
mod calibration;
/// The global initial alignment.
mod global;
/// The run's state machine, stepped by hand.
mod run;
/// The verdict on a labelled suite.
mod verdict;
