//! `rosExports(extrinsics, roi?)`: one calibration's extrinsics in ROS's own terms, made by the
//! library's writers (`report::ros`), which the CLI's `--export` prints too; with the ROI, also
//! GMMCalib's config.yaml (`io::gmmcalib_config`, which `gmmcalib simulate` writes too).

use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::{Roi, options_or_default, to_js};
use crate::io::{ConfigTransform, gmmcalib_config};
use crate::report::ros::{self, Extrinsic};

#[derive(Deserialize)]
struct ExtrinsicInput {
    parent: String,
    child: String,
    /// `T_parent_child`, row-major 4x4.
    pose: Vec<f64>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ExportsOutput {
    ros1: String,
    ros2: String,
    tf_yaml: String,
    urdf: String,
    autoware: String,
    kitti: String,
    /// With a ROI: GMMCalib's config.yaml of the extrinsics.
    #[serde(skip_serializing_if = "Option::is_none")]
    gmmcalib_yaml: Option<String>,
}

/// Every ROS export of `extrinsics` (`[{parent, child, pose}]`, `pose` = `T_parent_child`
/// row-major 4x4): `{ros1, ros2, tfYaml, urdf, autoware, kitti}`, each stating its direction;
/// with `roi` (`{min, max}`, m), `gmmcalibYaml` too.
#[wasm_bindgen(js_name = rosExports)]
pub fn ros_exports(extrinsics: JsValue, roi: JsValue) -> Result<JsValue, JsError> {
    let roi: Option<Roi> = options_or_default(roi, "rosExports roi")?;
    let input: Vec<ExtrinsicInput> = options_or_default(extrinsics, "rosExports")?;
    let extrinsics = input
        .into_iter()
        .map(|e| {
            let pose = <[f64; 16]>::try_from(e.pose.as_slice())
                .ok()
                .filter(|m| m.iter().all(|x| x.is_finite()))
                .map(|m| crate::se3::from_row_major(&m))
                .ok_or_else(|| {
                    JsError::new(&format!("{}: pose is not 16 finite numbers", e.child))
                })?;
            Ok(Extrinsic { parent: e.parent, child: e.child, pose })
        })
        .collect::<Result<Vec<_>, JsError>>()?;
    to_js(&ExportsOutput {
        ros1: ros::ros1_static_transform_publisher(&extrinsics),
        ros2: ros::ros2_static_transform_publisher(&extrinsics),
        tf_yaml: ros::tf_static_yaml(&extrinsics),
        urdf: ros::urdf(&extrinsics),
        autoware: ros::autoware_calibration(&extrinsics),
        kitti: ros::kitti_tr(&extrinsics),
        gmmcalib_yaml: roi.map(|roi| {
            let transforms: Vec<ConfigTransform> = extrinsics
                .iter()
                .map(|e| {
                    let (xyz, rpy) = crate::se3::xyz_rpy(&e.pose);
                    let note = format!("{} -> {}", e.child, e.parent);
                    ConfigTransform { sensor: e.child.clone(), xyz, rpy, note }
                })
                .collect();
            let roi = crate::cloud::Aabb::new(roi.min, roi.max);
            gmmcalib_config("gmmcalib: calibrated extrinsics", &transforms, None, &roi)
        }),
    })
}
