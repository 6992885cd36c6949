//! Tests of `src/twin`, one module per concern (one test binary: one link).

#[path = "../common/mod.rs"]
mod common;

/// Accuracy on the digital twin.
mod accuracy;
/// The paper's experiment.
mod experiment;
/// The twin's scanners and scenes.
mod model;
/// The rig zoo.
mod zoo;
