//! The ray-cast digital twin (paper section V): a static scene of ground and boxes, rotating
//! LiDARs that produce organized scans in their own frames, presets with true mounts, and the
//! miscalibration sampler. Unlike `synth`, points come from exact ray casting, so occlusion,
//! ring spacing, beam incidence and missing returns look like a real scan.
//!
//! - [`scene`]: geometry and exact ray intersection.
//! - [`lidar`]: the sensor model and one scan.
//! - [`rig`]: presets, simulation of many frames, miscalibration and the expected correction.

pub mod lidar;
pub mod rig;
pub mod scene;

pub use lidar::Lidar;
pub use rig::{
    MAX_MISCALIBRATION_ANGLE, MAX_MISCALIBRATION_TRANSLATION, Preset, SensorSpec, SimView,
    expected_correction, miscalibrate,
};
pub use scene::{OrientedBox, Scene};
