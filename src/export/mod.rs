//! Every writer: what a result, a rig, a cloud or a mesh becomes as a file. The CLI, `gmmcalib
//! simulate` and the page (through wasm) all write here, so each format has one writer.
//!
//! Readers are `io`'s (bytes in); the result's shape is `report`'s (types and prose).

mod clouds;
mod gmmcalib;
pub mod ros;
mod target;

pub use clouds::{
    write_obj, write_pcd_binary, write_pcd_binary_compressed, write_pcd_binary_organized,
    write_ply_binary,
};
pub use gmmcalib::{ConfigTransform, gmmcalib_config};
pub use ros::Extrinsic;
pub use target::{Target, target_ply};

use serde::Serialize;

use crate::cloud::Aabb;
use crate::report::Report;
use crate::se3::{Pose, from_row_major};

/// Every JSON the tool writes (a result, a comparison, a drift report, a twin's truth): pretty,
/// with a final newline.
pub fn json(value: &impl Serialize) -> Result<String, serde_json::Error> {
    Ok(serde_json::to_string_pretty(value)? + "\n")
}

/// One calibration in every form a user takes it away in. Each extrinsic is `T_parent_child`:
/// `parent` (the frame the nominals and the ROI are given in) is the parent, each sensor the
/// child of its own name.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Exports {
    pub parent: String,
    /// The result as `gmmcalib calibrate --json` writes it (absent when made from the
    /// extrinsics alone: it names no frame, so a renamed parent leaves it as it was).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "ts", ts(optional))]
    pub json: Option<String>,
    /// GMMCalib's `config.yaml` with the calibrated transforms and the ROI.
    pub gmmcalib_yaml: String,
    pub urdf: String,
    pub ros1: String,
    pub ros2: String,
    pub tf_yaml: String,
    pub autoware: String,
    pub kitti: String,
    /// The reconstructed target as PLY (absent for a method that reconstructs nothing).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "ts", ts(optional))]
    pub target_ply: Option<String>,
}

impl Exports {
    /// Every export of `report`, with `parent` the vehicle frame's name: made from the numbers
    /// the result reports, as a renamed frame's exports are (`exportsOf`), so the two differ in
    /// the frame's name alone.
    pub fn of(report: &Report, parent: &str) -> Self {
        let sensors: Vec<(String, Pose)> = (report.sensors.iter())
            .map(|s| (s.name.clone(), from_row_major(&s.extrinsic)))
            .collect();
        let roi = Aabb::new(report.roi.min, report.roi.max);
        let r = &report.reconstruction;
        let target = Target { means: &r.means, sigmas: &r.sigmas, priors: &r.priors };
        // serde_json writes a report whole (NaN as null, no map keys that are not strings).
        let json = json(report).ok();
        Self { json, ..Self::new(parent, &sensors, &roi, target) }
    }

    /// The exports that name frames: of each sensor's `T_parent_sensor`, the ROI and the target.
    /// What a renamed parent changes.
    pub fn new(parent: &str, sensors: &[(String, Pose)], roi: &Aabb, target: Target) -> Self {
        let extrinsics: Vec<Extrinsic> = (sensors.iter())
            .map(|(name, pose)| Extrinsic {
                parent: parent.into(),
                child: name.clone(),
                pose: *pose,
            })
            .collect();
        let transforms: Vec<ConfigTransform> = sensors
            .iter()
            .map(|(name, pose)| {
                let (xyz, rpy) = crate::se3::xyz_rpy(pose);
                ConfigTransform {
                    sensor: name.clone(),
                    xyz,
                    rpy,
                    note: format!("{name} -> {parent}"),
                }
            })
            .collect();
        let comment = "gmmcalib: calibrated extrinsics";
        Self {
            parent: parent.into(),
            json: None,
            gmmcalib_yaml: gmmcalib_config(comment, &transforms, None, roi),
            urdf: ros::urdf(&extrinsics),
            ros1: ros::ros1_static_transform_publisher(&extrinsics),
            ros2: ros::ros2_static_transform_publisher(&extrinsics),
            tf_yaml: ros::tf_static_yaml(&extrinsics),
            autoware: ros::autoware_calibration(&extrinsics),
            kitti: ros::kitti_tr(&extrinsics),
            target_ply: target_ply(target, parent),
        }
    }
}
