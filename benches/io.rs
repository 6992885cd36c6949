//! I/O benchmark: parse speed of every encoding on a ~1M-point LiDAR-like cloud made in memory,
//! and the binary writers' speed. A module, not a binary: the bench executable includes it with
//! `#[path = ".../benches/io.rs"] mod io_bench;` and calls [`run`].
//!
//! Throughput is file bytes per second (MB = 10^6 bytes), best of [`RUNS`] runs; the parsers
//! also drop missing returns while reading, so that cost is included.

use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

use gmmcalib::Cloud;
use gmmcalib::io::{parse_cloud, write_pcd_binary, write_pcd_binary_compressed, write_ply_binary};

/// Points in the benchmark cloud.
pub const POINTS: usize = 1_000_000;
/// Timed repetitions per encoding; the best is reported.
pub const RUNS: usize = 5;

/// Prints one line per encoding: file size, best parse time (ms) and throughput (MB/s).
pub fn run() {
    let cloud = lidar_like(POINTS);
    let compressed = write_pcd_binary_compressed(&cloud).expect("1M points fit u32 sizes");
    let files: [(&str, &str, Vec<u8>); 7] = [
        ("PCD ascii", "bench.pcd", ascii_pcd(&cloud)),
        ("PCD binary", "bench.pcd", write_pcd_binary(&cloud)),
        ("PCD binary_compressed", "bench.pcd", compressed),
        ("PLY ascii", "bench.ply", ascii_ply(&cloud)),
        ("PLY binary_little_endian", "bench.ply", write_ply_binary(&cloud)),
        ("PLY binary_big_endian", "bench.ply", big_endian_ply(&cloud)),
        ("KITTI bin", "bench.bin", kitti(&cloud)),
    ];
    println!("io: parse {POINTS} points (x y z intensity), best of {RUNS}");
    for (label, name, bytes) in &files {
        let (seconds, parsed) =
            best_of(|| parse_cloud(bytes, name).expect("benchmark file parses"));
        assert_eq!(parsed.cloud.len() + parsed.dropped, POINTS, "{label}");
        report(label, bytes.len(), seconds);
    }
    println!("io: write {POINTS} points, best of {RUNS}");
    type Writer = fn(&Cloud) -> Vec<u8>;
    let writers: [(&str, Writer); 3] = [
        ("write PCD binary", write_pcd_binary),
        ("write PCD binary_compressed", |c| write_pcd_binary_compressed(c).unwrap_or_default()),
        ("write PLY binary", write_ply_binary),
    ];
    for (label, write) in writers {
        let (seconds, bytes) = best_of(|| write(&cloud));
        report(label, bytes.len(), seconds);
    }
}

fn best_of<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..RUNS {
        let start = Instant::now();
        let out = black_box(f());
        best = best.min(start.elapsed().as_secs_f64());
        last = Some(out);
    }
    (best, last.expect("RUNS > 0"))
}

fn report(label: &str, bytes: usize, seconds: f64) {
    let mb = bytes as f64 / 1e6;
    println!("  {label:<28} {mb:>7.1} MB {:>9.1} ms {:>8.0} MB/s", seconds * 1e3, mb / seconds);
}

/// A spinning-LiDAR-like scan: 64 rings, ranges 2..60 m with a deterministic jitter, intensity
/// 0..255, and about 3 % missing returns stored as zeros, as drivers write organized clouds.
fn lidar_like(n: usize) -> Cloud {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        // xorshift64*: cheap, deterministic, good enough for benchmark data.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f64 / (1u64 << 24) as f64
    };
    let mut points = Vec::with_capacity(n);
    let mut intensity = Vec::with_capacity(n);
    for i in 0..n {
        let ring = (i % 64) as f64;
        let azimuth = (i / 64) as f64 * 0.0035;
        let elevation = (ring - 40.0).to_radians() * 0.6;
        let range = 2.0 + 58.0 * next();
        let p = if next() < 0.03 {
            [0.0; 3]
        } else {
            [
                (range * elevation.cos() * azimuth.cos()) as f32,
                (range * elevation.cos() * azimuth.sin()) as f32,
                (range * elevation.sin()) as f32,
            ]
        };
        points.push(p);
        intensity.push((next() * 255.0).round() as f32);
    }
    Cloud { points, intensity: Some(intensity) }
}

/// The rows `x y z intensity` as text, shortest round-trip decimals.
fn ascii_rows(cloud: &Cloud) -> String {
    let intensity = cloud.intensity.as_deref().unwrap_or_default();
    let mut text = String::with_capacity(cloud.len() * 40);
    for (p, i) in cloud.points.iter().zip(intensity) {
        let _ = writeln!(text, "{} {} {} {}", p[0], p[1], p[2], i);
    }
    text
}

fn ascii_pcd(cloud: &Cloud) -> Vec<u8> {
    let n = cloud.len();
    let header = format!(
        "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n\
         WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA ascii\n"
    );
    (header + &ascii_rows(cloud)).into_bytes()
}

fn ply_header(format: &str, n: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
         property float z\nproperty float intensity\nend_header\n"
    )
}

fn ascii_ply(cloud: &Cloud) -> Vec<u8> {
    (ply_header("ascii", cloud.len()) + &ascii_rows(cloud)).into_bytes()
}

fn big_endian_ply(cloud: &Cloud) -> Vec<u8> {
    let mut out = ply_header("binary_big_endian", cloud.len()).into_bytes();
    let intensity = cloud.intensity.as_deref().unwrap_or_default();
    for (p, i) in cloud.points.iter().zip(intensity) {
        for v in [p[0], p[1], p[2], *i] {
            out.extend_from_slice(&v.to_be_bytes());
        }
    }
    out
}

fn kitti(cloud: &Cloud) -> Vec<u8> {
    let intensity = cloud.intensity.as_deref().unwrap_or_default();
    let records = cloud.points.iter().zip(intensity).flat_map(|(p, i)| [p[0], p[1], p[2], *i]);
    records.flat_map(f32::to_le_bytes).collect()
}
