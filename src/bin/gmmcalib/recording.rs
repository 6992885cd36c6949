//! `gmmcalib inspect FILE`: a recording's topics and tf tree. The library does the work
//! (`calibrate --bag` is in `gmmcalib::command`).

use std::path::Path;

use gmmcalib::command::recording_file;
use gmmcalib::io::recording::{Recording, Tree};

use crate::host::Native;

/// Opens `path`, with a progress line on stderr while a file without index is scanned.
fn open(path: &Path) -> Result<Recording, String> {
    let show = std::io::IsTerminal::is_terminal(&std::io::stderr());
    // A rosbag2 bag named by its folder: the library finds the storage file.
    let path = recording_file(&mut Native::new(), &path.to_string_lossy())?;
    let rec = Recording::open_path(Path::new(&path), &mut |done, total| {
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
            k if k.is_point_cloud() && topic.count > 0 => {
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
