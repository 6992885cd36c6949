//! LZF (Marc Lehmann's liblzf format), the compression inside PCD `binary_compressed`: a
//! codec below both `io` (which decompresses) and `export` (which compresses).
//!
//! A stream is a sequence of runs, each introduced by a control byte `c`:
//! - `c < 32`: a literal run; the next `c + 1` bytes are copied to the output.
//! - otherwise a back-reference: length `(c >> 5) + 2` (when `c >> 5 == 7`, one more byte is
//!   added to the length), then one byte `b`; the copy starts `((c & 31) << 8) + b + 1` bytes
//!   back in the output and may overlap the bytes it produces (run-length repeats).
//!
//! There is no end marker and no length field, so the caller supplies the expected output size.

use std::fmt;

/// A literal run holds at most this many bytes (control values 0..=31).
const MAX_LITERAL: usize = 32;
/// Largest back-reference distance: 13 bits of offset, plus one.
const MAX_DISTANCE: usize = 1 << 13;
/// Back-references copy between 3 and 7 + 255 + 2 bytes.
const MIN_MATCH: usize = 3;
const MAX_MATCH: usize = 7 + 255 + 2;
/// Most output one input byte can produce: a 3-byte maximal back-reference yields 264 bytes.
pub const MAX_EXPANSION: usize = MAX_MATCH / 3;

/// A corrupt LZF stream: the problem and the byte offset in the compressed input where it was
/// found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LzfError {
    pub offset: usize,
    pub problem: String,
}

impl fmt::Display for LzfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "LZF data corrupt at compressed byte {}: {}", self.offset, self.problem)
    }
}

impl std::error::Error for LzfError {}

fn corrupt(offset: usize, problem: impl Into<String>) -> LzfError {
    LzfError { offset, problem: problem.into() }
}

/// Decompresses `input`, which must decode to exactly `expected_len` bytes.
///
/// `expected_len` usually comes from a file header, so it is checked against what `input` could
/// possibly produce before the output buffer is allocated.
pub fn decompress(input: &[u8], expected_len: usize) -> Result<Vec<u8>, LzfError> {
    if expected_len > input.len().saturating_mul(MAX_EXPANSION) {
        return Err(corrupt(
            0,
            format!("{} compressed bytes cannot expand to {expected_len} bytes", input.len()),
        ));
    }
    let mut out: Vec<u8> = Vec::with_capacity(expected_len);
    let mut ip = 0;
    while let Some(&ctrl) = input.get(ip) {
        let at = ip;
        ip += 1;
        let ctrl = usize::from(ctrl);
        if ctrl < MAX_LITERAL {
            let len = ctrl + 1;
            let literal = input
                .get(ip..ip + len)
                .ok_or_else(|| corrupt(at, format!("literal run of {len} bytes is truncated")))?;
            if out.len() + len > expected_len {
                return Err(corrupt(
                    at,
                    format!("output exceeds the declared {expected_len} bytes"),
                ));
            }
            out.extend_from_slice(literal);
            ip += len;
        } else {
            let mut len = (ctrl >> 5) + 2;
            if ctrl >> 5 == 7 {
                let extra = input.get(ip).ok_or_else(|| corrupt(at, "truncated back-reference"))?;
                len += usize::from(*extra);
                ip += 1;
            }
            let low = input.get(ip).ok_or_else(|| corrupt(at, "truncated back-reference"))?;
            ip += 1;
            let distance = ((ctrl & 0x1f) << 8) + usize::from(*low) + 1;
            let start = out.len().checked_sub(distance).ok_or_else(|| {
                corrupt(at, format!("back-reference {distance} bytes before the start of output"))
            })?;
            if out.len() + len > expected_len {
                return Err(corrupt(
                    at,
                    format!("output exceeds the declared {expected_len} bytes"),
                ));
            }
            copy_back_reference(&mut out, start, len);
        }
    }
    if out.len() != expected_len {
        return Err(corrupt(
            input.len(),
            format!("stream ends after {} of {expected_len} bytes", out.len()),
        ));
    }
    Ok(out)
}

/// Appends `len` bytes copied from `out[start..]`. When the source overlaps the bytes being
/// written the data from `start` repeats with period `out.len() - start`, so copying in chunks
/// that are whole multiples of that period (doubling each time) gives the byte-by-byte result.
fn copy_back_reference(out: &mut Vec<u8>, start: usize, len: usize) {
    let mut remaining = len;
    while remaining > 0 {
        let chunk = remaining.min(out.len() - start);
        out.extend_from_within(start..start + chunk);
        remaining -= chunk;
    }
}

/// Compresses `input` into an LZF stream (greedy matching over a hash of the next three bytes,
/// as liblzf does; the output is valid LZF but not byte-identical to liblzf's).
pub fn compress(input: &[u8]) -> Vec<u8> {
    const HASH_BITS: u32 = 14;
    let hash = |b: &[u8]| -> usize {
        let v = u32::from(b[0]) << 16 | u32::from(b[1]) << 8 | u32::from(b[2]);
        (v.wrapping_mul(2_654_435_761) >> (32 - HASH_BITS)) as usize
    };
    // Position + 1 of the last occurrence of each hash; 0 = none.
    let mut table = vec![0usize; 1 << HASH_BITS];
    let mut out = Vec::with_capacity(input.len() + input.len() / MAX_LITERAL + 1);
    let mut literal_start = 0;
    let mut i = 0;
    while i + MIN_MATCH <= input.len() {
        let slot = hash(&input[i..]);
        let candidate = table[slot].checked_sub(1);
        table[slot] = i + 1;
        let matched = candidate.filter(|&r| i - r <= MAX_DISTANCE).map(|r| {
            let limit = (input.len() - i).min(MAX_MATCH);
            (r, (0..limit).take_while(|&k| input[r + k] == input[i + k]).count())
        });
        match matched {
            Some((r, len)) if len >= MIN_MATCH => {
                push_literals(&mut out, &input[literal_start..i]);
                let (code, offset) = (len - 2, i - r - 1);
                if code < 7 {
                    out.push((code << 5 | offset >> 8) as u8);
                } else {
                    out.push((7 << 5 | offset >> 8) as u8);
                    out.push((code - 7) as u8);
                }
                out.push(offset as u8);
                i += len;
                literal_start = i;
            }
            _ => i += 1,
        }
    }
    push_literals(&mut out, &input[literal_start..]);
    out
}

fn push_literals(out: &mut Vec<u8>, literals: &[u8]) {
    for run in literals.chunks(MAX_LITERAL) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_hand_made_literal_and_back_references() {
        let stream = [
            2,
            b'a',
            b'b',
            b'c', // literal run "abc"
            1 << 5,
            2, // length 3, distance 3: "abc"
            7 << 5,
            1,
            0, // length 7 + 1 + 2 = 10, distance 1: overlapping run of "c"
            3 << 5,
            12, // length 5, distance 13: "abccc"
        ];
        let out = decompress(&stream, 21).unwrap();
        assert_eq!(out, [b"abcabc".as_slice(), &[b'c'; 10], b"abccc"].concat());
    }

    #[test]
    fn decodes_far_back_reference() {
        // 300 literal bytes in runs of 32, then 4 bytes copied from 300 back (offset high bits 1).
        let literals: Vec<u8> = (0..300u32).map(|i| (i * 37 % 256) as u8).collect();
        let mut stream = Vec::new();
        for run in literals.chunks(32) {
            stream.push(run.len() as u8 - 1);
            stream.extend_from_slice(run);
        }
        stream.extend_from_slice(&[(2 << 5) | 1, 43]); // distance (1 << 8) + 43 + 1 = 300
        let out = decompress(&stream, 304).unwrap();
        assert_eq!(&out[..300], &literals[..]);
        assert_eq!(&out[300..], &literals[..4]);
    }

    #[test]
    fn rejects_corrupt_streams() {
        let err = decompress(&[1 << 5, 0], 3).unwrap_err();
        assert!(err.problem.contains("before the start"), "{err}");
        let err = decompress(&[5, b'a'], 6).unwrap_err();
        assert!(err.problem.contains("truncated"), "{err}");
        let err = decompress(&[0, b'a', 0, b'b'], 1).unwrap_err();
        assert_eq!(err.offset, 2);
        assert!(err.problem.contains("exceeds"), "{err}");
        let err = decompress(&[0, b'a'], 2).unwrap_err();
        assert!(err.problem.contains("after 1 of 2"), "{err}");
        let err = decompress(&[0, b'a'], usize::MAX / 2).unwrap_err();
        assert!(err.problem.contains("cannot expand"), "{err}");
        assert_eq!(decompress(&[], 0).unwrap(), Vec::<u8>::new());
    }

    #[test]
    fn compress_round_trips() {
        let mut inputs: Vec<Vec<u8>> = vec![vec![], vec![7], b"ab".to_vec(), vec![0; 10_000]];
        inputs.push((0..20_000u32).map(|i| (i * 7919 % 251) as u8).collect());
        inputs.push((0..5_000u32).flat_map(|i| (i as f32 * 0.01).to_le_bytes()).collect());
        for input in inputs {
            let packed = compress(&input);
            assert_eq!(decompress(&packed, input.len()).unwrap(), input);
        }
        assert!(compress(&[0; 10_000]).len() < 200);
    }
}
