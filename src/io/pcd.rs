//! PCD (Point Cloud Library) reader, versions 0.6 and 0.7.
//!
//! The header is text lines (`#` comments, any order) ending with `DATA ascii|binary|
//! binary_compressed`. Points are records of fields; each field has a `SIZE` in bytes, a `TYPE`
//! (I signed, U unsigned, F float) and a `COUNT` of elements, of which we use the first.
//! - `ascii`: one point per line, `sum(COUNT)` numbers.
//! - `binary`: little-endian records of `sum(SIZE * COUNT)` bytes, point after point.
//! - `binary_compressed`: u32 compressed size, u32 uncompressed size, then LZF data that expands
//!   to the fields one after another (all x, then all y, ...). A block whose two sizes are equal
//!   is stored uncompressed.

mod header;

use std::borrow::Cow;

use super::decode::{Builder, Column, Endian, decode_columns};
use super::text::{TextLines, parse_f32, tokenize};
use super::{Decoded, Fault, Format};
use crate::lzf;
use header::{Header, offset_of, parse_header, record_size};

/// Reads a PCD file.
pub(crate) fn read(bytes: &[u8]) -> Result<Decoded, Fault> {
    let header = parse_header(bytes)?;
    let body = bytes.get(header.body_start..).unwrap_or_default();
    let builder = match header.format {
        Format::PcdAscii => read_ascii(&header, body)?,
        Format::PcdBinary => {
            let record = record_size(&header.fields)?;
            let stored = body_size(&header, record)?;
            check_present(&header, stored, body.len())?;
            decode(&header, body, |j| offset_of(&header.fields, j).map(|o| (o, record)))?
        }
        _ => {
            let raw = decompress(&header, body)?;
            let n = header.points;
            // Field-major: field j starts after all points of the fields before it.
            decode(&header, &raw, |j| {
                let base = offset_of(&header.fields, j)?.checked_mul(n)?;
                Some((base, header.fields.get(j)?.bytes()?))
            })?
        }
    };
    let (cloud, dropped) = builder.finish();
    Ok(Decoded {
        cloud,
        dropped,
        format: header.format,
        width: header.width,
        height: header.height,
        viewpoint: header.viewpoint,
    })
}

/// POINTS * point size, the number of data bytes the header declares.
fn body_size(header: &Header, record: usize) -> Result<usize, Fault> {
    header.points.checked_mul(record).ok_or_else(|| {
        Fault::whole(format!(
            "POINTS {} of {record} bytes overflow the address space",
            header.points
        ))
    })
}

/// Fails fast when the header declares more data than the file holds.
fn check_present(header: &Header, needed: usize, present: usize) -> Result<(), Fault> {
    if needed > present {
        return Err(Fault::byte(
            header.body_start,
            format!(
                "truncated: POINTS {} need {needed} bytes of data, the file has {present}",
                header.points
            ),
        ));
    }
    Ok(())
}

/// Decodes the points in `data`, where point `i`'s value of field `j` starts at
/// `base + i * stride` for `(base, stride) = place(j)`.
fn decode(
    header: &Header,
    data: &[u8],
    place: impl Fn(usize) -> Option<(usize, usize)>,
) -> Result<Builder, Fault> {
    let column = |j: usize| -> Result<Column, Fault> {
        let ty = header.fields.get(j).map(|f| f.scalar);
        match (place(j), ty) {
            (Some((base, stride)), Some(ty)) => Ok(Column { base, stride, ty }),
            _ => Err(Fault::whole("field offsets overflow")),
        }
    };
    let [x, y, z] = header.xyz;
    let xyz = [column(x)?, column(y)?, column(z)?];
    let intensity = header.intensity.map(column).transpose()?;
    let mut out = Builder::new(header.points, intensity.is_some());
    if !decode_columns(data, header.points, xyz, intensity, Endian::Little, &mut out) {
        return Err(Fault::byte(header.body_start, "truncated: data ends inside a point"));
    }
    Ok(out)
}

/// The field-major bytes of a `binary_compressed` body.
fn decompress<'a>(header: &Header, body: &'a [u8]) -> Result<Cow<'a, [u8]>, Fault> {
    let start = header.body_start;
    let size_at = |i: usize| {
        body.get(i..i + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes).ok_or_else(
            || Fault::byte(start, "truncated: binary_compressed data needs two 4-byte sizes"),
        )
    };
    let (compressed, uncompressed) = (size_at(0)? as usize, size_at(4)? as usize);
    let expected = body_size(header, record_size(&header.fields)?)?;
    if uncompressed != expected {
        return Err(Fault::byte(
            start + 4,
            format!(
                "uncompressed size {uncompressed} does not match POINTS*point size = {expected}"
            ),
        ));
    }
    let packed = body.get(8..).and_then(|b| b.get(..compressed)).ok_or_else(|| {
        let present = body.len().saturating_sub(8);
        Fault::byte(
            start,
            format!("truncated: compressed size {compressed} but {present} bytes follow"),
        )
    })?;
    if compressed == uncompressed {
        return Ok(Cow::Borrowed(packed));
    }
    lzf::decompress(packed, uncompressed)
        .map(Cow::Owned)
        .map_err(|e| Fault::byte(start + 8 + e.offset, format!("LZF data corrupt: {}", e.problem)))
}

fn read_ascii(header: &Header, body: &[u8]) -> Result<Builder, Fault> {
    let per_point = header.fields.iter().try_fold(0usize, |acc, f| acc.checked_add(f.count));
    let per_point = per_point.ok_or_else(|| Fault::whole("COUNT values overflow"))?;
    // Each value takes at least one character and one separator.
    let most = (body.len() + 1) / per_point.saturating_mul(2).max(1);
    if header.points > most {
        return Err(Fault::line(
            header.body_line,
            format!(
                "truncated: POINTS {} but the {} bytes of ascii data hold at most {most}",
                header.points,
                body.len()
            ),
        ));
    }
    let token_of = |j: usize| header.fields.get(..j).map_or(0, |f| f.iter().map(|f| f.count).sum());
    let [x, y, z] = header.xyz.map(token_of);
    let intensity = header.intensity.map(token_of);
    let mut out = Builder::new(header.points, intensity.is_some());
    let mut tokens = Vec::new();
    let mut lines = TextLines::new(body, header.body_line);
    while out.seen() < header.points {
        let Some((n, line)) = lines.next() else {
            let seen = out.seen();
            let problem = format!("truncated: data ends after {seen} of {} points", header.points);
            return Err(lines.ran_out(problem));
        };
        tokenize(line, &mut tokens);
        if tokens.first().is_none_or(|t| t.starts_with('#')) {
            continue;
        }
        if tokens.len() != per_point {
            let cut = if lines.at_end() { "truncated: " } else { "" };
            let problem = format!("{cut}expected {per_point} values, found {}", tokens.len());
            return Err(Fault::line(n, problem));
        }
        let value = |i: usize| match tokens.get(i) {
            Some(t) => parse_f32(t).map_err(|e| Fault::line(n, e)),
            None => Err(Fault::line(n, "missing value")),
        };
        let p = [value(x)?, value(y)?, value(z)?];
        out.push(p, intensity.map(value).transpose()?.unwrap_or(0.0));
    }
    Ok(out)
}
