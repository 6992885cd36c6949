//! Chunk decompression with pure-Rust decoders (they build for wasm32): zstd (`ruzstd`), LZ4
//! frames (`lz4_flex`; MCAP and ROS 1's `lz4` both use the frame format) and bzip2 (`bzip2`
//! over `libbz2-rs-sys`). The declared uncompressed size bounds every output, so a corrupt
//! chunk cannot make us allocate more than it claims.

use std::io::Read;

/// A chunk's compression, as the container names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    None,
    Zstd,
    Lz4,
    Bz2,
}

impl Compression {
    /// From MCAP's (`""`, `zstd`, `lz4`) or ROS 1's (`none`, `bz2`, `lz4`) names.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "" | "none" => Some(Self::None),
            "zstd" => Some(Self::Zstd),
            "lz4" => Some(Self::Lz4),
            "bz2" => Some(Self::Bz2),
            _ => None,
        }
    }
}

/// Decompresses `data` into exactly `size` bytes; an error names what is wrong.
pub fn decompress(kind: Compression, data: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let limit = size as u64 + 1;
    let result = match kind {
        Compression::None => {
            out.extend_from_slice(data);
            Ok(())
        }
        Compression::Zstd => match ruzstd::streaming_decoder::StreamingDecoder::new(data) {
            Ok(decoder) => decoder.take(limit).read_to_end(&mut out).map(|_| ()),
            Err(e) => return Err(format!("zstd: {e}")),
        },
        Compression::Lz4 => {
            lz4_flex::frame::FrameDecoder::new(data).take(limit).read_to_end(&mut out).map(|_| ())
        }
        Compression::Bz2 => {
            bzip2::read::BzDecoder::new(data).take(limit).read_to_end(&mut out).map(|_| ())
        }
    };
    result.map_err(|e| format!("{kind:?} decompression failed: {e}"))?;
    if out.len() != size {
        return Err(format!("decompressed to {} bytes, declared {size}", out.len()));
    }
    Ok(out)
}
