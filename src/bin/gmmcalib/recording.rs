//! `gmmcalib inspect FILE` and `calibrate --bag FILE`: a recording's topics and tf tree, and
//! the rig its point-cloud topics make (sensors named by topic, frames by instant), with
//! nominals from a URDF or `/tf_static`. The library does the work.

use std::path::Path;

use gmmcalib::calib::{Calibration, Scan};
use gmmcalib::io::recording::select::Settings as Select;
use gmmcalib::io::recording::urdf::Urdf;
use gmmcalib::io::recording::{Kind, Recording, Tree, nominals};
use gmmcalib::report::ros::{self, Extrinsic};
use gmmcalib::se3::Pose;

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

/// The rig's parts from a recording.
pub struct BagRig {
    pub scans: Vec<Scan>,
    pub nominal: Vec<(String, Pose)>,
    pub reference: String,
    pub base: String,
    /// Per sensor (topic), its frame id.
    pub frames: Vec<(String, String)>,
    pub urdf: Option<Urdf>,
}

pub fn rig(path: &Path, req: &BagRequest) -> Result<BagRig, String> {
    let mut rec = open(path)?;
    let label = rec.file().to_string();
    let names: Vec<String> = match req.topics {
        Some(list) => list.split(',').map(|s| s.trim().to_string()).collect(),
        None => rec
            .topics()
            .iter()
            .filter(|t| t.kind == Kind::PointCloud2 && t.count > 0)
            .map(|t| t.name.clone())
            .collect(),
    };
    let topics = names
        .iter()
        .map(|n| rec.topic(n).ok_or_else(|| format!("{label}: no topic {n}")))
        .collect::<Result<Vec<_>, _>>()?;
    if topics.len() < 2 {
        return Err(format!(
            "{label}: {} point-cloud topics; calibration needs two or more (--topics)",
            topics.len()
        ));
    }
    let reference = req.reference.map_or(names[0].clone(), str::to_string);
    let r = *topics
        .get(
            names
                .iter()
                .position(|n| *n == reference)
                .ok_or_else(|| format!("--reference {reference} is not among the topics"))?,
        )
        .unwrap_or(&topics[0]);
    let chosen = rec
        .choose(&topics, r, &Select { frames: req.frames, ..Select::default() })
        .map_err(|e| e.to_string())?;
    if chosen.picks.is_empty() {
        return Err(format!(
            "{label}: no instant where every topic has a scan within 20 ms of {reference}'s"
        ));
    }
    eprintln!("gmmcalib: {} instants from {label}:", chosen.picks.len());
    for (k, p) in chosen.picks.iter().enumerate() {
        let offsets: Vec<String> =
            p.others.iter().map(|(_, d)| format!("{:+.1} ms", *d as f64 * 1e-6)).collect();
        eprintln!(
            "  {}: t = {:.3} s, offsets {}",
            k + 1,
            p.reference_ns as f64 * 1e-9,
            offsets.join(", ")
        );
    }
    if chosen.motion.moving {
        let min = chosen.motion.overlap.iter().copied().fold(1.0, f64::min);
        eprintln!(
            "gmmcalib: warning: the rig moved between instants ({:.0}% overlap of {reference}'s scans); each instant's scans must see the same scene",
            min * 100.0
        );
    }
    let mut frames: Vec<(String, String)> = Vec::new();
    for s in &chosen.scans {
        if !frames.iter().any(|(t, _)| *t == s.topic) {
            frames.push((s.topic.clone(), s.cloud.frame_id.clone()));
        }
    }
    let (tree, urdf) = match req.urdf {
        Some(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let urdf = Urdf::parse(&text).map_err(|e| format!("{}: {e}", p.display()))?;
            (urdf.tree(), Some(urdf))
        }
        None => {
            let (t, problems) = rec.transforms(false);
            problems.iter().for_each(|p| eprintln!("gmmcalib: warning: {p}"));
            (Tree::new(t), None)
        }
    };
    let (nominal, base) = if tree.edges.is_empty() {
        eprintln!(
            "gmmcalib: no /tf_static and no --urdf: identity nominals (the global alignment finds the rest)"
        );
        (
            frames.iter().map(|(t, _)| (t.clone(), Pose::identity())).collect(),
            req.base_frame.to_string(),
        )
    } else {
        let base = tree.base(req.base_frame).map_err(|e| format!("{label}: {e}"))?;
        (nominals(&tree, &base, &frames).map_err(|e| format!("{label}: {e}"))?, base)
    };
    let scans = chosen
        .scans
        .into_iter()
        .map(|s| Scan {
            source: Some(format!("{label} {} message {}", s.topic, s.message)),
            sensor: s.topic,
            frame: s.frame,
            points: s.cloud.cloud.points,
        })
        .collect();
    Ok(BagRig { scans, nominal, reference, base, frames, urdf })
}

/// The calibration's extrinsics in the export format `format`.
pub fn export(format: &str, result: &Calibration, bag: &BagRig) -> Result<String, String> {
    let frame_of = |sensor: &str| {
        bag.frames.iter().find(|(t, _)| t == sensor).map_or(sensor.to_string(), |(_, f)| f.clone())
    };
    let extrinsics: Vec<Extrinsic> = result
        .sensors
        .iter()
        .map(|s| Extrinsic {
            parent: bag.base.clone(),
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
                let poses: Vec<(String, Pose)> =
                    extrinsics.iter().map(|e| (e.child.clone(), e.pose)).collect();
                urdf.with_origins(&bag.base, &poses)?
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
