//! Any bytes named `.ply` must parse to an error or to a cloud of finite, non-zero points with
//! one intensity per point, and never panic.
#![no_main]

use gmmcalib::io::parse_cloud;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(parsed) = parse_cloud(data, "fuzz.ply") {
        let cloud = parsed.cloud;
        assert!(cloud.points.iter().all(gmmcalib::cloud::is_valid_point));
        if let Some(intensity) = &cloud.intensity {
            assert_eq!(intensity.len(), cloud.points.len());
        }
    }
});
