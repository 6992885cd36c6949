//! `calibrate --bag FILE`: the rig a recording's point-cloud topics make (sensors named by
//! topic, frames by instant), with nominals from a URDF or `/tf_static`, and `--export`.

use super::{EntryKind, Host, join, read_text};
use crate::calib::Calibration;
use crate::export::ros::{self, Extrinsic};
use crate::io::recording::instants::InstantSettings;
use crate::io::recording::urdf::Urdf;
use crate::io::recording::{Recording, RecordingRig, RigRequest, storage_file};

/// What `calibrate --bag` asks of a recording.
pub struct BagRequest<'a> {
    pub topics: Option<&'a str>,
    pub reference: Option<&'a str>,
    pub base_frame: &'a str,
    pub frames: usize,
    pub urdf: Option<&'a str>,
}

/// The rig a recording makes, and the URDF its nominals came from (for the `urdf` export).
pub struct BagRig {
    pub rig: RecordingRig,
    pub urdf: Option<Urdf>,
}

/// The recording file `path` names: itself, or the storage file of the rosbag2 bag folder it
/// names (`metadata.yaml` beside a `.mcap` or `.db3`).
pub fn resolve(host: &mut dyn Host, path: &str) -> Result<String, String> {
    if host.kind(path) != EntryKind::Dir {
        return Ok(path.to_string());
    }
    let names = host.list(path).map_err(|e| format!("{path}: {e}"))?;
    let meta = join(path, "metadata.yaml");
    let metadata =
        if host.kind(&meta) == EntryKind::File { Some(read_text(host, &meta)?) } else { None };
    Ok(join(path, &storage_file(path, &names, metadata.as_deref())?))
}

/// Opens `path` (a file or a rosbag2 folder), with a progress line while a file without index
/// is scanned.
pub fn open(host: &mut dyn Host, path: &str) -> Result<Recording, String> {
    let path = &resolve(host, path)?;
    let source = host.open(path).map_err(|e| format!("{path}: {e}"))?;
    let rec = Recording::open(source, path, &mut |done, total| {
        host.progress(&format!("scanning {}%", done * 100 / total.max(1)));
    })
    .map_err(|e| e.to_string())?;
    host.progress("");
    for p in rec.problems() {
        host.err(&format!("gmmcalib: warning: {p}\n"));
    }
    Ok(rec)
}

/// The library's rig from the recording at `path`, with what it chose said on stderr.
pub fn rig(host: &mut dyn Host, path: &str, req: &BagRequest) -> Result<BagRig, String> {
    let mut rec = open(host, path)?;
    let label = rec.file().to_string();
    let urdf = match req.urdf {
        Some(p) => Some(Urdf::parse(&read_text(host, p)?).map_err(|e| format!("{p}: {e}"))?),
        None => None,
    };
    let request = RigRequest {
        topics: req.topics.map(|list| list.split(',').map(|s| s.trim().to_string()).collect()),
        reference: req.reference.map(str::to_string),
        base_frame: req.base_frame.to_string(),
        instants: InstantSettings { frames: req.frames, ..InstantSettings::default() },
        urdf: urdf.as_ref(),
    };
    let rig = rec.rig(&request).map_err(|e| format!("{label}: {e}"))?;
    let mut say = format!("gmmcalib: {} instants from {label}:\n", rig.picks.len());
    for (k, p) in rig.picks.iter().enumerate() {
        let offsets: Vec<String> =
            p.others.iter().map(|(_, d)| format!("{:+.1} ms", *d as f64 * 1e-6)).collect();
        say += &format!(
            "  {}: t = {:.3} s, offsets {}\n",
            k + 1,
            p.reference_ns as f64 * 1e-9,
            offsets.join(", ")
        );
    }
    if rig.motion.moving {
        let min = rig.motion.overlap.iter().copied().fold(1.0, f64::min);
        say += &format!(
            "gmmcalib: warning: the rig moved between instants ({:.0}% overlap of {}'s scans); each instant's scans must see the same scene\n",
            min * 100.0,
            rig.reference
        );
    }
    rig.problems.iter().for_each(|p| say += &format!("gmmcalib: warning: {p}\n"));
    for (topic, why) in &rig.left_out {
        say += &format!("gmmcalib: left out {topic}: {why}\n");
    }
    if rig.identity_nominals {
        say += "gmmcalib: no /tf_static and no --urdf: identity nominals (the global alignment finds the rest)\n";
    }
    host.err(&say);
    Ok(BagRig { rig, urdf })
}

/// The calibration's extrinsics in the export format `format`.
pub fn export(format: &str, result: &Calibration, bag: &BagRig) -> Result<String, String> {
    let frame_of = |sensor: &str| {
        bag.rig
            .frames
            .iter()
            .find(|(t, _)| t == sensor)
            .map_or(sensor.to_string(), |(_, f)| f.clone())
    };
    let extrinsics: Vec<Extrinsic> = result
        .sensors
        .iter()
        .map(|s| Extrinsic {
            parent: bag.rig.base.clone(),
            child: frame_of(&s.name),
            pose: s.extrinsic,
        })
        .collect();
    Ok(match format {
        "ros1" => ros::ros1_static_transform_publisher(&extrinsics),
        "ros2" => ros::ros2_static_transform_publisher(&extrinsics),
        "tf-yaml" => ros::tf_static_yaml(&extrinsics),
        "autoware" => ros::autoware_calibration(&extrinsics),
        "kitti" => ros::kitti_tr(&extrinsics),
        "urdf" => match &bag.urdf {
            Some(urdf) => {
                let poses: Vec<(String, crate::Pose)> =
                    extrinsics.iter().map(|e| (e.child.clone(), e.pose)).collect();
                urdf.with_origins(&bag.rig.base, &poses)?
            }
            None => ros::urdf(&extrinsics),
        },
        other => {
            return Err(format!(
                "--export {other}: expected ros1, ros2, tf-yaml, urdf, autoware or kitti"
            ));
        }
    })
}
