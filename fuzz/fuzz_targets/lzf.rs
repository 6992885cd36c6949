//! LZF: decompressing any bytes to any declared size is an error or exactly that many bytes,
//! and compressing any bytes round-trips.
#![no_main]

use gmmcalib::lzf;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first two bytes choose the declared size; the rest is the stream.
    if let [a, b, stream @ ..] = data {
        let expected = usize::from(u16::from_le_bytes([*a, *b]));
        if let Ok(out) = lzf::decompress(stream, expected) {
            assert_eq!(out.len(), expected);
        }
    }
    let packed = lzf::compress(data);
    assert_eq!(lzf::decompress(&packed, data.len()).as_deref(), Ok(data));
});
