//! Recordings against fixtures written by independent writers (tests/fixtures/recording/
//! make.py: PyPI `rosbags` and `mcap`): every container and compression, every PointCloud2
//! layout, Livox's CustomMsg, the tf tree, the same calibration as from PCD files, and damaged
//! files.

// Native: reads fixtures from disk and compares with serde_json.
#![cfg(not(target_arch = "wasm32"))]

use std::path::PathBuf;

use gmmcalib::calib::{self, Method, Rig, Scan, Settings};
use gmmcalib::config::Config;
use gmmcalib::io::parse_cloud;
use gmmcalib::io::recording::instants::InstantSettings;
use gmmcalib::io::recording::{Container, Kind, Recording, RecordingError, Tree, nominals};
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::from_row_major;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/recording").join(name)
}

fn bytes(name: &str) -> Vec<u8> {
    std::fs::read(path(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn open_bytes(data: Vec<u8>, name: &str) -> Result<Recording, RecordingError> {
    Recording::open(Box::new(data), name, &mut |_, _| {})
}

fn open(name: &str) -> Recording {
    open_bytes(bytes(name), name).unwrap_or_else(|e| panic!("{e}"))
}

fn expected() -> serde_json::Value {
    serde_json::from_slice(&bytes("expected.json")).unwrap()
}

const LAYOUTS: [&str; 8] = [
    "layouts_none.mcap",
    "layouts_zstd.mcap",
    "layouts_lz4.mcap",
    "layouts_unindexed.mcap",
    "layouts_none.bag",
    "layouts_bz2.bag",
    "layouts_lz4.bag",
    "layouts.db3",
];

/// A cloud as make.py wrote it to the expected JSON: its points and its intensity, if any.
fn expected_cloud(want: &serde_json::Value) -> (Vec<[f32; 3]>, Option<Vec<f32>>) {
    let points = want["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| std::array::from_fn(|i| p[i].as_f64().unwrap() as f32))
        .collect();
    let intensity = want["intensity"]
        .as_array()
        .map(|v| v.iter().map(|x| x.as_f64().unwrap() as f32).collect());
    (points, intensity)
}

#[test]
fn every_container_decodes_every_layout() {
    let expected = expected();
    for file in LAYOUTS {
        let mut rec = open(file);
        assert!(rec.problems().is_empty(), "{file}: {:?}", rec.problems());
        for (topic, want) in expected["layouts"].as_object().unwrap() {
            let t = rec.topic(topic).unwrap_or_else(|| panic!("{file}: no {topic}"));
            assert_eq!(rec.topics()[t].count, 2, "{file} {topic}");
            for m in 0..2 {
                let pc = rec.point_cloud(t, m).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(pc.frame_id, want["frame_id"].as_str().unwrap(), "{file} {topic}");
                let (points, intensity) = expected_cloud(want);
                assert_eq!(pc.cloud.points, points, "{file} {topic}");
                assert_eq!(pc.cloud.intensity, intensity, "{file} {topic}");
                assert_eq!(pc.stamp_ns, 1_700_000_000_000_000_000 + m as i64 * 50_000_000);
            }
        }
        let organised = rec.topic("/layout/organised").unwrap();
        let pc = rec.point_cloud(organised, 0).unwrap();
        assert_eq!((pc.width, pc.height, pc.dropped), (4, 3, 5), "{file}");
    }
}

#[test]
fn containers_are_told_apart_and_indexes_read() {
    assert_eq!(open("layouts_zstd.mcap").container(), Container::Mcap);
    assert_eq!(open("layouts_lz4.bag").container(), Container::Bag);
    assert_eq!(open("layouts.db3").container(), Container::Db3);
    let rec = open("calib_zstd.mcap");
    let t = &rec.topics()[rec.topic("/front_left/points").unwrap()];
    assert_eq!((t.count, t.type_name.as_str()), (3, "sensor_msgs/msg/PointCloud2"));
    assert!((t.rate_hz() - 10.0).abs() < 1e-9);
}

/// The tf tree of depth 3 resolves each sensor's frame to the twin's nominal.
#[test]
fn tf_static_resolves_to_the_nominals() {
    let config =
        Config::from_yaml(&String::from_utf8(bytes("config.yaml")).unwrap(), "config.yaml")
            .unwrap();
    let nominal = config.nominal_poses();
    for file in ["calib_zstd.mcap", "calib_bz2.bag"] {
        let mut rec = open(file);
        let (transforms, problems) = rec.transforms(false);
        assert!(problems.is_empty());
        let tree = Tree::new(transforms);
        assert_eq!(tree.base("base_link").unwrap(), "base_link");
        assert_eq!(tree.depth("front_left"), 3);
        let frames = [("sensor_1", "front_left"), ("sensor_2", "front_right")]
            .map(|(s, f)| (s.to_string(), f.to_string()));
        let resolved = nominals(&tree, "base_link", &frames).unwrap();
        for ((name, pose), (_, want)) in resolved.iter().zip(&nominal) {
            let d = pose.inverse() * want;
            assert!(
                d.translation.vector.norm() < 1e-12 && d.rotation.angle() < 1e-12,
                "{file} {name}"
            );
        }
    }
    // The edges as make.py wrote them.
    let expected = expected();
    let tree = Tree::new(open("layouts_lz4.bag").transforms(false).0);
    for edge in expected["tf_static"].as_array().unwrap() {
        let m: Vec<f64> = edge["matrix"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
            .collect();
        let want = from_row_major(&m.try_into().unwrap());
        let got = tree
            .resolve(edge["parent"].as_str().unwrap(), edge["child"].as_str().unwrap())
            .unwrap();
        assert!((got.inverse() * want).translation.vector.norm() < 1e-12);
    }
}

const P2P: Method = Method::Icp(gmmcalib::icp::Metric::PointToPoint);

fn settings() -> Settings {
    let mut s = Settings { align_globally: Some(false), ..Settings::default() };
    s.jrmpc.threads = 1;
    s
}

/// The same scans calibrate to the same result from a recording (nominals from /tf_static) as
/// from PCD files (nominals from config.yaml): as PointCloud2 and as Livox CustomMsg (whose
/// scans carry a NaN and a zero return more, dropped).
#[test]
fn recording_calibrates_as_pcd_folders() {
    let config =
        Config::from_yaml(&String::from_utf8(bytes("config.yaml")).unwrap(), "config.yaml")
            .unwrap();
    let mut scans = Vec::new();
    for sensor in ["sensor_1", "sensor_2"] {
        for frame in 1..=3 {
            let name = format!("pcd/{sensor}/{frame}.pcd");
            let cloud = parse_cloud(&bytes(&name), &name).unwrap().cloud;
            scans.push(Scan {
                sensor: sensor.into(),
                frame: frame.to_string(),
                points: cloud.points,
                source: None,
            });
        }
    }
    let folder = Rig { scans, nominal: config.nominal_poses(), roi: config.roi, reference: None };
    let from_pcd = calib::calibrate(&folder, P2P, &settings(), |_| Control::Continue).unwrap();
    for file in ["calib_zstd.mcap", "calib_bz2.bag", "livox.mcap", "livox.bag"] {
        let mut rec = open(file);
        let topics = ["/front_left/points", "/front_right/points"].map(|t| rec.topic(t).unwrap());
        let chosen = rec.choose(&topics, topics[0], &InstantSettings::default()).unwrap();
        assert_eq!(chosen.picks.len(), 3);
        let dropped = if file.starts_with("livox") { 2 } else { 0 };
        assert!(chosen.scans.iter().all(|s| s.cloud.dropped == dropped), "{file}");
        assert!(chosen.picks.iter().all(|p| p.others == vec![(p.reference, 5_000_000)]));
        assert!(!chosen.motion.moving, "{:?}", chosen.motion);
        let tree = Tree::new(rec.transforms(false).0);
        let frames: Vec<(String, String)> =
            chosen.scans.iter().map(|s| (s.topic.clone(), s.cloud.frame_id.clone())).collect();
        let scans: Vec<Scan> = chosen
            .scans
            .into_iter()
            .map(|s| Scan {
                sensor: s.topic,
                frame: s.frame,
                points: s.cloud.cloud.points,
                source: None,
            })
            .collect();
        let mut nominal = nominals(&tree, "base_link", &frames).unwrap();
        nominal.dedup_by(|a, b| a.0 == b.0);
        let rig = Rig { scans, nominal, roi: config.roi, reference: None };
        let from_bag = calib::calibrate(&rig, P2P, &settings(), |_| Control::Continue).unwrap();
        for (a, b) in from_pcd.sensors.iter().zip(&from_bag.sensors) {
            let d = a.extrinsic.inverse() * b.extrinsic;
            assert!(
                d.translation.vector.norm() < 1e-9 && d.rotation.angle() < 1e-9,
                "{file}: {} vs {}",
                a.name,
                b.name
            );
        }
    }
}

// --- Livox CustomMsg ---------------------------------------------------------------------------

/// A Livox topic lists with its type, count, rate and frame id, and is a point cloud to a rig.
#[test]
fn livox_topics_list_as_point_clouds() {
    let cases = [
        ("livox.bag", "/front_left/points", "livox_ros_driver/CustomMsg", 3, 10.0, "front_left"),
        ("livox.bag", "/front_right/points", "livox_ros_driver2/CustomMsg", 3, 10.0, "front_right"),
        (
            "livox.mcap",
            "/front_right/points",
            "livox_ros_driver2/msg/CustomMsg",
            3,
            10.0,
            "front_right",
        ),
        ("livox.db3", "/livox/small", "livox_ros_driver2/msg/CustomMsg", 2, 20.0, "livox_frame"),
        ("livox_small.bag", "/livox/small", "livox_ros_driver/CustomMsg", 2, 20.0, "livox_frame"),
    ];
    for (file, name, type_name, count, rate, frame) in cases {
        let mut rec = open(file);
        assert!(rec.problems().is_empty(), "{file}: {:?}", rec.problems());
        let t = rec.topic(name).unwrap();
        // An MCAP opened from its summary bounds a topic's times by its chunks' until it is used.
        rec.times(t).unwrap();
        let topic = &rec.topics()[t];
        assert_eq!(
            (topic.type_name.as_str(), topic.kind, topic.count),
            (type_name, Kind::LivoxCustom, count),
            "{file}"
        );
        assert!(topic.kind.is_point_cloud() && (topic.rate_hz() - rate).abs() < 1e-9, "{file}");
        assert_eq!(rec.point_cloud(t, 0).unwrap().frame_id, frame, "{file}");
    }
}

/// /livox/small's points as make.py wrote them, big-endian CDR included: NaN, infinite and
/// zero returns dropped, reflectivity as intensity.
#[test]
fn livox_points_decode_in_every_container() {
    let expected: serde_json::Value =
        serde_json::from_slice(&bytes("expected_livox.json")).unwrap();
    let want = &expected["/livox/small"];
    let (points, intensity) = expected_cloud(want);
    let intensity = intensity.expect("/livox/small has intensity");
    for file in ["livox.bag", "livox.mcap", "livox.db3", "livox_small.bag", "livox_small.mcap"] {
        let mut rec = open(file);
        let t = rec.topic("/livox/small").unwrap();
        for m in 0..2 {
            let pc = rec.point_cloud(t, m).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(pc.cloud.points, points, "{file} {m}");
            assert_eq!(pc.cloud.intensity.as_ref(), Some(&intensity), "{file} {m}");
            assert_eq!((pc.width, pc.height, pc.dropped), (7, 1, 3), "{file} {m}");
            assert_eq!(pc.stamp_ns, 1_700_000_000_000_000_000 + m as i64 * 50_000_000);
        }
    }
}

/// A points sequence longer than the message is named, in CDR (.db3) and ROS 1 (a bag).
#[test]
fn livox_counts_beyond_the_message_are_named() {
    // lidar_id 3, rsvd 0 0 0, then the sequence's length: 7 points, little endian.
    let seven = [3, 0, 0, 0, 7, 0, 0, 0];
    for (file, want) in [
        ("livox.db3", "points: 8 points need 159 bytes, 139 left in the message"),
        ("livox_small.bag", "points: 8 points need 152 bytes, 133 left in the message"),
    ] {
        let mut data = bytes(file);
        let at = find(&data, &seven)[0] + 4;
        data[at] = 8;
        let mut rec = open_bytes(data, file).unwrap();
        let t = rec.topic("/livox/small").unwrap();
        let e = rec.point_cloud(t, 0).unwrap_err();
        assert_eq!(e.to_string(), format!("{file}, topic /livox/small, message 0: {want}"));
        assert!(rec.point_cloud(t, 1).is_ok(), "{file}");
    }
}

// --- damaged recordings: each a named error, the rest usable where the format allows ------

fn find(hay: &[u8], needle: &[u8]) -> Vec<usize> {
    hay.windows(needle.len()).enumerate().filter(|(_, w)| *w == needle).map(|(i, _)| i).collect()
}

#[test]
fn truncated_recordings_keep_what_precedes_the_cut() {
    for file in ["calib_zstd.mcap", "calib_bz2.bag"] {
        let mut data = bytes(file);
        data.truncate(data.len() * 6 / 10);
        let mut rec = open_bytes(data, file).unwrap_or_else(|e| panic!("{e}"));
        let problem =
            rec.problems().first().unwrap_or_else(|| panic!("{file}: no problem reported"));
        assert!(problem.problem.contains("truncated") && problem.file == file, "{problem}");
        let t = rec.topic("/front_left/points").unwrap();
        assert!(rec.topics()[t].count >= 1, "{file}");
        rec.point_cloud(t, 0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(rec.transforms(false).0.len(), 5, "{file}");
    }
}

#[test]
fn corrupt_chunk_is_named_and_other_chunks_read() {
    let mut data = bytes("calib_zstd.mcap");
    let mut clean = open("calib_zstd.mcap");
    let t = clean.topic("/front_right/points").unwrap();
    let good = clean.point_cloud(t, 2).unwrap();
    // Flip a byte in the middle of the file: inside one chunk's compressed data.
    let mid = data.len() / 2;
    data[mid] ^= 0x5A;
    let mut rec = open_bytes(data, "bad.mcap").unwrap();
    let mut errors = Vec::new();
    let mut ok = 0;
    for topic in ["/front_left/points", "/front_right/points"] {
        let t = rec.topic(topic).unwrap();
        for m in 0..3 {
            match rec.point_cloud(t, m) {
                Ok(_) => ok += 1,
                Err(e) => errors.push(e),
            }
        }
    }
    assert!(!errors.is_empty() && ok > 0, "{errors:?}");
    let e = &errors[0];
    assert!(
        e.file == "bad.mcap" && e.topic.is_some() && e.message.is_some() && e.offset.is_some(),
        "{e}"
    );
    assert!(rec.point_cloud(t, 2).is_err() || rec.point_cloud(t, 2).unwrap() == good);
}

#[test]
fn unknown_compression_is_named() {
    let mut data = bytes("layouts_zstd.mcap");
    for at in find(&data, b"zstd") {
        data[at..at + 4].copy_from_slice(b"zstx");
    }
    let mut rec = open_bytes(data, "x.mcap").unwrap();
    let t = rec.topic("/layout/f64").unwrap();
    let e = rec.point_cloud(t, 1).unwrap_err();
    assert!(e.problem.contains("unknown chunk compression 'zstx'"), "{e}");
    assert_eq!((e.topic.as_deref(), e.message), (Some("/layout/f64"), Some(1)));

    let mut data = bytes("layouts_lz4.bag");
    for at in find(&data, b"compression=lz4") {
        data[at + 12..at + 15].copy_from_slice(b"lz5");
    }
    let mut rec = open_bytes(data, "x.bag").unwrap();
    let t = rec.topic("/layout/f64").unwrap();
    let e = rec.point_cloud(t, 0).unwrap_err();
    assert!(e.problem.contains("unknown chunk compression 'lz5'"), "{e}");
}

#[test]
fn sizes_beyond_the_file_are_named() {
    // A record length beyond the end, in an unindexed MCAP: the scan keeps what precedes it.
    let mut data = bytes("layouts_unindexed.mcap");
    let rec = open_bytes(data.clone(), "u.mcap").unwrap();
    let before = rec.topics().iter().map(|t| t.count).sum::<usize>();
    let last = find(&data, &[0x05]).into_iter().rev().find(|&i| {
        let len = u64::from_le_bytes(data[i + 1..i + 9].try_into().unwrap());
        i + 9 + len as usize <= data.len() && len > 30 && len < 2000
    });
    let at = last.unwrap();
    data[at + 1..at + 9].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let rec = open_bytes(data, "u.mcap").unwrap();
    let p = &rec.problems()[0];
    assert!(
        p.problem.contains("bytes declared, file ends at") && p.offset == Some(at as u64),
        "{p}"
    );
    let after = rec.topics().iter().map(|t| t.count).sum::<usize>();
    assert!(after > 0 && after < before);

    // A PointCloud2 whose data length exceeds the message.
    let mut data = bytes("layouts_none.bag");
    let step = [22u32.to_le_bytes(), 132u32.to_le_bytes(), 132u32.to_le_bytes()].concat();
    let at = find(&data, &step)[0] + 8;
    data[at..at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    let mut rec = open_bytes(data, "n.bag").unwrap();
    let t = rec.topic("/layout/padded22").unwrap();
    let e = rec.point_cloud(t, 0).unwrap_err();
    assert!(e.problem.contains("data: 1000000 bytes declared"), "{e}");
    assert!(rec.point_cloud(t, 1).is_ok() || rec.point_cloud(t, 1).is_err());
    assert!(rec.point_cloud(rec.topic("/layout/f64").unwrap(), 0).is_ok());
}

#[test]
fn fields_overrunning_point_step_are_named() {
    let mut data = bytes("layouts_none.bag");
    let step = [22u32.to_le_bytes(), 132u32.to_le_bytes()].concat();
    let hits = find(&data, &step);
    assert_eq!(hits.len(), 2);
    data[hits[0]..hits[0] + 4].copy_from_slice(&12u32.to_le_bytes());
    let mut rec = open_bytes(data, "p.bag").unwrap();
    let t = rec.topic("/layout/padded22").unwrap();
    let e = rec.point_cloud(t, 0).unwrap_err();
    assert_eq!(
        e.to_string(),
        "p.bag, topic /layout/padded22, message 0: field z ends at byte 14, beyond point_step 12"
    );
    assert!(rec.point_cloud(t, 1).is_ok());
}

/// Inputs the fuzzers found, kept so they stay fixed (notes-recording.md).
#[test]
fn fuzz_findings_are_errors_not_panics() {
    for name in ["fuzz/db3_value_size_overflow.db3"] {
        if let Ok(mut rec) = open_bytes(bytes(name), name) {
            for t in 0..rec.topics().len() {
                for m in 0..rec.topics()[t].count {
                    let _ = rec.message(t, m);
                }
            }
        }
    }
}

/// A source counting its reads.
struct Counted {
    data: Vec<u8>,
    reads: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl gmmcalib::io::recording::ReadAt for Counted {
    fn size(&self) -> u64 {
        self.data.len() as u64
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.reads.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.data.read_at(offset, buf)
    }
}

#[test]
fn an_mcap_with_statistics_opens_from_its_summary_alone() {
    use std::sync::atomic::Ordering::Relaxed;
    let reads = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let source = Counted { data: bytes("stamps.mcap"), reads: reads.clone() };
    let mut rec = Recording::open(Box::new(source), "stamps.mcap", &mut |_, _| {}).unwrap();
    let opened = reads.load(Relaxed);
    // The magics, the footer and the summary: none of the 60 chunks' message indexes.
    assert!(opened <= 5, "{opened} reads to open");
    for t in rec.topics() {
        assert_eq!(t.count, 20, "{}", t.name);
        assert!((t.rate_hz() - 10.0).abs() < 0.01, "{} at {} Hz", t.name, t.rate_hz());
    }
    let a = rec.topic("/a/points").unwrap();
    let times = rec.times(a).unwrap();
    assert_eq!(times.len(), 20);
    assert_eq!(times[1] - times[0], 100_000_000);
    // One message index record per chunk of /a/points, then nothing more for it.
    assert_eq!(reads.load(Relaxed) - opened, 20);
    rec.times(a).unwrap();
    assert_eq!(reads.load(Relaxed) - opened, 20);
}

#[test]
fn instants_pair_by_header_stamps_not_log_times() {
    // /b/points is logged a full period late: by log time /a's message k would pair with /b's
    // k - 1; by stamp it is /b's k, 2 ms later. /c/points has no stamps: its log time stands.
    for file in ["stamps.mcap", "stamps.bag"] {
        let mut rec = open(file);
        let topic = |n: &str| rec.topic(n).unwrap();
        let (a, b, c) = (topic("/a/points"), topic("/b/points"), topic("/c/points"));
        let instants = InstantSettings { frames: 5, tolerance_ns: 20_000_000 };
        let chosen = rec.choose(&[a, b, c], a, &instants).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(chosen.picks.len(), 5, "{file}");
        for p in &chosen.picks {
            assert_eq!(
                p.reference_ns,
                1_700_000_000_000_000_000 + p.reference as u64 * 100_000_000
            );
            assert_eq!(p.others, [(p.reference, 2_000_000), (p.reference, 7_000_000)], "{file}");
        }
        // Each message's point is (k, topic, 1): an instant's scans share k.
        for k in 0..5 {
            let x: Vec<f32> =
                (0..3).map(|t| chosen.scans[t * 5 + k].cloud.cloud.points[0][0]).collect();
            assert_eq!(x, [x[0]; 3], "{file}: instant {k}");
            assert_eq!(x[0] as usize, chosen.picks[k].reference, "{file}");
        }
    }
}
