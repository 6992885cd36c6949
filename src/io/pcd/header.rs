//! The PCD header: text lines up to and including `DATA`, in any order, `#` comments allowed.
//! Everything the data decoders need is checked here (field types, counts, point numbers,
//! viewpoint), so they only have to check sizes against the bytes present.

use nalgebra::{Quaternion, Translation3, UnitQuaternion};

use super::super::decode::Scalar;
use super::super::text::Lines;
use super::super::{Fault, Format};
use crate::se3::Pose;

/// One declared field.
pub(super) struct Field {
    pub(super) name: String,
    pub(super) scalar: Scalar,
    pub(super) count: usize,
}

impl Field {
    /// Bytes per point.
    pub(super) fn bytes(&self) -> Option<usize> {
        self.scalar.size().checked_mul(self.count)
    }
}

pub(super) struct Header {
    pub(super) fields: Vec<Field>,
    /// Indices into `fields` of x, y, z and intensity.
    pub(super) xyz: [usize; 3],
    pub(super) intensity: Option<usize>,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) points: usize,
    pub(super) viewpoint: Option<Pose>,
    pub(super) format: Format,
    /// Byte offset and line number where the data starts.
    pub(super) body_start: usize,
    pub(super) body_line: usize,
}

pub(super) fn record_size(fields: &[Field]) -> Result<usize, Fault> {
    offset_of(fields, fields.len()).ok_or_else(|| Fault::whole("point size overflows"))
}

/// Bytes of one point before field `j`.
pub(super) fn offset_of(fields: &[Field], j: usize) -> Option<usize> {
    fields.get(..j)?.iter().try_fold(0usize, |acc, f| acc.checked_add(f.bytes()?))
}

pub(super) fn parse_header(bytes: &[u8]) -> Result<Header, Fault> {
    let mut names: Option<(usize, Vec<String>)> = None;
    let mut sizes: Option<(usize, Vec<usize>)> = None;
    let mut types: Option<(usize, Vec<char>)> = None;
    let mut counts: Option<(usize, Vec<usize>)> = None;
    let (mut width, mut height, mut points) = (None, None, None);
    let mut viewpoint = None;
    let mut lines = Lines::new(bytes, 1, 0);
    let mut data = None;
    for (n, raw) in &mut lines {
        // Comments are skipped unread: some writers put Latin-1 text there.
        if raw.trim_ascii_start().starts_with(b"#") {
            continue;
        }
        let text = std::str::from_utf8(raw)
            .map_err(|_| Fault::line(n, "header is not valid UTF-8 text"))?
            .trim();
        let mut words = text.split_ascii_whitespace();
        let Some(keyword) = words.next() else { continue };
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
            let w = match (w, p) {
                (Some((_, w)), _) => w,
                // Without WIDTH the points fill HEIGHT rows (when they divide evenly).
                (None, Some((_, p))) => p.checked_div(h).filter(|w| w * h == p).unwrap_or(p),
                (None, None) => 0,
            };
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
