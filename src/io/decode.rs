//! Binary building blocks shared by the readers: scalar types and their byte decoding, strided
//! column reads, and a point collector that drops missing returns.

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

    /// The value at the start of `b`, converted to f64 (exact for every type but 64-bit
    /// integers beyond 2^53); `None` when `b` is shorter than [`Scalar::size`].
    pub fn read_f64(self, b: &[u8], e: Endian) -> Option<f64> {
        Some(match self {
            Scalar::F32 => read_as!(f32, b, e).into(),
            Scalar::F64 => read_as!(f64, b, e),
            Scalar::I8 => read_as!(i8, b, e).into(),
            Scalar::U8 => read_as!(u8, b, e).into(),
            Scalar::I16 => read_as!(i16, b, e).into(),
            Scalar::U16 => read_as!(u16, b, e).into(),
            Scalar::I32 => read_as!(i32, b, e).into(),
            Scalar::U32 => read_as!(u32, b, e).into(),
            Scalar::I64 => read_as!(i64, b, e) as f64,
            Scalar::U64 => read_as!(u64, b, e) as f64,
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

    /// Decodes the values of points `first..first + out.len()` into `out`. The type and byte
    /// order are matched once per block, so each inner loop is a plain strided load.
    fn fill(&self, data: &[u8], first: usize, e: Endian, out: &mut [f32]) {
        macro_rules! fill_as {
            ($t:ty, $from:ident) => {{
                const N: usize = std::mem::size_of::<$t>();
                for (k, slot) in out.iter_mut().enumerate() {
                    let at = self.base + (first + k) * self.stride;
                    // `fits` was checked for every index used, so the NaN fallback is
                    // unreachable; it would only count the point as dropped, never panic.
                    let bytes = data.get(at..at + N).and_then(|b| <[u8; N]>::try_from(b).ok());
                    *slot = bytes.map_or(f32::NAN, |b| <$t>::$from(b) as f32);
                }
            }};
        }
        match (self.ty, e) {
            (Scalar::F32, Endian::Little) => fill_as!(f32, from_le_bytes),
            (Scalar::F32, Endian::Big) => fill_as!(f32, from_be_bytes),
            (Scalar::F64, Endian::Little) => fill_as!(f64, from_le_bytes),
            (Scalar::F64, Endian::Big) => fill_as!(f64, from_be_bytes),
            (Scalar::I8 | Scalar::U8, _) => {
                let signed = self.ty == Scalar::I8;
                for (k, slot) in out.iter_mut().enumerate() {
                    let byte = data.get(self.base + (first + k) * self.stride).copied();
                    *slot =
                        byte.map_or(f32::NAN, |b| if signed { b as i8 as f32 } else { b as f32 });
                }
            }
            (Scalar::I16, Endian::Little) => fill_as!(i16, from_le_bytes),
            (Scalar::I16, Endian::Big) => fill_as!(i16, from_be_bytes),
            (Scalar::U16, Endian::Little) => fill_as!(u16, from_le_bytes),
            (Scalar::U16, Endian::Big) => fill_as!(u16, from_be_bytes),
            (Scalar::I32, Endian::Little) => fill_as!(i32, from_le_bytes),
            (Scalar::I32, Endian::Big) => fill_as!(i32, from_be_bytes),
            (Scalar::U32, Endian::Little) => fill_as!(u32, from_le_bytes),
            (Scalar::U32, Endian::Big) => fill_as!(u32, from_be_bytes),
            (Scalar::I64, Endian::Little) => fill_as!(i64, from_le_bytes),
            (Scalar::I64, Endian::Big) => fill_as!(i64, from_be_bytes),
            (Scalar::U64, Endian::Little) => fill_as!(u64, from_le_bytes),
            (Scalar::U64, Endian::Big) => fill_as!(u64, from_be_bytes),
        }
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
    // Blocks small enough to stay in L1 while the columns are merged into points.
    const BLOCK: usize = 256;
    let mut values = [[0.0f32; BLOCK]; 4];
    let mut first = 0;
    while first < n {
        let len = (n - first).min(BLOCK);
        for (column, slot) in xyz.iter().chain(intensity.iter()).zip(values.iter_mut()) {
            column.fill(data, first, e, &mut slot[..len]);
        }
        let [xs, ys, zs, is] = &values;
        for k in 0..len {
            out.push([xs[k], ys[k], zs[k]], is[k]);
        }
        first += len;
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
