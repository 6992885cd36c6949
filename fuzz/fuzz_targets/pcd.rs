//! Any bytes named `.pcd` (or `.bin`, the other headerless path) must parse to an error or to a
//! cloud of valid points with one intensity per point, and never panic.
#![no_main]

use gmmcalib::cloud::is_valid_point;
use gmmcalib::io::{ParsedCloud, parse_cloud};
use libfuzzer_sys::fuzz_target;

fn check(parsed: ParsedCloud) {
    let cloud = parsed.cloud;
    // Missing returns are dropped in the sensor frame; a viewpoint may then move a real point
    // onto the origin, so after one only finiteness holds.
    let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite());
    let valid = |p: &[f32; 3]| finite(p) && (parsed.viewpoint_applied || is_valid_point(p));
    assert!(cloud.points.iter().all(valid));
    if let Some(intensity) = &cloud.intensity {
        assert_eq!(intensity.len(), cloud.points.len());
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(parsed) = parse_cloud(data, "fuzz.pcd") {
        check(parsed);
    }
    if let Ok(parsed) = parse_cloud(data, "fuzz.bin") {
        check(parsed);
    }
});
