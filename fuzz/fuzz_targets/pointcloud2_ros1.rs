//! Any bytes decoded as a Ros1 PointCloud2 (and TFMessage) give an error or finite points with
//! one intensity per point, and never panic.
#![no_main]

use gmmcalib::io::recording::{Encoding, decode_point_cloud, decode_tf};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(pc) = decode_point_cloud(data, Encoding::Ros1) {
        assert!(pc.cloud.points.iter().all(|p| p.iter().all(|c| c.is_finite())));
        if let Some(i) = &pc.cloud.intensity {
            assert_eq!(i.len(), pc.cloud.points.len());
        }
    }
    let _ = decode_tf(data, Encoding::Ros1);
});
