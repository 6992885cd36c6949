//! GMMCalib's `config.yaml`, the rig description GMMCalib itself reads (`crate::config` reads
//! it back).

/// One sensor's transform in GMMCalib's `config.yaml`: `T_vehicle_sensor` as the numbers the
/// file holds, and a note for its comment.
pub struct ConfigTransform {
    pub sensor: String,
    /// m.
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw (rad), about the fixed x, y, z axes.
    pub rpy: [f64; 3],
    pub note: String,
}

/// GMMCalib's `config.yaml`: `number_of_sensors`, `transform_<sensor>: - [roll, pitch, yaw, x,
/// y, z]` per sensor, our `reference` key when given, and the ROI as `min_bound` / `max_bound`;
/// `comment` (lines) first. Numbers as the shortest text that reads back to the same f64, so
/// `config::Config` reads the file back bit for bit. The page's export and `gmmcalib simulate`
/// both write it here.
pub fn gmmcalib_config(
    comment: &str,
    transforms: &[ConfigTransform],
    reference: Option<&str>,
    roi: &crate::cloud::Aabb,
) -> String {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
    let mut yaml: String = comment.lines().map(|l| format!("# {l}\n")).collect();
    yaml += &format!("number_of_sensors: {}\n", transforms.len());
    for t in transforms {
        let values = [t.rpy[0], t.rpy[1], t.rpy[2], t.xyz[0], t.xyz[1], t.xyz[2]];
        yaml += &format!(
            "transform_{}:  # {}\n  - [{}]  # [roll, pitch, yaw (rad), x, y, z (m)]\n",
            t.sensor,
            t.note,
            list(&values)
        );
    }
    if let Some(name) = reference {
        yaml += &format!("reference: {name}\n");
    }
    yaml += &format!("min_bound:\n  - [{}]\n", list(&roi.min));
    yaml + &format!("max_bound:\n  - [{}]\n", list(&roi.max))
}
