//! PLY (Stanford polygon format) reader: the `vertex` element's x, y, z and intensity.
//!
//! The header (`ply`, `format`, `comment`/`obj_info`, `element <name> <count>`, `property <type>
//! <name>`, `property list <count type> <item type> <name>`, `end_header`) declares elements
//! stored one after another. ASCII data has one record per line; binary data packs records with
//! no padding, and list properties make records variable-length, so elements stored before
//! `vertex` (faces, say) are walked record by record to find where the vertices begin.

mod faces;
mod header;

use super::decode::{Builder, Column, Endian, decode_columns};
use super::text::{TextLines, parse_f32, tokenize};
use super::{Decoded, Fault, Format};
use header::{Element, Property, parse_header};

pub(crate) use faces::read_mesh;

/// Reads a PLY file.
pub(crate) fn read(bytes: &[u8]) -> Result<Decoded, Fault> {
    let (format, elements, lines) = parse_header(bytes)?;
    let Some(v) = elements.iter().position(|e| e.name == "vertex") else {
        return Err(Fault::whole("no vertex element"));
    };
    let vertex = &elements[v];
    // Slot of each vertex property: 0, 1, 2 for x, y, z, 3 for intensity.
    let mut roles: Vec<Option<usize>> = vec![None; vertex.properties.len()];
    for (slot, names) in
        [&["x"][..], &["y"], &["z"], &["intensity", "scalar_intensity"]].iter().enumerate()
    {
        let found = vertex
            .properties
            .iter()
            .position(|(n, _)| names.iter().any(|w| n.eq_ignore_ascii_case(w)));
        match (found, slot) {
            (Some(k), _) if matches!(vertex.properties[k].1, Property::List { .. }) => {
                return Err(Fault::line(
                    vertex.line,
                    format!("vertex property {} is a list", names[0]),
                ));
            }
            (Some(k), _) => roles[k] = Some(slot),
            (None, 3) => {}
            (None, _) => {
                let problem = format!("vertex element has no {} property", names[0]);
                return Err(Fault::line(vertex.line, problem));
            }
        }
    }
    let has_intensity = roles.contains(&Some(3));
    let builder = match format {
        Format::PlyAscii => {
            let body = bytes.get(lines.offset()..).unwrap_or_default();
            let mut lines = TextLines::new(body, lines.number());
            for element in &elements[..v] {
                skip_ascii(element, &mut lines)?;
            }
            read_ascii(vertex, &roles, has_intensity, &mut lines)?
        }
        _ => {
            let e = if format == Format::PlyBinaryBigEndian { Endian::Big } else { Endian::Little };
            let mut pos = lines.offset();
            for element in &elements[..v] {
                pos = skip_binary(element, bytes, pos, e)?;
            }
            read_binary(vertex, &roles, has_intensity, bytes, pos, e)?
        }
    };
    let (cloud, dropped) = builder.finish();
    Ok(Decoded { cloud, dropped, format, width: vertex.count, height: 1, viewpoint: None })
}

/// The message for data that ends inside `element`, at record `record`.
fn ends_in(element: &Element, record: usize) -> String {
    format!(
        "truncated: data ends in element {} after {record} of {} records",
        element.name, element.count
    )
}

fn truncated(at: usize, element: &Element, record: usize) -> Fault {
    Fault::byte(at, ends_in(element, record))
}

/// Returns the byte offset just past `element`'s records, which start at `pos`.
fn skip_binary(element: &Element, bytes: &[u8], mut pos: usize, e: Endian) -> Result<usize, Fault> {
    if let Some(size) = element.fixed_size() {
        // Also covers elements without properties, which take no bytes however many they are.
        let end = size.checked_mul(element.count).and_then(|n| n.checked_add(pos));
        return end.filter(|&end| end <= bytes.len()).ok_or_else(|| truncated(pos, element, 0));
    }
    // Every record holds a list length, so each takes at least one byte and this loop ends
    // within the file whatever `count` says.
    for record in 0..element.count {
        for (_, property) in &element.properties {
            let len = match *property {
                Property::Scalar(s) => Some(s.size()),
                Property::List { count, item } => bytes
                    .get(pos..)
                    .and_then(|b| count.read_count(b, e))
                    .and_then(|n| n.checked_mul(item.size()))
                    .and_then(|n| n.checked_add(count.size())),
            };
            pos = len
                .and_then(|n| pos.checked_add(n))
                .filter(|&end| end <= bytes.len())
                .ok_or_else(|| truncated(pos, element, record))?;
        }
    }
    Ok(pos)
}

fn read_binary(
    vertex: &Element,
    roles: &[Option<usize>],
    has_intensity: bool,
    bytes: &[u8],
    start: usize,
    e: Endian,
) -> Result<Builder, Fault> {
    let left = bytes.len().saturating_sub(start);
    let needed = vertex.min_size().checked_mul(vertex.count);
    if needed.is_none_or(|n| n > left) {
        let problem =
            format!("truncated: {} vertices do not fit in the {left} bytes left", vertex.count);
        return Err(Fault::byte(start, problem));
    }
    let mut out = Builder::new(vertex.count, has_intensity);
    if let Some(record) = vertex.fixed_size() {
        let mut columns: [Option<Column>; 4] = [None; 4];
        let mut base = start;
        for ((_, property), role) in vertex.properties.iter().zip(roles) {
            if let (Property::Scalar(ty), Some(slot)) = (property, role) {
                columns[*slot] = Some(Column { base, stride: record, ty: *ty });
            }
            base += match property {
                Property::Scalar(s) | Property::List { count: s, .. } => s.size(),
            };
        }
        if let [Some(x), Some(y), Some(z), intensity] = columns {
            if decode_columns(bytes, vertex.count, [x, y, z], intensity, e, &mut out) {
                return Ok(out);
            }
        }
        return Err(truncated(start, vertex, 0));
    }
    let mut pos = start;
    for record in 0..vertex.count {
        let mut values = [0.0f32; 4];
        for ((_, property), role) in vertex.properties.iter().zip(roles) {
            let at = bytes.get(pos..).unwrap_or_default();
            let len = match *property {
                Property::Scalar(s) => {
                    if let Some(slot) = role {
                        let value =
                            s.read_f32(at, e).ok_or_else(|| truncated(pos, vertex, record))?;
                        values[*slot] = value;
                    }
                    Some(s.size())
                }
                Property::List { count, item } => count
                    .read_count(at, e)
                    .and_then(|n| n.checked_mul(item.size()))
                    .and_then(|n| n.checked_add(count.size())),
            };
            pos = len
                .and_then(|n| pos.checked_add(n))
                .filter(|&end| end <= bytes.len())
                .ok_or_else(|| truncated(pos, vertex, record))?;
        }
        out.push([values[0], values[1], values[2]], values[3]);
    }
    Ok(out)
}

/// Skips `element`'s records, one per non-blank line.
fn skip_ascii(element: &Element, lines: &mut TextLines<'_>) -> Result<(), Fault> {
    // An element without properties has nothing to write, so it takes no lines.
    let count = if element.properties.is_empty() { 0 } else { element.count };
    let mut record = 0;
    while record < count {
        let Some((_, line)) = lines.next() else {
            return Err(lines.ran_out(ends_in(element, record)));
        };
        record += usize::from(!line.trim_ascii().is_empty());
    }
    Ok(())
}

fn read_ascii(
    vertex: &Element,
    roles: &[Option<usize>],
    has_intensity: bool,
    lines: &mut TextLines<'_>,
) -> Result<Builder, Fault> {
    // Each value takes at least one character and one separator.
    let most = lines.remaining() / vertex.properties.len().saturating_mul(2).max(1) + 1;
    if vertex.count > most {
        let problem =
            format!("truncated: {} vertices but the ascii data holds at most {most}", vertex.count);
        return Err(Fault::line(lines.number(), problem));
    }
    let mut out = Builder::new(vertex.count, has_intensity);
    let mut tokens = Vec::new();
    while out.seen() < vertex.count {
        let Some((n, line)) = lines.next() else {
            return Err(lines.ran_out(ends_in(vertex, out.seen())));
        };
        tokenize(line, &mut tokens);
        if tokens.is_empty() {
            continue;
        }
        let mut values = [0.0f32; 4];
        let mut cursor = 0usize;
        for ((name, property), role) in vertex.properties.iter().zip(roles) {
            let token = tokens.get(cursor).ok_or_else(|| {
                let cut = if lines.at_end() { "truncated: " } else { "" };
                let problem =
                    format!("{cut}too few values ({}) for the vertex properties", tokens.len());
                Fault::line(n, problem)
            })?;
            cursor += 1;
            match property {
                Property::Scalar(_) => {
                    if let Some(slot) = role {
                        values[*slot] = parse_f32(token).map_err(|e| Fault::line(n, e))?;
                    }
                }
                Property::List { .. } => {
                    let len = token.parse::<usize>().ok().ok_or_else(|| {
                        Fault::line(n, format!("list {name} has no valid length"))
                    })?;
                    cursor = cursor.saturating_add(len);
                }
            }
        }
        if cursor != tokens.len() {
            return Err(Fault::line(
                n,
                format!("expected {cursor} values, found {}", tokens.len()),
            ));
        }
        out.push([values[0], values[1], values[2]], values[3]);
    }
    Ok(out)
}
