//! PLY as a mesh: the `vertex` element's x, y, z and the `face` element's `vertex_indices` (or
//! `vertex_index`) lists, in either order, any encoding. Other elements and properties are
//! walked over. Polygons are fanned into triangles.

use super::super::decode::{Endian, Scalar};
use super::super::mesh::{Mesh, fan, finite_vertex};
use super::super::text::{TextLines, shown, tokenize};
use super::super::{Fault, Format};
use super::header::{Element, Property, parse_header};
use super::{ends_in, skip_ascii, skip_binary, truncated};

/// What one element's records give: corners (vertex) or polygons (face).
#[derive(Clone, Copy)]
enum Role<'a> {
    /// The slot (0, 1, 2 for x, y, z) of each property.
    Vertex(&'a [Option<usize>]),
    /// The property holding the corner list, and the vertex count indices must stay below.
    Face { list: usize, vertices: usize },
}

/// Reads a PLY file as a mesh.
pub(crate) fn read_mesh(bytes: &[u8]) -> Result<Mesh, Fault> {
    let (format, elements, lines) = parse_header(bytes)?;
    let Some(v) = elements.iter().position(|e| e.name == "vertex") else {
        return Err(Fault::whole("no vertex element"));
    };
    let Some(f) = elements.iter().position(|e| e.name == "face") else {
        return Err(Fault::whole("a point cloud, not a mesh: it has no faces"));
    };
    let slots = xyz_slots(&elements[v])?;
    let list = corner_list(&elements[f])?;
    let role_of = |i: usize| match i {
        _ if i == v => Some(Role::Vertex(&slots)),
        _ if i == f => Some(Role::Face { list, vertices: elements[v].count }),
        _ => None,
    };
    let mut mesh = Mesh::default();
    if format == Format::PlyAscii {
        let body = bytes.get(lines.offset()..).unwrap_or_default();
        let mut lines = TextLines::new(body, lines.number());
        for (i, element) in elements.iter().enumerate() {
            match role_of(i) {
                Some(role) => read_ascii(element, role, &mut lines, &mut mesh)?,
                None => skip_ascii(element, &mut lines)?,
            }
        }
    } else {
        let e = if format == Format::PlyBinaryBigEndian { Endian::Big } else { Endian::Little };
        let mut pos = lines.offset();
        for (i, element) in elements.iter().enumerate() {
            pos = match role_of(i) {
                Some(role) => read_binary(element, role, bytes, pos, e, &mut mesh)?,
                None => skip_binary(element, bytes, pos, e)?,
            };
        }
    }
    Ok(mesh)
}

/// The slot of each vertex property: x, y, z scalars are required.
fn xyz_slots(vertex: &Element) -> Result<Vec<Option<usize>>, Fault> {
    let mut slots = vec![None; vertex.properties.len()];
    for (slot, name) in ["x", "y", "z"].into_iter().enumerate() {
        match vertex.properties.iter().position(|(n, _)| n.eq_ignore_ascii_case(name)) {
            Some(k) if matches!(vertex.properties[k].1, Property::Scalar(_)) => {
                slots[k] = Some(slot)
            }
            Some(_) => {
                return Err(Fault::line(vertex.line, format!("vertex property {name} is a list")));
            }
            None => {
                let problem = format!("vertex element has no {name} property");
                return Err(Fault::line(vertex.line, problem));
            }
        }
    }
    Ok(slots)
}

/// The face property holding the corner indices: an integer list.
fn corner_list(face: &Element) -> Result<usize, Fault> {
    let found =
        face.properties.iter().position(|(n, _)| n == "vertex_indices" || n == "vertex_index");
    match found.map(|k| (k, face.properties[k].1)) {
        Some((k, Property::List { item, .. })) if item.is_integer() => Ok(k),
        Some(_) => Err(Fault::line(face.line, "face vertex_indices is not a list of integers")),
        None => Err(Fault::line(face.line, "face element has no vertex_indices property")),
    }
}

fn index_out_of_range(index: usize, vertices: usize) -> String {
    format!("index out of range: a face uses vertex {index} of {vertices}")
}

fn read_binary(
    element: &Element,
    role: Role<'_>,
    bytes: &[u8],
    mut pos: usize,
    e: Endian,
    mesh: &mut Mesh,
) -> Result<usize, Fault> {
    // Every record takes at least `min_size` bytes, so this bounds `count` by the file.
    let left = bytes.len().saturating_sub(pos);
    if element.min_size().checked_mul(element.count).is_none_or(|n| n > left) {
        let problem = format!(
            "truncated: {} {} records do not fit in the {left} bytes left",
            element.count, element.name
        );
        return Err(Fault::byte(pos, problem));
    }
    if let Role::Vertex(_) = role {
        mesh.vertices.reserve(element.count);
    }
    let mut corners = Vec::new();
    for record in 0..element.count {
        let start = pos;
        let mut p = [0.0; 3];
        corners.clear();
        for (k, (_, property)) in element.properties.iter().enumerate() {
            let at = bytes.get(pos..).unwrap_or_default();
            let cut = || truncated(pos, element, record);
            pos = match (*property, role) {
                (Property::Scalar(s), Role::Vertex(slots)) => {
                    if let Some(slot) = slots[k] {
                        p[slot] = s.read_f64(at, e).ok_or_else(cut)?;
                    }
                    pos + s.size()
                }
                (Property::Scalar(s), _) => pos + s.size(),
                (Property::List { count, item }, _) => {
                    let n = count.read_count(at, e).ok_or_else(cut)?;
                    let end = n
                        .checked_mul(item.size())
                        .and_then(|len| len.checked_add(pos + count.size()))
                        .filter(|&end| end <= bytes.len())
                        .ok_or_else(cut)?;
                    if let Role::Face { list, vertices } = role {
                        if k == list {
                            for i in 0..n {
                                let o = pos + count.size() + i * item.size();
                                corners.push(binary_index(item, &bytes[o..], e, vertices, o)?);
                            }
                        }
                    }
                    end
                }
            };
            if pos > bytes.len() {
                return Err(truncated(start, element, record));
            }
        }
        add_record(role, p, &corners, mesh, |problem| Fault::byte(start, problem))?;
    }
    Ok(pos)
}

/// A binary corner index: a non-negative integer below `vertices`.
fn binary_index(
    item: Scalar,
    b: &[u8],
    e: Endian,
    vertices: usize,
    at: usize,
) -> Result<u32, Fault> {
    match item.read_count(b, e) {
        Some(i) if i < vertices => {
            u32::try_from(i).map_err(|_| Fault::byte(at, "more than 2^32 vertices"))
        }
        Some(i) => Err(Fault::byte(at, index_out_of_range(i, vertices))),
        None => Err(Fault::byte(at, "negative vertex index")),
    }
}

/// Stores one decoded record: a finite vertex, or a polygon of 3 or more corners.
fn add_record(
    role: Role<'_>,
    p: [f64; 3],
    corners: &[u32],
    mesh: &mut Mesh,
    fault: impl Fn(String) -> Fault,
) -> Result<(), Fault> {
    match role {
        Role::Vertex(_) => mesh.vertices.push(finite_vertex(p, &fault)?),
        Role::Face { .. } if corners.len() < 3 => {
            return Err(fault(format!(
                "a face needs 3 or more corners, this has {}",
                corners.len()
            )));
        }
        Role::Face { .. } => fan(corners, &mut mesh.triangles),
    }
    Ok(())
}

fn read_ascii(
    element: &Element,
    role: Role<'_>,
    lines: &mut TextLines<'_>,
    mesh: &mut Mesh,
) -> Result<(), Fault> {
    let count = if element.properties.is_empty() { 0 } else { element.count };
    let mut tokens = Vec::new();
    let mut corners = Vec::new();
    let mut record = 0;
    while record < count {
        let Some((n, line)) = lines.next() else {
            return Err(lines.ran_out(ends_in(element, record)));
        };
        tokenize(line, &mut tokens);
        if tokens.is_empty() {
            continue;
        }
        let mut p = [0.0; 3];
        corners.clear();
        let mut cursor = 0usize;
        let few = || {
            let cut = if lines.at_end() { "truncated: " } else { "" };
            Fault::line(
                n,
                format!(
                    "{cut}too few values ({}) for the {} properties",
                    tokens.len(),
                    element.name
                ),
            )
        };
        for (k, (name, property)) in element.properties.iter().enumerate() {
            let token = *tokens.get(cursor).ok_or_else(few)?;
            cursor += 1;
            match (property, role) {
                (Property::Scalar(_), Role::Vertex(slots)) => {
                    if let Some(slot) = slots[k] {
                        p[slot] = token.parse::<f64>().map_err(|_| {
                            Fault::line(n, format!("'{}' is not a number", shown(token)))
                        })?;
                    }
                }
                (Property::Scalar(_), _) => {}
                (Property::List { .. }, _) => {
                    let len = token
                        .parse::<usize>()
                        .map_err(|_| Fault::line(n, format!("list {name} has no valid length")))?;
                    let items = tokens.get(cursor..cursor.saturating_add(len)).ok_or_else(few)?;
                    if let Role::Face { list, vertices } = role {
                        if k == list {
                            for token in items {
                                corners.push(ascii_index(token, vertices, n)?);
                            }
                        }
                    }
                    cursor += len;
                }
            }
        }
        if cursor != tokens.len() {
            return Err(Fault::line(
                n,
                format!("expected {cursor} values, found {}", tokens.len()),
            ));
        }
        add_record(role, p, &corners, mesh, |problem| Fault::line(n, problem))?;
        record += 1;
    }
    Ok(())
}

/// An ASCII corner index: a non-negative integer below `vertices`.
fn ascii_index(token: &str, vertices: usize, line: usize) -> Result<u32, Fault> {
    match token.parse::<i64>() {
        Ok(i) if i < 0 => Err(Fault::line(line, "negative vertex index")),
        Ok(i) if (i as u64) < vertices as u64 => {
            u32::try_from(i).map_err(|_| Fault::line(line, "more than 2^32 vertices"))
        }
        Ok(i) => Err(Fault::line(line, index_out_of_range(i as usize, vertices))),
        Err(_) => Err(Fault::line(line, format!("'{}' is not a vertex index", shown(token)))),
    }
}
