//! Any bytes decoded as a Livox CustomMsg, in CDR and in ROS 1, give an error or finite points
//! with one intensity per point, and never panic.
#![no_main]

use gmmcalib::io::recording::{Encoding, decode_livox};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for encoding in [Encoding::Cdr, Encoding::Ros1] {
        if let Ok(pc) = decode_livox(data, encoding) {
            assert!(pc.cloud.points.iter().all(|p| p.iter().all(|c| c.is_finite())));
            let intensity = pc.cloud.intensity.as_ref().map(Vec::len);
            assert_eq!(intensity, Some(pc.cloud.points.len()));
            assert_eq!(pc.cloud.points.len() + pc.dropped, pc.width);
        }
    }
});
