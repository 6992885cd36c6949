//! Tests of `src/io`, one module per concern (one test binary: one link).

#[path = "../common/mod.rs"]
mod common;

/// The readers and writers.
mod files;
/// CAD meshes.
mod mesh;
/// Recordings: MCAP, ROS 1, rosbag2.
mod recording;
/// Malformed input.
mod robustness;
