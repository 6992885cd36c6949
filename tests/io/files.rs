//! Point-cloud readers and writers against committed fixtures (tests/fixtures, made by
//! make_fixtures.py, an encoder independent of ours) and hand-made byte streams.

use std::time::{Duration, Instant};

use gmmcalib::Cloud;
use gmmcalib::export::{
    write_pcd_binary, write_pcd_binary_compressed, write_pcd_binary_organized, write_ply_binary,
};
use gmmcalib::io::{Format, Offset, ParsedCloud, ReadOptions, parse_cloud, parse_cloud_with};

fn fixture(name: &str) -> Vec<u8> {
    let path = format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn parse_fixture(name: &str) -> ParsedCloud {
    parse_cloud(&fixture(name), name).unwrap_or_else(|e| panic!("{e}"))
}

/// The cloud make_fixtures.py writes as `same_*` (same formulas, f64 then rounded to f32).
fn same_cloud(n: usize) -> Cloud {
    let f = |v: f64| v as f32;
    let points = (0..n)
        .map(|i| {
            let x = f(((i * 37) % 101) as f64 / 7.0 - 5.0);
            let y = f(((i * 53) % 97) as f64 / 3.0 - 10.0);
            let z = f(((i * 11) % 89) as f64 / 13.0 + 0.5);
            [x, y, z]
        })
        .collect();
    let intensity = (0..n).map(|i| f(((i * 29) % 256) as f64 / 3.0)).collect();
    Cloud { points, intensity: Some(intensity) }
}

/// An LZF stream of literal runs only: independent of the crate's compressor.
fn lzf_literal_only(data: &[u8]) -> Vec<u8> {
    data.chunks(32)
        .flat_map(|run| std::iter::once(run.len() as u8 - 1).chain(run.iter().copied()))
        .collect()
}

fn compressed_pcd(fields: &str, points: usize, sizes: [u32; 2], payload: &[u8]) -> Vec<u8> {
    let k = fields.split(' ').count();
    let fours = vec!["4"; k].join(" ");
    let fs = vec!["F"; k].join(" ");
    let ones = vec!["1"; k].join(" ");
    let mut out = format!(
        "VERSION 0.7\nFIELDS {fields}\nSIZE {fours}\nTYPE {fs}\nCOUNT {ones}\nWIDTH {points}\n\
         HEIGHT 1\nPOINTS {points}\nDATA binary_compressed\n"
    )
    .into_bytes();
    out.extend_from_slice(&sizes[0].to_le_bytes());
    out.extend_from_slice(&sizes[1].to_le_bytes());
    out.extend_from_slice(payload);
    out
}

#[test]
fn every_encoding_of_the_same_cloud_reads_identically() {
    let expected = same_cloud(60);
    let cases = [
        ("same_ascii.pcd", Format::PcdAscii),
        ("same_binary.pcd", Format::PcdBinary),
        ("same_compressed.pcd", Format::PcdBinaryCompressed),
        ("same_ascii.ply", Format::PlyAscii),
        ("same_le.ply", Format::PlyBinaryLittleEndian),
        ("same_be.ply", Format::PlyBinaryBigEndian),
        ("same.bin", Format::KittiBin),
    ];
    for (name, format) in cases {
        let parsed = parse_fixture(name);
        assert_eq!(parsed.cloud, expected, "{name}");
        assert_eq!(
            (parsed.format, parsed.dropped, parsed.width, parsed.height),
            (format, 0, 60, 1)
        );
        assert!(!parsed.viewpoint_applied);
    }
}

#[test]
fn writers_round_trip_bit_for_bit() {
    let mut cloud = same_cloud(500);
    // Values whose decimal forms are long, subnormal or huge must come back bit-identical too.
    cloud.points[0] = [f32::MIN_POSITIVE / 8.0, -f32::MAX, 1.0e-30];
    cloud.points[1] = [std::f32::consts::PI, -0.0, 1.0];
    let with_intensity = cloud.clone();
    let without = Cloud::from_points(cloud.points.clone());
    for cloud in [with_intensity, without] {
        let files = [
            ("w.pcd", write_pcd_binary(&cloud), Format::PcdBinary),
            ("w.pcd", write_pcd_binary_compressed(&cloud).unwrap(), Format::PcdBinaryCompressed),
            ("w.ply", write_ply_binary(&cloud), Format::PlyBinaryLittleEndian),
        ];
        for (name, bytes, format) in files {
            let parsed = parse_cloud(&bytes, name).unwrap();
            assert_eq!(parsed.format, format);
            let bits =
                |c: &Cloud| c.points.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&parsed.cloud), bits(&cloud), "{format}");
            assert_eq!(parsed.cloud.intensity, cloud.intensity, "{format}");
        }
    }
    // Compression really happens on repetitive data, and an empty cloud writes and reads back.
    let flat = Cloud::from_points(vec![[1.0, 2.0, 3.0]; 1000]);
    assert!(write_pcd_binary_compressed(&flat).unwrap().len() < 1000);
    for bytes in [write_pcd_binary(&Cloud::default()), write_ply_binary(&Cloud::default())] {
        assert!(
            parse_cloud(&bytes, "empty.pcd")
                .or_else(|_| parse_cloud(&bytes, "e.ply"))
                .unwrap()
                .cloud
                .is_empty()
        );
    }
}

#[test]
fn organized_writer_keeps_the_scan_shape() {
    let mut cloud = same_cloud(12);
    cloud.points[5] = [0.0; 3]; // a miss stays in place in an organized scan
    let bytes = write_pcd_binary_organized(&cloud, 4, 3).unwrap();
    let parsed = parse_cloud(&bytes, "scan.pcd").unwrap();
    assert_eq!((parsed.width, parsed.height), (4, 3));
    assert_eq!(parsed.dropped, 1);
    assert_eq!(parsed.cloud.len(), 11);
    assert!(write_pcd_binary_organized(&cloud, 5, 3).is_none());
    assert!(write_pcd_binary_organized(&cloud, usize::MAX, 2).is_none());
}

#[test]
fn organized_clouds_drop_nan_and_zero_returns() {
    for name in ["organized_ascii.pcd", "organized_binary.pcd", "organized_compressed.pcd"] {
        let parsed = parse_fixture(name);
        assert_eq!((parsed.width, parsed.height, parsed.dropped), (8, 4, 6), "{name}");
        let kept: Vec<f32> =
            (0..32).filter(|k| ![3, 5, 12, 17, 21, 30].contains(k)).map(|k| k as f32).collect();
        assert_eq!(parsed.cloud.intensity.as_deref(), Some(&kept[..]), "{name}");
        let first = parsed.cloud.points[0];
        assert_eq!(first, [1.0, -0.5, 2.0]);
        assert!(parsed.cloud.points.iter().flatten().all(|c| c.is_finite()));
    }
}

#[test]
fn padding_count_timestamp_ring_and_rgb_fields_are_skipped() {
    let expected = same_cloud(10);
    for name in ["extras_ascii.pcd", "extras_binary.pcd", "extras_compressed.pcd"] {
        let parsed = parse_fixture(name);
        assert_eq!(parsed.cloud.points, expected.points, "{name}");
        let intensity: Vec<f32> = (100..110).map(|v| v as f32).collect();
        assert_eq!(parsed.cloud.intensity, Some(intensity), "{name}");
    }
}

#[test]
fn viewpoint_is_applied_unless_disabled() {
    let raw = same_cloud(5);
    let bytes = fixture("viewpoint.pcd");
    let moved = parse_cloud(&bytes, "viewpoint.pcd").unwrap();
    assert!(moved.viewpoint_applied);
    // VIEWPOINT 1 2 3 with a quarter turn about z: (x, y, z) -> (1 - y, 2 + x, 3 + z).
    for (p, q) in raw.points.iter().zip(&moved.cloud.points) {
        let want = [1.0 - p[1], 2.0 + p[0], 3.0 + p[2]];
        assert!((0..3).all(|k| (q[k] - want[k]).abs() < 1e-5), "{q:?} vs {want:?}");
    }
    let opts = ReadOptions { apply_viewpoint: false };
    let kept = parse_cloud_with(&bytes, "viewpoint.pcd", &opts).unwrap();
    assert!(!kept.viewpoint_applied);
    assert_eq!(kept.cloud, raw, "x has COUNT 2; the first element is x");
    assert!(ReadOptions::default().apply_viewpoint);
}

#[test]
fn pcd_v06_with_shuffled_header_and_i_field() {
    // Without WIDTH, POINTS fill HEIGHT rows.
    let no_width = edited("v06.pcd", "HEIGHT 1\n", "HEIGHT 2\n");
    let no_width = String::from_utf8(no_width).unwrap().replace("WIDTH 4\n", "");
    let parsed = parse_cloud(no_width.as_bytes(), "w.pcd").unwrap();
    assert_eq!((parsed.width, parsed.height, parsed.cloud.len()), (2, 2, 4));
    let parsed = parse_fixture("v06.pcd");
    assert_eq!(
        parsed.cloud,
        Cloud { points: same_cloud(4).points, intensity: same_cloud(4).intensity }
    );
    assert_eq!(parsed.format, Format::PcdAscii);
}

#[test]
fn ply_elements_before_vertex_and_list_properties() {
    let expected = same_cloud(12);
    let cases = [
        ("faces_first_ascii.ply", Format::PlyAscii),
        ("faces_first_le.ply", Format::PlyBinaryLittleEndian),
        ("faces_first_be.ply", Format::PlyBinaryBigEndian),
    ];
    for (name, format) in cases {
        let parsed = parse_fixture(name);
        assert_eq!(parsed.format, format);
        assert_eq!(parsed.cloud, expected, "{name}");
    }
    let ints = parse_fixture("ints_be.ply");
    let want: Vec<[f32; 3]> =
        (0..6).map(|i| [(i - 3) as f32, (-200 * i) as f32, (70000 + i) as f32]).collect();
    assert_eq!(ints.cloud, Cloud::from_points(want));
}

#[test]
fn compressed_pcd_from_independent_encoders() {
    // Literal-only LZF written here, not by the crate.
    let cloud = same_cloud(33);
    let mut raw = Vec::new();
    for axis in 0..3 {
        raw.extend(cloud.points.iter().flat_map(|p| p[axis].to_le_bytes()));
    }
    raw.extend(cloud.intensity.as_ref().unwrap().iter().flat_map(|v| v.to_le_bytes()));
    let packed = lzf_literal_only(&raw);
    let file =
        compressed_pcd("x y z intensity", 33, [packed.len() as u32, raw.len() as u32], &packed);
    assert_eq!(parse_cloud(&file, "lit.pcd").unwrap().cloud, cloud);
    // A block whose sizes are equal is stored raw.
    let file = compressed_pcd("x y z intensity", 33, [raw.len() as u32; 2], &raw);
    assert_eq!(parse_cloud(&file, "raw.pcd").unwrap().cloud, cloud);

    // Back-references by hand: 4 points at (1, 2, 3). Per field, one 4-byte literal, then a
    // 12-byte copy from 4 back (control 7 << 5, extra length 3, distance byte 3).
    let mut stream = Vec::new();
    for v in [1.0f32, 2.0, 3.0] {
        stream.push(3);
        stream.extend_from_slice(&v.to_le_bytes());
        stream.extend_from_slice(&[7 << 5, 3, 3]);
    }
    let file = compressed_pcd("x y z", 4, [stream.len() as u32, 48], &stream);
    let parsed = parse_cloud(&file, "refs.pcd").unwrap();
    assert_eq!(parsed.cloud.points, vec![[1.0, 2.0, 3.0]; 4]);
    assert_eq!(parsed.format, Format::PcdBinaryCompressed);
}

/// Asserts `parse_cloud(bytes, name)` fails with a message holding `name` and every `part`.
fn assert_fails(bytes: &[u8], name: &str, parts: &[&str]) -> gmmcalib::io::IoError {
    let err = parse_cloud(bytes, name).expect_err(name);
    let message = err.to_string();
    assert!(message.starts_with(name), "{message}");
    for part in parts {
        assert!(message.contains(part), "'{message}' lacks '{part}'");
    }
    err
}

fn edited(name: &str, from: &str, to: &str) -> Vec<u8> {
    let bytes = fixture(name);
    let at = bytes.windows(from.len()).position(|w| w == from.as_bytes()).expect(from);
    [&bytes[..at], to.as_bytes(), &bytes[at + from.len()..]].concat()
}

#[test]
fn pcd_errors_name_file_line_and_problem() {
    let err = assert_fails(
        &edited("same_binary.pcd", "SIZE 4 4 4 4", "SIZE 4 4 4 2"),
        "scan.pcd",
        &["unknown TYPE/SIZE pair F/2"],
    );
    assert_eq!(err.offset, Some(Offset::Line(5)));
    assert!(err.to_string().starts_with("scan.pcd, line 5: unknown TYPE/SIZE pair F/2"));
    assert_fails(
        &edited("same_binary.pcd", "POINTS 60", "POINTS 61"),
        "a.pcd",
        &["line 10", "POINTS 61 does not match WIDTH*HEIGHT"],
    );
    assert_fails(
        &edited("same_binary.pcd", "FIELDS x", "FIELDS a"),
        "a.pcd",
        &["line 3", "no x field"],
    );
    assert_fails(
        &edited("same_binary.pcd", "TYPE F F F F", "TYPE F F F Q"),
        "a.pcd",
        &["TYPE 'Q'"],
    );
    assert_fails(
        &edited("same_binary.pcd", "COUNT 1 1 1 1", "COUNT 1 1 1"),
        "a.pcd",
        &["COUNT has 3 values"],
    );
    assert_fails(
        &edited("same_binary.pcd", "WIDTH 60", "WIDTH -60"),
        "a.pcd",
        &["WIDTH value '-60'"],
    );
    assert_fails(
        &edited("same_binary.pcd", "DATA binary", "DATA zip"),
        "a.pcd",
        &["unknown DATA encoding 'zip'"],
    );
    assert_fails(&edited("same_ascii.pcd", "DATA ascii\n", ""), "a.pcd", &["no DATA line"]);
    assert_fails(
        &edited("same_binary.pcd", "VIEWPOINT 0 0 0 1", "VIEWPOINT 0 0 0 0"),
        "a.pcd",
        &["VIEWPOINT", "quaternion"],
    );
    // Header text must be UTF-8; comments are skipped unread (writers put Latin-1 there).
    let mut bad_utf8 = fixture("same_binary.pcd");
    let at = bad_utf8.windows(8).position(|w| w == b"VERSION ").unwrap();
    bad_utf8[at + 8] = 0xff;
    assert_fails(&bad_utf8, "a.pcd", &["line 2", "not valid UTF-8"]);
    let mut latin1_comment = fixture("same_binary.pcd");
    latin1_comment[3] = 0xe9;
    assert!(parse_cloud(&latin1_comment, "a.pcd").is_ok());

    let binary = fixture("same_binary.pcd");
    let err = assert_fails(
        &binary[..binary.len() - 1],
        "cut.pcd",
        &["truncated", "need 960 bytes", "has 959"],
    );
    assert!(matches!(err.offset, Some(Offset::Byte(_))));
    let ascii = fixture("same_ascii.pcd");
    let newlines: Vec<usize> = (0..ascii.len()).filter(|&k| ascii[k] == b'\n').collect();
    let two_lines_short = &ascii[..newlines[newlines.len() - 3] + 1];
    assert_fails(two_lines_short, "cut.pcd", &["line 70", "truncated: data ends after 58 of 60"]);
    // Cut inside a number the data still parses (ascii cannot tell); cut before one it cannot.
    let mid_line = &ascii[..ascii.iter().rposition(|&b| b == b' ').unwrap()];
    assert_fails(mid_line, "cut.pcd", &["line 71", "truncated: expected 4 values, found 3"]);
    assert_fails(
        &edited("same_ascii.pcd", "-5 -10 0.5 0\n", "-5 -10 0.5\n"),
        "a.pcd",
        &["line 12", "expected 4 values, found 3"],
    );
    assert_fails(
        &edited("same_ascii.pcd", "-5 -10 0.5 0\n", "-5 abc 0.5 0\n"),
        "a.pcd",
        &["line 12", "'abc' is not a number"],
    );
}

#[test]
fn compressed_pcd_size_errors() {
    let file = fixture("same_compressed.pcd");
    let body = file.windows(18).position(|w| w == b"binary_compressed\n").unwrap() + 18;
    let set = |at: usize, v: u32| {
        let mut f = file.clone();
        f[body + at..body + at + 4].copy_from_slice(&v.to_le_bytes());
        f
    };
    assert_fails(
        &set(4, 961),
        "c.pcd",
        &["uncompressed size 961 does not match POINTS*point size = 960"],
    );
    assert_fails(&set(0, 5000), "c.pcd", &["truncated: compressed size 5000"]);
    assert_fails(&file[..body + 6], "c.pcd", &["two 4-byte sizes"]);
    // Back-reference before the start of the output.
    let stream = [1 << 5, 0];
    assert_fails(
        &compressed_pcd("x y z", 1, [2, 12], &stream),
        "c.pcd",
        &["LZF data corrupt", "before the start"],
    );
    let stream = [0x1f, 1, 2];
    assert_fails(
        &compressed_pcd("x y z", 1, [3, 12], &stream),
        "c.pcd",
        &["LZF data corrupt", "truncated"],
    );
}

#[test]
fn ply_and_kitti_errors() {
    assert_fails(
        &edited("same_le.ply", "element vertex", "element points"),
        "s.ply",
        &["no vertex element"],
    );
    assert_fails(
        &edited("same_le.ply", "property float x", "property float q"),
        "s.ply",
        &["line 5", "no x property"],
    );
    assert_fails(
        &edited("same_le.ply", "property float x", "property half x"),
        "s.ply",
        &["line 6", "unknown property type 'half'"],
    );
    assert_fails(
        &edited("same_le.ply", "binary_little_endian", "binary_middle_endian"),
        "s.ply",
        &["line 2", "unknown format"],
    );
    assert_fails(
        &edited("faces_first_le.ply", "list uchar int", "list float int"),
        "s.ply",
        &["not an integer type"],
    );
    assert_fails(
        &edited("same_le.ply", "end_header", "end_heading"),
        "s.ply",
        &["unknown header line 'end_heading'"],
    );
    assert_fails(&edited("same_le.ply", "ply\n", "pyl\n"), "s.ply", &["line 1", "not a PLY file"]);
    let le = fixture("faces_first_le.ply");
    assert_fails(&le[..le.len() - 10], "s.ply", &["truncated", "element vertex"]);
    let at = le.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    assert_fails(&le[..at + 5], "s.ply", &["truncated", "element face"]);
    let ascii = fixture("faces_first_ascii.ply");
    // Keep all but the last 5 lines: 2 material records and 3 vertices go missing.
    let newlines: Vec<usize> = (0..ascii.len()).filter(|&k| ascii[k] == b'\n').collect();
    let cut = newlines[newlines.len() - 6] + 1;
    assert_fails(&ascii[..cut], "s.ply", &["truncated", "element vertex after 9 of 12"]);
    assert_fails(
        &edited("same_ascii.ply", "-5 -10 0.5 0\n", "-5 -10 0.5\n"),
        "s.ply",
        &["line 11", "too few values"],
    );
    assert_fails(&fixture("same.bin")[..100], "k.bin", &["byte 96", "not a multiple of 16"]);
    assert_fails(b"x", "scan.xyz", &["unknown extension"]);
    assert_fails(b"x", "noextension", &["unknown extension"]);
    assert!(parse_cloud(&fixture("same.bin"), "K.BIN").is_ok(), "extensions are case-insensitive");
    // Header text must be UTF-8, except comments, where writers put Latin-1.
    let mut latin1 = fixture("same_le.ply");
    let at = latin1.windows(7).position(|w| w == b"fixture").unwrap();
    latin1[at + 6] = 0xe9; // "fixtur\xe9": Latin-1, not UTF-8
    assert!(parse_cloud(&latin1, "c.ply").is_ok());
    let at = latin1.windows(5).position(|w| w == b"float").unwrap();
    latin1[at] = 0xe9;
    assert_fails(&latin1, "c.ply", &["line 6", "not valid UTF-8"]);
}

#[test]
fn huge_declared_sizes_fail_fast_without_allocating() {
    let tera = "1000000000000";
    let files = [
        (
            "h.pcd",
            edited(
                "same_binary.pcd",
                "WIDTH 60\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 60",
                &format!("WIDTH {tera}\nHEIGHT 1\nPOINTS {tera}"),
            ),
        ),
        (
            "h.pcd",
            edited(
                "same_ascii.pcd",
                "WIDTH 60\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 60",
                &format!("POINTS {tera}"),
            ),
        ),
        (
            "h.pcd",
            edited(
                "same_compressed.pcd",
                "WIDTH 60\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 60",
                &format!("WIDTH {tera}"),
            ),
        ),
        ("h.pcd", edited("same_binary.pcd", "COUNT 1 1 1 1", &format!("COUNT 1 1 1 {tera}"))),
        ("h.ply", edited("same_le.ply", "element vertex 60", &format!("element vertex {tera}"))),
        ("h.ply", edited("same_ascii.ply", "element vertex 60", &format!("element vertex {tera}"))),
        ("h.ply", edited("faces_first_le.ply", "element face 3", &format!("element face {tera}"))),
        (
            "h.ply",
            edited("faces_first_ascii.ply", "element face 3", &format!("element face {tera}")),
        ),
    ];
    for (name, bytes) in files {
        let start = Instant::now();
        let err = parse_cloud(&bytes, name).expect_err(name);
        assert!(start.elapsed() < Duration::from_millis(200), "{err}");
        assert!(
            err.to_string().contains("truncated") || err.to_string().contains("uncompressed size"),
            "{err}"
        );
    }
    // No points but a huge COUNT: nothing may be sized from the COUNT alone.
    let no_points = String::from_utf8(edited("v06.pcd", "POINTS 4", "POINTS 0")).unwrap();
    let no_points = no_points.replace("WIDTH 4", "WIDTH 0");
    let huge_count = no_points.replace("COUNT 1 1 1 1", &format!("COUNT 1 1 1 {tera}"));
    assert!(parse_cloud(huge_count.as_bytes(), "c.pcd").unwrap().cloud.is_empty());
    // An element without properties takes no bytes, however many records it declares.
    let empty_elements =
        edited("same_le.ply", "element vertex", &format!("element nothing {tera}\nelement vertex"));
    assert_eq!(parse_cloud(&empty_elements, "e.ply").unwrap().cloud, same_cloud(60));
}

#[test]
fn format_names_and_error_display() {
    assert_eq!(Format::PcdBinaryCompressed.to_string(), "PCD binary_compressed");
    assert_eq!(Format::PlyBinaryBigEndian.to_string(), "PLY binary_big_endian");
    assert_eq!(Format::KittiBin.to_string(), "KITTI bin");
    let err = parse_cloud(b"x", "a.bin").unwrap_err();
    assert_eq!(
        err.to_string(),
        "a.bin, byte 0: length 1 is not a multiple of 16 bytes (f32 x, y, z, intensity per point)"
    );
    let boxed: Box<dyn std::error::Error> = Box::new(err);
    assert!(boxed.to_string().contains("a.bin"));
}
