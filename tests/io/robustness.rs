//! Property-style robustness: valid files of every kind, mutated thousands of ways (truncated,
//! bytes flipped, header numbers made huge/zero/negative, header lines dropped or repeated),
//! must each parse to an error naming the file or to a cloud of valid points; never a panic.
//! Seeded, so a failure reproduces; the message names the mutation.

use std::panic::{AssertUnwindSafe, catch_unwind};

use gmmcalib::Cloud;
use gmmcalib::cloud::is_valid_point;
use gmmcalib::export::{write_pcd_binary, write_pcd_binary_compressed, write_ply_binary};
use gmmcalib::io::parse_cloud;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Every fixture plus the writers' output, with the name that picks the reader.
fn originals() -> Vec<(String, Vec<u8>)> {
    let dir = format!("{}/tests/fixtures", env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .expect("fixtures directory")
        .filter_map(|entry| {
            let path = entry.ok()?.path();
            let name = path.file_name()?.to_str()?.to_string();
            let readable = [".pcd", ".ply", ".bin"].iter().any(|ext| name.ends_with(ext));
            readable.then(|| (name, std::fs::read(&path).expect("fixture")))
        })
        .collect();
    files.sort();
    let points = (0..40).map(|i| [i as f32 * 0.5 + 1.0, -(i as f32), 0.25 * i as f32]).collect();
    let intensity = Some((0..40).map(|i| i as f32).collect());
    let cloud = Cloud { points, intensity };
    files.push(("written.pcd".into(), write_pcd_binary(&cloud)));
    files.push(("written_lzf.pcd".into(), write_pcd_binary_compressed(&cloud).expect("small")));
    files.push(("written.ply".into(), write_ply_binary(&cloud)));
    assert!(files.len() >= 20, "fixtures missing: {}", files.len());
    files
}

/// Length of the header text (up to the end of the `DATA` or `end_header` line), or of the whole
/// file when there is none (KITTI).
fn header_len(bytes: &[u8]) -> usize {
    for marker in [&b"DATA "[..], b"end_header"] {
        if let Some(at) = bytes.windows(marker.len()).position(|w| w == marker) {
            let eol =
                bytes[at..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |e| at + e + 1);
            return eol;
        }
    }
    bytes.len()
}

/// Runs the parser and checks the outcome; returns whether it parsed.
fn check(name: &str, bytes: &[u8], what: &str) -> bool {
    let outcome = catch_unwind(AssertUnwindSafe(|| parse_cloud(bytes, name)));
    match outcome {
        Err(_) => panic!("{name}: parser panicked on {what}"),
        Ok(Err(err)) => {
            assert!(err.to_string().starts_with(name), "{what}: {err}");
            assert!(!err.problem.is_empty(), "{what}: empty problem");
            false
        }
        Ok(Ok(parsed)) => {
            let cloud = parsed.cloud;
            // Missing returns are dropped in the sensor frame; a viewpoint may then move a real
            // point onto the origin, so after one only finiteness holds.
            let ok = |p: &[f32; 3]| match parsed.viewpoint_applied {
                true => p.iter().all(|c| c.is_finite()),
                false => is_valid_point(p),
            };
            assert!(cloud.points.iter().all(ok), "{name}: invalid point after {what}");
            if let Some(intensity) = &cloud.intensity {
                assert_eq!(intensity.len(), cloud.points.len(), "{name}: {what}");
            }
            assert!(cloud.len() + parsed.dropped <= parsed.width.saturating_mul(parsed.height));
            true
        }
    }
}

#[test]
fn truncated_files_never_panic() {
    let mut rng = Pcg64::seed_from_u64(1);
    let mut runs = 0;
    for (name, bytes) in originals() {
        assert!(check(&name, &bytes, "nothing"), "{name} must parse unmutated");
        // Every cut in the header region, then random cuts in the data.
        let head = header_len(&bytes).min(bytes.len());
        let cuts: Vec<usize> = (0..=head.min(400))
            .step_by(3)
            .chain((0..40).map(|_| rng.random_range(0..=bytes.len())))
            .collect();
        for cut in cuts {
            check(&name, &bytes[..cut], &format!("cut at {cut}"));
            runs += 1;
        }
    }
    assert!(runs > 2000, "{runs}");
}

#[test]
fn flipped_bytes_never_panic() {
    let mut rng = Pcg64::seed_from_u64(2);
    let mut runs = 0;
    for (name, bytes) in originals() {
        let head = header_len(&bytes).max(1);
        for trial in 0..80 {
            let mut mutated = bytes.clone();
            let flips = rng.random_range(1..=6);
            for _ in 0..flips {
                // Half the flips land in the header, where they change the declared layout.
                let limit = if trial % 2 == 0 { head } else { mutated.len() };
                let at = rng.random_range(0..limit.min(mutated.len()).max(1));
                if let Some(b) = mutated.get_mut(at) {
                    *b = rng.random();
                }
            }
            check(&name, &mutated, &format!("flip trial {trial}"));
            runs += 1;
        }
    }
    assert!(runs > 1500, "{runs}");
}

#[test]
fn extreme_header_numbers_never_panic() {
    let replacements = [
        "0",
        "-1",
        "1",
        "3",
        "65536",
        "4294967295",
        "4294967296",
        "1000000000000",
        "18446744073709551615",
        "18446744073709551616",
        "1e9",
        "nan",
        "",
    ];
    let mut rng = Pcg64::seed_from_u64(3);
    let mut runs = 0;
    for (name, bytes) in originals() {
        let head = header_len(&bytes);
        // Runs of digits in the header: sizes, counts, widths, element counts, viewpoint values.
        let mut numbers = Vec::new();
        let mut k = 0;
        while k < head {
            if bytes[k].is_ascii_digit() {
                let start = k;
                while k < head && bytes[k].is_ascii_digit() {
                    k += 1;
                }
                numbers.push(start..k);
            }
            k += 1;
        }
        for range in &numbers {
            for replacement in replacements {
                let mutated =
                    [&bytes[..range.start], replacement.as_bytes(), &bytes[range.end..]].concat();
                check(&name, &mutated, &format!("number at {} -> '{replacement}'", range.start));
                runs += 1;
            }
        }
        // Header lines dropped or repeated.
        let lines: Vec<usize> = (0..head).filter(|&k| bytes[k] == b'\n').collect();
        for pair in lines.windows(2) {
            let line = pair[0] + 1..pair[1] + 1;
            let dropped = [&bytes[..line.start], &bytes[line.end..]].concat();
            check(&name, &dropped, &format!("line at {} dropped", line.start));
            let repeated = [&bytes[..line.end], &bytes[line.clone()], &bytes[line.end..]].concat();
            check(&name, &repeated, &format!("line at {} repeated", line.start));
            runs += 2;
        }
        // The two u32 sizes of a compressed PCD block.
        if bytes.windows(17).any(|w| w == b"binary_compressed") {
            for _ in 0..30 {
                let mut mutated = bytes.clone();
                let at = head + rng.random_range(0..8usize);
                let value: u32 =
                    if rng.random_bool(0.5) { rng.random() } else { rng.random_range(0..4000) };
                if let Some(slot) = mutated.get_mut(at..at + 4) {
                    slot.copy_from_slice(&value.to_le_bytes());
                }
                check(&name, &mutated, &format!("size at {at} -> {value}"));
                runs += 1;
            }
        }
    }
    assert!(runs > 2000, "{runs}");
}
