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

use nalgebra::{Quaternion, Translation3, UnitQuaternion};

use super::decode::{Builder, Column, Endian, Lines, Scalar, decode_columns, parse_f32, tokenize};
use super::{Decoded, Fault, Format, lzf};
use crate::se3::Pose;

/// One declared field.
struct Field {
    name: String,
    scalar: Scalar,
    count: usize,
}

impl Field {
    /// Bytes per point.
    fn bytes(&self) -> Option<usize> {
        self.scalar.size().checked_mul(self.count)
    }
}

struct Header {
    fields: Vec<Field>,
    /// Indices into `fields` of x, y, z and intensity.
    xyz: [usize; 3],
    intensity: Option<usize>,
    width: usize,
    height: usize,
    points: usize,
    viewpoint: Option<Pose>,
    format: Format,
    /// Byte offset and line number where the data starts.
    body_start: usize,
    body_line: usize,
}

/// Reads a PCD file.
pub(crate) fn read(bytes: &[u8]) -> Result<Decoded, Fault> {
    let header = parse_header(bytes)?;
    let body = bytes.get(header.body_start..).unwrap_or_default();
    let has_intensity = header.intensity.is_some();
    let builder = match header.format {
        Format::PcdAscii => read_ascii(&header, body)?,
        Format::PcdBinary => {
            let record = record_size(&header.fields)?;
            let stored = body_size(&header, record)?;
            check_present(&header, stored, body.len())?;
            let columns = columns(&header, |j| offset_of(&header.fields, j).map(|o| (o, record)))?;
            decode(&header, body, columns, has_intensity)?
        }
        _ => {
            let raw = decompress(&header, body)?;
            let n = header.points;
            // Field-major: field j starts after all points of the fields before it.
            let columns = columns(&header, |j| {
                let base = offset_of(&header.fields, j)?.checked_mul(n)?;
                Some((base, header.fields.get(j)?.bytes()?))
            })?;
            decode(&header, &raw, columns, has_intensity)?
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

fn parse_header(bytes: &[u8]) -> Result<Header, Fault> {
    let mut names: Option<(usize, Vec<String>)> = None;
    let mut sizes: Option<(usize, Vec<usize>)> = None;
    let mut types: Option<(usize, Vec<char>)> = None;
    let mut counts: Option<(usize, Vec<usize>)> = None;
    let (mut width, mut height, mut points) = (None, None, None);
    let mut viewpoint = None;
    let mut lines = Lines::new(bytes, 1, 0);
    let mut data = None;
    for (n, raw) in &mut lines {
        let text = std::str::from_utf8(raw)
            .map_err(|_| Fault::line(n, "header is not valid UTF-8 text"))?
            .trim();
        let mut words = text.split_ascii_whitespace();
        let Some(keyword) = words.next().filter(|w| !w.starts_with('#')) else { continue };
        let values: Vec<&str> = words.collect();
        let number = |v: &str| parse_count(n, keyword, v);
        match keyword.to_ascii_uppercase().as_str() {
            "FIELDS" | "COLUMNS" => {
                names = Some((n, values.iter().map(|v| v.to_string()).collect()))
            }
            "SIZE" => {
                sizes = Some((n, values.iter().map(|v| number(v)).collect::<Result<_, _>>()?))
            }
            "COUNT" => {
                counts = Some((n, values.iter().map(|v| number(v)).collect::<Result<_, _>>()?))
            }
            "TYPE" => {
                types =
                    Some((n, values.iter().map(|v| parse_type(n, v)).collect::<Result<_, _>>()?))
            }
            "WIDTH" => width = Some((n, number(single(n, keyword, &values)?)?)),
            "HEIGHT" => height = Some((n, number(single(n, keyword, &values)?)?)),
            "POINTS" => points = Some((n, number(single(n, keyword, &values)?)?)),
            "VIEWPOINT" => viewpoint = parse_viewpoint(n, &values)?,
            "DATA" => {
                data = Some(match values.first().map(|v| v.to_ascii_lowercase()).as_deref() {
                    Some("ascii") => Format::PcdAscii,
                    Some("binary") => Format::PcdBinary,
                    Some("binary_compressed") => Format::PcdBinaryCompressed,
                    _ => {
                        return Err(Fault::line(
                            n,
                            format!("unknown DATA encoding '{}'", values.join(" ")),
                        ));
                    }
                });
                break;
            }
            // VERSION, and anything else PCL would ignore too.
            _ => {}
        }
    }
    let format = data.ok_or_else(|| Fault::whole("no DATA line: the header never ends"))?;
    let (names_line, names) = names.ok_or_else(|| Fault::whole("no FIELDS line"))?;
    let fields = declare_fields(names_line, &names, sizes, types, counts, format)?;
    let find = |wanted: &[&str]| {
        fields.iter().position(|f| wanted.iter().any(|w| f.name.eq_ignore_ascii_case(w)))
    };
    let mut xyz = [0; 3];
    for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
        *slot = find(&[axis]).ok_or_else(|| {
            Fault::line(names_line, format!("no {axis} field (FIELDS {})", names.join(" ")))
        })?;
    }
    let intensity = find(&["intensity", "i"]);

    let (width, height, points) = match (width, height, points) {
        (None, _, None) => return Err(Fault::whole("no POINTS or WIDTH line")),
        (w, h, p) => {
            let h = h.map_or(1, |(_, h)| h);
            let w = w.map_or_else(|| p.map_or(0, |(_, p)| p), |(_, w)| w);
            let product = w
                .checked_mul(h)
                .ok_or_else(|| Fault::whole(format!("WIDTH*HEIGHT = {w}*{h} overflows")))?;
            match p {
                Some((line, p)) if p != product => {
                    return Err(Fault::line(
                        line,
                        format!("POINTS {p} does not match WIDTH*HEIGHT = {w}*{h} = {product}"),
                    ));
                }
                _ => (w, h, product),
            }
        }
    };
    Ok(Header {
        fields,
        xyz,
        intensity,
        width,
        height,
        points,
        viewpoint,
        format,
        body_start: lines.offset(),
        body_line: lines.number(),
    })
}

/// Pairs names with sizes, types and counts. ASCII data does not depend on SIZE/TYPE, so old
/// files without them are read as F/4.
fn declare_fields(
    names_line: usize,
    names: &[String],
    sizes: Option<(usize, Vec<usize>)>,
    types: Option<(usize, Vec<char>)>,
    counts: Option<(usize, Vec<usize>)>,
    format: Format,
) -> Result<Vec<Field>, Fault> {
    let k = names.len();
    let ascii = format == Format::PcdAscii;
    let (size_line, sizes) = match sizes {
        Some(s) => s,
        None if ascii => (names_line, vec![4; k]),
        None => return Err(Fault::whole("no SIZE line")),
    };
    let (type_line, types) = match types {
        Some(t) => t,
        None if ascii => (names_line, vec!['F'; k]),
        None => return Err(Fault::whole("no TYPE line")),
    };
    let (count_line, counts) = counts.unwrap_or((names_line, vec![1; k]));
    for (line, what, len) in [
        (size_line, "SIZE", sizes.len()),
        (type_line, "TYPE", types.len()),
        (count_line, "COUNT", counts.len()),
    ] {
        if len != k {
            return Err(Fault::line(line, format!("{what} has {len} values but FIELDS has {k}")));
        }
    }
    let mut fields = Vec::with_capacity(k);
    for (((name, &size), &ty), &count) in names.iter().zip(&sizes).zip(&types).zip(&counts) {
        let scalar = match (ty, size) {
            ('I', 1) => Scalar::I8,
            ('I', 2) => Scalar::I16,
            ('I', 4) => Scalar::I32,
            ('I', 8) => Scalar::I64,
            ('U', 1) => Scalar::U8,
            ('U', 2) => Scalar::U16,
            ('U', 4) => Scalar::U32,
            ('U', 8) => Scalar::U64,
            ('F', 4) => Scalar::F32,
            ('F', 8) => Scalar::F64,
            _ => {
                let line = type_line.max(size_line);
                return Err(Fault::line(
                    line,
                    format!("unknown TYPE/SIZE pair {ty}/{size} for field {name}"),
                ));
            }
        };
        if count == 0 {
            return Err(Fault::line(count_line, format!("COUNT of field {name} is 0")));
        }
        fields.push(Field { name: name.clone(), scalar, count });
    }
    Ok(fields)
}

fn parse_count(line: usize, keyword: &str, value: &str) -> Result<usize, Fault> {
    value.parse::<usize>().map_err(|_| {
        Fault::line(line, format!("{keyword} value '{value}' is not a non-negative integer"))
    })
}

fn parse_type(line: usize, value: &str) -> Result<char, Fault> {
    match value.to_ascii_uppercase().as_str() {
        "I" => Ok('I'),
        "U" => Ok('U'),
        "F" => Ok('F'),
        _ => Err(Fault::line(line, format!("TYPE '{value}' is not I, U or F"))),
    }
}

fn single<'a>(line: usize, keyword: &str, values: &[&'a str]) -> Result<&'a str, Fault> {
    match values {
        [v] => Ok(v),
        _ => Err(Fault::line(line, format!("{keyword} needs one value, found {}", values.len()))),
    }
}

/// `VIEWPOINT tx ty tz qw qx qy qz` (metres, unit quaternion); `None` for the identity.
fn parse_viewpoint(line: usize, values: &[&str]) -> Result<Option<Pose>, Fault> {
    let v: Vec<f64> = values.iter().filter_map(|v| v.parse::<f64>().ok()).collect();
    let [tx, ty, tz, qw, qx, qy, qz] = v[..] else {
        return Err(Fault::line(line, "VIEWPOINT needs 7 numbers: tx ty tz qw qx qy qz"));
    };
    let q = Quaternion::new(qw, qx, qy, qz);
    let norm = q.norm();
    if !(v.iter().all(|c| c.is_finite()) && norm > 1e-9) {
        return Err(Fault::line(line, "VIEWPOINT must be finite with a non-zero quaternion"));
    }
    if [tx, ty, tz, qx, qy, qz] == [0.0; 6] {
        return Ok(None);
    }
    // Writers print 6 digits (0.707107), so the quaternion is renormalised rather than refused.
    let rotation = UnitQuaternion::from_quaternion(q / norm);
    Ok(Some(Pose::from_parts(Translation3::new(tx, ty, tz), rotation)))
}

fn record_size(fields: &[Field]) -> Result<usize, Fault> {
    offset_of(fields, fields.len()).ok_or_else(|| Fault::whole("point size overflows"))
}

/// Bytes of one point before field `j`.
fn offset_of(fields: &[Field], j: usize) -> Option<usize> {
    fields.get(..j)?.iter().try_fold(0usize, |acc, f| acc.checked_add(f.bytes()?))
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

/// Columns of x, y, z and intensity from `place(j) = (base, stride)` of field `j`.
fn columns(
    header: &Header,
    place: impl Fn(usize) -> Option<(usize, usize)>,
) -> Result<[Option<Column>; 4], Fault> {
    let column = |j: usize| -> Result<Column, Fault> {
        let (base, stride) = place(j).ok_or_else(|| Fault::whole("field offsets overflow"))?;
        let ty = header.fields.get(j).map_or(Scalar::F32, |f| f.scalar);
        Ok(Column { base, stride, ty })
    };
    let [x, y, z] = header.xyz;
    Ok([
        Some(column(x)?),
        Some(column(y)?),
        Some(column(z)?),
        header.intensity.map(column).transpose()?,
    ])
}

fn decode(
    header: &Header,
    data: &[u8],
    columns: [Option<Column>; 4],
    has_intensity: bool,
) -> Result<Builder, Fault> {
    let mut out = Builder::new(header.points, has_intensity);
    let [Some(x), Some(y), Some(z), intensity] = columns else {
        return Err(Fault::whole("internal: missing x/y/z column"));
    };
    if !decode_columns(data, header.points, [x, y, z], intensity, Endian::Little, &mut out) {
        return Err(Fault::byte(header.body_start, "truncated: data ends inside a point"));
    }
    Ok(out)
}

/// The field-major bytes of a `binary_compressed` body.
fn decompress<'a>(header: &Header, body: &'a [u8]) -> Result<std::borrow::Cow<'a, [u8]>, Fault> {
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
        return Ok(std::borrow::Cow::Borrowed(packed));
    }
    lzf::decompress(packed, uncompressed)
        .map(std::borrow::Cow::Owned)
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
    let mut tokens = Vec::with_capacity(per_point);
    let mut lines = Lines::new(body, header.body_line, header.body_start);
    while out.seen() < header.points {
        let Some((n, line)) = lines.next() else {
            let seen = out.seen();
            let problem = format!("truncated: data ends after {seen} of {} points", header.points);
            return Err(Fault::line(lines.number(), problem));
        };
        tokenize(line, &mut tokens);
        if tokens.first().is_none_or(|t| t.starts_with(b"#")) {
            continue;
        }
        if tokens.len() != per_point {
            return Err(Fault::line(
                n,
                format!("expected {per_point} values, found {}", tokens.len()),
            ));
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
