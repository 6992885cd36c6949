//! `gmmcalib inspect FILE` and `calibrate --bag FILE`: a recording's topics and tf tree, and
//! the rig its point-cloud topics make (sensors named by topic, frames by instant), with
//! nominals from a URDF or `/tf_static`. The library does the work.

use std::path::Path;

use gmmcalib::calib::Calibration;
use gmmcalib::io::recording::select::Settings as Select;
use gmmcalib::io::recording::urdf::Urdf;
use gmmcalib::io::recording::{Kind, Recording, RecordingRig, RigRequest, Tree};
use gmmcalib::report::ros::{self, Extrinsic};

/// Opens `path`, with a progress line on stderr while a file without index is scanned.
fn open(path: &Path) -> Result<Recording, String> {
    let show = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let rec = Recording::open_path(path, &mut |done, total| {
        if show {
            eprint!("\r\x1b[Kscanning {}%", done * 100 / total.max(1));
        }
    })
    .map_err(|e| e.to_string())?;
    if show {
        eprint!("\r\x1b[K");
    }
    for p in rec.problems() {
        eprintln!("gmmcalib: warning: {p}");
    }
    Ok(rec)
}

pub fn inspect(path: &Path) -> Result<(), String> {
    let mut rec = open(path)?;
    println!("{} ({:?})", rec.file(), rec.container());
    println!("{:<32} {:>7} {:>8}  {:<14} type", "topic", "count", "rate Hz", "frame_id");
    for t in 0..rec.topics().len() {
        let topic = rec.topics()[t].clone();
        // The frame id is in each message; the first one's is shown for point clouds.
        let frame = match topic.kind {
            Kind::PointCloud2 if topic.count > 0 => {
                rec.point_cloud(t, 0).map_or_else(|e| format!("({e})"), |pc| pc.frame_id)
            }
            _ => String::new(),
        };
        println!(
            "{:<32} {:>7} {:>8.2}  {:<14} {}",
            topic.name,
            topic.count,
            topic.rate_hz(),
            frame,
            topic.type_name
        );
    }
    let (transforms, problems) = rec.transforms(false);
    problems.iter().for_each(|p| eprintln!("gmmcalib: warning: {p}"));
    let tree = Tree::new(transforms);
    if !tree.edges.is_empty() {
        println!("\n/tf_static tree (T_parent_child):");
        for root in tree.roots() {
            println!("{root}");
            print_children(&tree, &root, 1);
        }
    }
    Ok(())
}

fn print_children(tree: &Tree, parent: &str, depth: usize) {
    for e in tree.edges.iter().filter(|e| e.parent == parent) {
        let ([x, y, z], [r, p, yaw]) = gmmcalib::se3::xyz_rpy(&e.pose);
        let d = |a: f64| a.to_degrees();
        println!(
            "{}{}  xyz {x:.4} {y:.4} {z:.4} m, rpy {:.3} {:.3} {:.3} deg",
            "  ".repeat(depth),
            e.child,
            d(r),
            d(p),
            d(yaw)
        );
        if depth < 32 {
            print_children(tree, &e.child, depth + 1);
        }
    }
}

/// What `calibrate --bag` asks of a recording.
pub struct BagRequest<'a> {
    pub topics: Option<&'a str>,
    pub reference: Option<&'a str>,
    pub base_frame: &'a str,
    pub frames: usize,
    pub urdf: Option<&'a Path>,
}

/// The rig a recording makes, and the URDF its nominals came from (for the `urdf` export).
pub struct BagRig {
    pub rig: RecordingRig,
    pub urdf: Option<Urdf>,
}

/// The library's rig from the recording at `path`, with what it chose said on stderr.
pub fn rig(path: &Path, req: &BagRequest) -> Result<BagRig, String> {
    let mut rec = open(path)?;
    let label = rec.file().to_string();
    let urdf = match req.urdf {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            Some(Urdf::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?)
        }
        None => None,
    };
    let request = RigRequest {
        topics: req.topics.map(|list| list.split(',').map(|s| s.trim().to_string()).collect()),
        reference: req.reference.map(str::to_string),
        base_frame: req.base_frame.to_string(),
        select: Select { frames: req.frames, ..Select::default() },
        urdf: urdf.as_ref(),
    };
    let rig = rec.rig(&request).map_err(|e| format!("{label}: {e}"))?;
    eprintln!("gmmcalib: {} instants from {label}:", rig.picks.len());
    for (k, p) in rig.picks.iter().enumerate() {
        let offsets: Vec<String> =
            p.others.iter().map(|(_, d)| format!("{:+.1} ms", *d as f64 * 1e-6)).collect();
        eprintln!(
            "  {}: t = {:.3} s, offsets {}",
            k + 1,
            p.reference_ns as f64 * 1e-9,
            offsets.join(", ")
        );
    }
    if rig.motion.moving {
        let min = rig.motion.overlap.iter().copied().fold(1.0, f64::min);
        eprintln!(
            "gmmcalib: warning: the rig moved between instants ({:.0}% overlap of {}'s scans); each instant's scans must see the same scene",
            min * 100.0,
            rig.reference
        );
    }
    rig.problems.iter().for_each(|p| eprintln!("gmmcalib: warning: {p}"));
    for (topic, why) in &rig.left_out {
        eprintln!("gmmcalib: left out {topic}: {why}");
    }
    if rig.identity_nominals {
        eprintln!(
            "gmmcalib: no /tf_static and no --urdf: identity nominals (the global alignment finds the rest)"
        );
    }
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
                let poses: Vec<(String, gmmcalib::Pose)> =
                    extrinsics.iter().map(|e| (e.child.clone(), e.pose)).collect();
                urdf.with_origins(&bag.rig.base, &poses)?
            }
            None => ros::urdf_joints(&extrinsics),
        },
        other => {
            return Err(format!(
                "--export {other}: expected ros1, ros2, tf-yaml, urdf, autoware or kitti"
            ));
        }
    })
}
