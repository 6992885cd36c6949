//! Building blocks shared by the PCD and PLY readers: scalar types and their byte decoding,
//! strided column reads, a point collector that drops missing returns, and ASCII tokenising.

use crate::cloud::{Cloud, is_valid_point};

/// A binary scalar type as PCD (`TYPE`/`SIZE`) and PLY (`property <type>`) declare them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

/// Byte order of binary data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

/// Reads a `$t` from the first bytes of `$b` in byte order `$e`; `None` when `$b` is too short.
macro_rules! read_as {
    ($t:ty, $b:expr, $e:expr) => {{
        const N: usize = std::mem::size_of::<$t>();
        let bytes: [u8; N] = $b.get(..N).and_then(|s| s.try_into().ok())?;
        match $e {
            Endian::Little => <$t>::from_le_bytes(bytes),
            Endian::Big => <$t>::from_be_bytes(bytes),
        }
    }};
}

impl Scalar {
    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// The value at the start of `b`, converted to f32 (f32 values bit for bit; wider values
    /// rounded); `None` when `b` is shorter than [`Scalar::size`].
    #[inline(always)]
    pub fn read_f32(self, b: &[u8], e: Endian) -> Option<f32> {
        Some(match self {
            Scalar::F32 => read_as!(f32, b, e),
            Scalar::F64 => read_as!(f64, b, e) as f32,
            Scalar::I8 => read_as!(i8, b, e) as f32,
            Scalar::U8 => read_as!(u8, b, e) as f32,
            Scalar::I16 => read_as!(i16, b, e) as f32,
            Scalar::U16 => read_as!(u16, b, e) as f32,
            Scalar::I32 => read_as!(i32, b, e) as f32,
            Scalar::U32 => read_as!(u32, b, e) as f32,
            Scalar::I64 => read_as!(i64, b, e) as f32,
            Scalar::U64 => read_as!(u64, b, e) as f32,
        })
    }

    /// A PLY list length at the start of `b`: `None` for float types, negative values or short
    /// input.
    pub fn read_count(self, b: &[u8], e: Endian) -> Option<usize> {
        let n: i128 = match self {
            Scalar::I8 => read_as!(i8, b, e).into(),
            Scalar::U8 => read_as!(u8, b, e).into(),
            Scalar::I16 => read_as!(i16, b, e).into(),
            Scalar::U16 => read_as!(u16, b, e).into(),
            Scalar::I32 => read_as!(i32, b, e).into(),
            Scalar::U32 => read_as!(u32, b, e).into(),
            Scalar::I64 => read_as!(i64, b, e).into(),
            Scalar::U64 => read_as!(u64, b, e).into(),
            Scalar::F32 | Scalar::F64 => return None,
        };
        usize::try_from(n).ok()
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// One value per point in a byte buffer: point `i`'s value starts at `base + i * stride`.
/// Point-major records (PCD binary, PLY) have `stride` = record size; the field-major PCD
/// compressed layout has `stride` = the field's own size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Column {
    pub base: usize,
    pub stride: usize,
    pub ty: Scalar,
}

impl Column {
    /// True when the values of `n` points all lie within `len` bytes.
    fn fits(&self, n: usize, len: usize) -> bool {
        let Some(last) = n.checked_sub(1) else { return true };
        last.checked_mul(self.stride)
            .and_then(|o| o.checked_add(self.base))
            .and_then(|o| o.checked_add(self.ty.size()))
            .is_some_and(|end| end <= len)
    }

    #[inline(always)]
    fn read(&self, data: &[u8], i: usize, e: Endian) -> f32 {
        // `fits` was checked for every index used, so the fallback is unreachable; NaN would
        // only make the point count as dropped, never panic.
        let at = self.base + i * self.stride;
        data.get(at..).and_then(|b| self.ty.read_f32(b, e)).unwrap_or(f32::NAN)
    }
}

/// Decodes `n` points from the x, y, z (and optional intensity) columns of `data` into `out`.
/// Returns false, decoding nothing, when some column runs past the end of `data`.
pub(crate) fn decode_columns(
    data: &[u8],
    n: usize,
    xyz: [Column; 3],
    intensity: Option<Column>,
    e: Endian,
    out: &mut Builder,
) -> bool {
    if !xyz.iter().chain(intensity.iter()).all(|c| c.fits(n, data.len())) {
        return false;
    }
    let [cx, cy, cz] = xyz;
    for i in 0..n {
        let p = [cx.read(data, i, e), cy.read(data, i, e), cz.read(data, i, e)];
        let value = intensity.map_or(0.0, |c| c.read(data, i, e));
        out.push(p, value);
    }
    true
}

/// Collects decoded points, dropping missing returns (NaN/inf or exact zero) as they arrive so
/// that no second pass over the cloud is needed.
pub(crate) struct Builder {
    points: Vec<[f32; 3]>,
    intensity: Option<Vec<f32>>,
    dropped: usize,
}

impl Builder {
    /// `capacity` must already be bounded by the bytes present, never taken from a header alone.
    pub fn new(capacity: usize, with_intensity: bool) -> Self {
        Self {
            points: Vec::with_capacity(capacity),
            intensity: with_intensity.then(|| Vec::with_capacity(capacity)),
            dropped: 0,
        }
    }

    #[inline(always)]
    pub fn push(&mut self, p: [f32; 3], intensity: f32) {
        if is_valid_point(&p) {
            self.points.push(p);
            if let Some(values) = &mut self.intensity {
                values.push(intensity);
            }
        } else {
            self.dropped += 1;
        }
    }

    /// Points seen so far, kept or dropped.
    pub fn seen(&self) -> usize {
        self.points.len() + self.dropped
    }

    /// The cloud and the number of dropped points.
    pub fn finish(self) -> (Cloud, usize) {
        (Cloud { points: self.points, intensity: self.intensity }, self.dropped)
    }
}

/// Lines of a byte buffer with their 1-based numbers and their start offsets; a trailing `\r` is
/// removed (files written on Windows).
pub(crate) struct Lines<'a> {
    rest: &'a [u8],
    offset: usize,
    number: usize,
}

impl<'a> Lines<'a> {
    /// Lines of `data`, which starts at line `first_number` and byte `offset` of the file.
    pub fn new(data: &'a [u8], first_number: usize, offset: usize) -> Self {
        Self { rest: data, offset, number: first_number }
    }

    /// Byte offset in the file of the next line not yet returned.
    pub fn offset(&self) -> usize {
        self.offset
    }

    /// Bytes not yet returned.
    pub fn remaining(&self) -> usize {
        self.rest.len()
    }

    /// Number of the next line not yet returned.
    pub fn number(&self) -> usize {
        self.number
    }
}

impl<'a> Iterator for Lines<'a> {
    /// `(line number, line without its terminator)`.
    type Item = (usize, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let (line, consumed) = match self.rest.iter().position(|&b| b == b'\n') {
            Some(end) => (&self.rest[..end], end + 1),
            None => (self.rest, self.rest.len()),
        };
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let number = self.number;
        self.rest = &self.rest[consumed..];
        self.offset += consumed;
        self.number += 1;
        Some((number, line))
    }
}

/// Splits `line` at ASCII whitespace into `out` (cleared first), reusing its allocation.
#[inline]
pub(crate) fn tokenize<'a>(line: &'a [u8], out: &mut Vec<&'a [u8]>) {
    out.clear();
    out.extend(line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty()));
}

/// Parses one ASCII token as f32 (`nan`, `inf` and exponents accepted, as C's `strtof` writes).
#[inline]
pub(crate) fn parse_f32(token: &[u8]) -> Result<f32, String> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
        .ok_or_else(|| format!("'{}' is not a number", shown(token)))
}

/// A token for an error message: lossy UTF-8, at most 40 characters.
pub(crate) fn shown(token: &[u8]) -> String {
    let text = String::from_utf8_lossy(token);
    match text.char_indices().nth(40) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.into_owned(),
    }
}
