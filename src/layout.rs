//! Which scan file is which sensor and frame, from the files' paths alone, as users lay out
//! their recordings: GMMCalib's `sensor_N/<frame>.pcd`, a folder per sensor under any name (a
//! bag exported per topic: `up/`, `down/`, files named by timestamp), loose `<sensor>_<frame>`
//! files (`left_003.pcd`) and loose `<frame>_<sensor>` files (the Livox Mid-100's
//! `scene1_pose10_L0.pcd`). No I/O: the CLI lists a folder and asks here; see docs/io.md.
//!
//! Frames pair across sensors by name. A sensor that shares no frame name with the first one
//! (exports named by each topic's own timestamps) is paired with it: by the nearest timestamp,
//! one to one, within half the first sensor's median interval, when both are named by
//! numbers; else in order. A scan left unpaired keeps its own frame name, so no other sensor
//! shares it.

use std::cmp::Ordering;
use std::collections::BTreeSet;
use std::fmt;

/// One scan file's place in the rig.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Placed {
    /// The path as given.
    pub path: String,
    pub sensor: String,
    pub frame: String,
}

/// How the frames of a sensor were matched to the first sensor's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Pairing {
    /// Both named by numbers (timestamps): nearest first, one to one.
    Timestamps { sensor: String, to: String, paired: usize, of: usize },
    /// In name order.
    InOrder { sensor: String, to: String, paired: usize },
}

/// The files' places, how frames were paired where names did not pair them, and what the
/// names left open.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Layout {
    /// Sensor by sensor (natural order), frames in natural order within each.
    pub scans: Vec<Placed>,
    pub pairings: Vec<Pairing>,
    /// Loose files whose names carry no sensor, beside other loose files: each placed as a
    /// sensor of its own name, frame 1. The CLI refuses them; the page asks the user.
    pub nameless: Vec<String>,
    /// Loose `<frame>_<sensor>` files read with the sensor last (the Livox Mid-100's units):
    /// the frame they share.
    pub sensors_last: Option<String>,
    /// Files that would be one sensor's one frame after the first: (first, second, frame).
    /// Left out of `scans`.
    pub duplicates: Vec<(String, String, String)>,
}

impl Layout {
    /// The first problem that keeps the layout from being used as it stands, for a front end
    /// that cannot ask (the CLI).
    pub fn problem(&self) -> Option<LayoutError> {
        if let Some((first, second, frame)) = self.duplicates.first() {
            let (first, second, frame) = (first.clone(), second.clone(), frame.clone());
            return Some(LayoutError::SameFrame { first, second, frame });
        }
        if let Some(path) = self.nameless.first() {
            return Some(LayoutError::NoSensor { path: path.clone() });
        }
        self.scans.is_empty().then_some(LayoutError::Empty)
    }
}

/// Files whose places cannot be told (see [`Layout::problem`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// No scan file among the paths.
    Empty,
    /// A loose file whose name carries no sensor (no `_`), beside other loose files.
    NoSensor { path: String },
    /// Two files would be one sensor's one frame.
    SameFrame { first: String, second: String, frame: String },
}

impl fmt::Display for LayoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LayoutError::Empty => f.write_str("no point-cloud scans (.pcd, .ply, .bin)"),
            LayoutError::NoSensor { path } => write!(
                f,
                "{path}: the name carries no sensor; put each sensor's scans in a folder of its own or name them <sensor>_<frame> (left_003.pcd)"
            ),
            LayoutError::SameFrame { first, second, frame } => {
                write!(f, "{first} and {second}: two files for frame {frame}")
            }
        }
    }
}

impl std::error::Error for LayoutError {}

/// The extensions of scan files.
pub const SCAN_EXTENSIONS: [&str; 3] = ["pcd", "ply", "bin"];

/// Whether `path` names a scan file.
pub fn is_scan(path: &str) -> bool {
    path.rsplit_once('.')
        .is_some_and(|(_, ext)| SCAN_EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()))
}

/// The places of the scan files among `paths` ('/'-separated, relative to the data folder;
/// other files are passed over).
pub fn place(paths: &[String]) -> Layout {
    let mut folders: Vec<(&str, Vec<&str>)> = Vec::new();
    for path in paths.iter().filter(|p| is_scan(p)) {
        let folder = path.rsplit_once('/').map_or("", |(f, _)| f);
        match folders.iter_mut().find(|(f, _)| *f == folder) {
            Some((_, list)) => list.push(path),
            None => folders.push((folder, vec![path])),
        }
    }
    let mut layout = Layout::default();
    for (folder, list) in &folders {
        place_folder(folder, list, &mut layout);
    }
    layout.scans.sort_by(|a, b| {
        natural(&a.sensor, &b.sensor).then(natural(&a.frame, &b.frame)).then(a.path.cmp(&b.path))
    });
    let mut kept: Vec<Placed> = Vec::with_capacity(layout.scans.len());
    for scan in std::mem::take(&mut layout.scans) {
        match kept.last() {
            Some(last) if last.sensor == scan.sensor && last.frame == scan.frame => {
                layout.duplicates.push((last.path.clone(), scan.path, scan.frame));
            }
            _ => kept.push(scan),
        }
    }
    layout.scans = kept;
    layout.pairings = pair(&mut layout.scans, &layout.nameless);
    layout
}

/// A file's name without folders and extension.
fn stem(path: &str) -> &str {
    let name = path.rsplit('/').next().unwrap_or(path);
    name.rsplit_once('.').map_or(name, |(s, _)| s)
}

/// `stem` split at its last `_` into two non-empty parts.
fn split(stem: &str) -> Option<(&str, &str)> {
    stem.rsplit_once('_').filter(|(a, b)| !a.is_empty() && !b.is_empty())
}

fn is_number(s: &str) -> bool {
    !s.is_empty() && s.parse::<f64>().is_ok_and(f64::is_finite) && !s.starts_with(['+', '-'])
}

/// The scans of one folder, into `layout`. A named folder is one sensor, its stems the
/// frames, unless its files name two or more sensors themselves; loose files (and such
/// folders) are placed by name.
fn place_folder(folder: &str, paths: &[&str], layout: &mut Layout) {
    let placed = |path: &str, sensor: &str, frame: &str| Placed {
        path: path.to_string(),
        sensor: sensor.to_string(),
        frame: frame.to_string(),
    };
    let name = folder.rsplit('/').next().unwrap_or(folder);
    let parts: Vec<Option<(&str, &str)>> = paths.iter().map(|p| split(stem(p))).collect();
    let named_sensors = parts.iter().flatten().map(|(sensor, _)| *sensor).collect::<BTreeSet<_>>();
    let all_named = parts.iter().all(Option::is_some);
    if !folder.is_empty() && (is_sensor_folder(name) || !all_named || named_sensors.len() < 2) {
        layout.scans.extend(paths.iter().map(|p| placed(p, name, stem(p))));
        return;
    }
    // `<frame>_<sensor>`: one shared prefix, every suffix a distinct non-number.
    let named: Vec<(&str, &str)> = parts.iter().flatten().copied().collect();
    let suffixes: BTreeSet<&str> = named.iter().map(|(_, b)| *b).collect();
    let sensors_last = all_named
        && paths.len() >= 2
        && named_sensors.len() == 1
        && suffixes.len() == paths.len()
        && named.iter().all(|(_, b)| !is_number(b));
    if sensors_last {
        layout.sensors_last = named.first().map(|(a, _)| a.to_string());
    }
    for (path, part) in paths.iter().zip(&parts) {
        match part {
            Some((a, b)) if sensors_last => layout.scans.push(placed(path, b, a)),
            Some((a, b)) => layout.scans.push(placed(path, a, b)),
            None => {
                // One loose file alone is a sensor of its own name (OpenCalib-style pairs).
                if paths.len() > 1 {
                    layout.nameless.push(path.to_string());
                }
                layout.scans.push(placed(path, stem(path), "1"));
            }
        }
    }
}

fn is_sensor_folder(name: &str) -> bool {
    name.strip_prefix("sensor_")
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|c| c.is_ascii_digit()))
}

/// Pairs each sensor sharing no frame name with the first sensor to it (see the module); the
/// `nameless` files' stand-in sensors neither pair nor are paired with.
fn pair(scans: &mut [Placed], nameless: &[String]) -> Vec<Pairing> {
    let named = |s: &Placed| !nameless.contains(&s.path);
    let Some(first) = scans.iter().find(|s| named(s)).map(|s| s.sensor.clone()) else {
        return Vec::new();
    };
    let reference: Vec<String> =
        scans.iter().filter(|s| s.sensor == first).map(|s| s.frame.clone()).collect();
    let sensors: Vec<String> = scans.iter().fold(Vec::new(), |mut list, s| {
        if s.sensor != first && named(s) && !list.contains(&s.sensor) {
            list.push(s.sensor.clone());
        }
        list
    });
    let mut pairings = Vec::new();
    for sensor in sensors {
        let idx: Vec<usize> = (0..scans.len()).filter(|&i| scans[i].sensor == sensor).collect();
        if idx.iter().any(|&i| reference.contains(&scans[i].frame)) {
            continue;
        }
        let times = |frames: &[&str]| -> Option<Vec<f64>> {
            frames.iter().map(|f| if is_number(f) { f.parse().ok() } else { None }).collect()
        };
        let own: Vec<&str> = idx.iter().map(|&i| scans[i].frame.as_str()).collect();
        let refs: Vec<&str> = reference.iter().map(String::as_str).collect();
        match (times(&refs), times(&own)) {
            (Some(t_ref), Some(t_own)) => {
                let matches = nearest(&t_ref, &t_own);
                for &(k, j) in &matches {
                    scans[idx[k]].frame = reference[j].clone();
                }
                pairings.push(Pairing::Timestamps {
                    sensor,
                    to: first.clone(),
                    paired: matches.len(),
                    of: idx.len(),
                });
            }
            _ => {
                let paired = idx.len().min(reference.len());
                for (k, &i) in idx.iter().take(paired).enumerate() {
                    scans[i].frame = reference[k].clone();
                }
                pairings.push(Pairing::InOrder { sensor, to: first.clone(), paired });
            }
        }
    }
    pairings
}

/// `(own, reference)` index pairs: closest first, one to one, within half the reference's
/// median interval (any distance when it has one time).
fn nearest(reference: &[f64], own: &[f64]) -> Vec<(usize, usize)> {
    let mut sorted = reference.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut gaps: Vec<f64> = sorted.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    let reach = if gaps.is_empty() { f64::INFINITY } else { gaps[gaps.len() / 2] / 2.0 };
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (k, t) in own.iter().enumerate() {
        for (j, r) in reference.iter().enumerate() {
            let gap = (t - r).abs();
            if gap <= reach {
                candidates.push((gap, k, j));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut taken, mut given) = (vec![false; own.len()], vec![false; reference.len()]);
    let mut out = Vec::new();
    for (_, k, j) in candidates {
        if !taken[k] && !given[j] {
            (taken[k], given[j]) = (true, true);
            out.push((k, j));
        }
    }
    out.sort_unstable();
    out
}

/// Natural order: runs of digits compare as numbers, everything else as text.
pub fn natural(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a, b);
    loop {
        let (Some(ca), Some(cb)) = (a.chars().next(), b.chars().next()) else {
            return a.len().cmp(&b.len());
        };
        let order = if ca.is_ascii_digit() && cb.is_ascii_digit() {
            let (da, ra) = split_digits(a);
            let (db, rb) = split_digits(b);
            (a, b) = (ra, rb);
            let (ta, tb) = (da.trim_start_matches('0'), db.trim_start_matches('0'));
            ta.len().cmp(&tb.len()).then(ta.cmp(tb)).then(da.len().cmp(&db.len()))
        } else {
            (a, b) = (&a[ca.len_utf8()..], &b[cb.len_utf8()..]);
            ca.cmp(&cb)
        };
        if order != Ordering::Equal {
            return order;
        }
    }
}

fn split_digits(s: &str) -> (&str, &str) {
    s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paths(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    fn places(layout: &Layout) -> Vec<(&str, &str, &str)> {
        layout
            .scans
            .iter()
            .map(|s| (s.path.as_str(), s.sensor.as_str(), s.frame.as_str()))
            .collect()
    }

    #[test]
    fn natural_order() {
        let mut names = vec!["sensor_10", "sensor_2", "sensor_1", "10.pcd", "9.pcd", "a", "02"];
        names.sort_by(|a, b| natural(a, b));
        assert_eq!(names, ["02", "9.pcd", "10.pcd", "a", "sensor_1", "sensor_2", "sensor_10"]);
        assert_eq!(natural("frame_007", "frame_7"), Ordering::Greater);
        assert_eq!(natural("x1", "x1"), Ordering::Equal);
    }

    #[test]
    fn gmmcalib_folders_sort_naturally() {
        let got = place(&paths(&[
            "sensor_10/2.pcd",
            "sensor_2/10.ply",
            "sensor_2/2.pcd",
            "config.yaml",
            "sensor_10/10.pcd",
        ]));
        assert_eq!(
            places(&got),
            [
                ("sensor_2/2.pcd", "sensor_2", "2"),
                ("sensor_2/10.ply", "sensor_2", "10"),
                ("sensor_10/2.pcd", "sensor_10", "2"),
                ("sensor_10/10.pcd", "sensor_10", "10")
            ]
        );
        assert!(got.pairings.is_empty());
    }

    #[test]
    fn topic_folders_pair_by_nearest_timestamp() {
        // up at 10 Hz; down 30 ms later, one scan too many and one missing.
        let got = place(&paths(&[
            "up/1000.100.pcd",
            "up/1000.200.pcd",
            "up/1000.300.pcd",
            "down/1000.130.pcd",
            "down/1000.330.pcd",
            "down/1000.900.pcd",
        ]));
        assert_eq!(
            places(&got),
            [
                ("down/1000.130.pcd", "down", "1000.130"),
                ("down/1000.330.pcd", "down", "1000.330"),
                ("down/1000.900.pcd", "down", "1000.900"),
                ("up/1000.100.pcd", "up", "1000.130"),
                ("up/1000.200.pcd", "up", "1000.200"),
                ("up/1000.300.pcd", "up", "1000.330")
            ]
        );
        // `down` sorts first, so `up` pairs to it, nearest first: 1000.100 and 1000.300 take
        // 1000.130 and 1000.330; 1000.200 finds neither free and 1000.900 out of reach (half
        // the median interval, 0.285 s), so keeps its own name.
        assert_eq!(
            got.pairings,
            [Pairing::Timestamps { sensor: "up".into(), to: "down".into(), paired: 2, of: 3 }]
        );
    }

    #[test]
    fn loose_files_name_their_sensor_either_way() {
        let got = place(&paths(&["left_2.pcd", "right_1.pcd", "left_1.pcd", "right_2.pcd"]));
        assert_eq!(got.sensors_last, None);
        let frames: Vec<_> = places(&got).iter().map(|(_, s, f)| format!("{s}/{f}")).collect();
        assert_eq!(frames, ["left/1", "left/2", "right/1", "right/2"]);
        let livox = place(&paths(&[
            "scene1_pose10_L0.pcd",
            "scene1_pose10_L1.pcd",
            "scene1_pose10_L2.pcd",
        ]));
        assert_eq!(livox.sensors_last.as_deref(), Some("scene1_pose10"));
        let frames: Vec<_> = places(&livox).iter().map(|(_, s, f)| format!("{s}/{f}")).collect();
        assert_eq!(frames, ["L0/scene1_pose10", "L1/scene1_pose10", "L2/scene1_pose10"]);
    }

    #[test]
    fn what_cannot_be_told_is_named() {
        assert_eq!(place(&paths(&["notes.txt"])).problem(), Some(LayoutError::Empty));
        let nameless = place(&paths(&["a.pcd", "b.pcd", "left_1.pcd"]));
        assert_eq!(nameless.nameless, ["a.pcd", "b.pcd"]);
        assert_eq!(nameless.scans.len(), 3, "placed as sensors of their own names");
        let problem = nameless.problem().unwrap();
        assert_eq!(problem, LayoutError::NoSensor { path: "a.pcd".into() });
        assert!(problem.to_string().starts_with("a.pcd: the name carries no sensor"));
        assert_eq!(place(&paths(&["p64.pcd"])).problem(), None, "one file alone is a sensor");
        let twice = place(&paths(&["sensor_1/3.pcd", "sensor_1/3.ply"]));
        assert_eq!(twice.scans.len(), 1);
        let problem = twice.problem().unwrap().to_string();
        assert_eq!(problem, "sensor_1/3.pcd and sensor_1/3.ply: two files for frame 3");
    }
}
