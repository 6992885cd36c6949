//! STL, ASCII (`solid` / `facet normal` / `outer loop` / `vertex x y z` / `endloop` /
//! `endfacet` / `endsolid`) and binary (an 80-byte header, a little-endian u32 triangle count
//! `n`, then `n` records of 50 bytes: normal, three corners as f32, a 2-byte attribute).
//!
//! Which one: a file of exactly `84 + 50 n` bytes is binary. Many binary files also begin with
//! "solid", so that word alone does not make a file ASCII; it must also hold no NUL byte near
//! the start (a binary count below 2^24 has one), which keeps a truncated binary file binary.
//! Stored normals are ignored: the winding gives them.

use super::super::Fault;
use super::super::text::{TextLines, shown, tokenize};
use super::{Mesh, VertexPool, fan, finite_vertex};

const HEADER: usize = 84;
const RECORD: usize = 50;

/// Reads an STL file.
pub(super) fn read(bytes: &[u8]) -> Result<Mesh, Fault> {
    let declared = bytes.get(80..HEADER).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let size = declared.and_then(|n| (n as usize).checked_mul(RECORD)?.checked_add(HEADER));
    let texty = bytes.trim_ascii_start().starts_with(b"solid")
        && !bytes[..bytes.len().min(HEADER + RECORD)].contains(&0);
    match (size == Some(bytes.len()), texty) {
        (false, true) => read_ascii(bytes),
        _ => read_binary(bytes, declared.unwrap_or(0) as usize),
    }
}

fn read_binary(bytes: &[u8], n: usize) -> Result<Mesh, Fault> {
    if bytes.len() < HEADER {
        let problem = format!(
            "truncated: a binary STL starts with an {HEADER}-byte header, the file has {} bytes",
            bytes.len()
        );
        return Err(Fault::byte(bytes.len(), problem));
    }
    let records = bytes[HEADER..].chunks_exact(RECORD);
    if records.len() < n {
        let problem = format!(
            "truncated: the header declares {n} triangles ({} bytes), the file has {} bytes",
            HEADER as u128 + RECORD as u128 * n as u128,
            bytes.len()
        );
        return Err(Fault::byte(HEADER + records.len() * RECORD, problem));
    }
    // Bytes after the declared records (padding some writers leave) are ignored.
    let mut pool = VertexPool::default();
    let mut triangles = Vec::with_capacity(n);
    for (k, record) in records.take(n).enumerate() {
        let at = HEADER + k * RECORD;
        let mut t = [0u32; 3];
        for (c, slot) in t.iter_mut().enumerate() {
            let p: [f64; 3] = std::array::from_fn(|i| {
                let o = 12 + 12 * c + 4 * i;
                f32::from_le_bytes([record[o], record[o + 1], record[o + 2], record[o + 3]]).into()
            });
            let p = finite_vertex(p, |e| Fault::byte(at + 12 + 12 * c, e))?;
            *slot = pool.add(p).ok_or_else(|| Fault::byte(at, "more than 2^32 vertices"))?;
        }
        triangles.push(t);
    }
    Ok(Mesh { vertices: pool.vertices, triangles })
}

/// Where the ASCII reader is in the `solid` / `facet` / `outer loop` nesting.
#[derive(Clone, Copy, PartialEq, Eq)]
enum In {
    Nothing,
    Solid,
    Facet,
    Loop,
}

fn read_ascii(bytes: &[u8]) -> Result<Mesh, Fault> {
    let mut lines = TextLines::new(bytes, 1);
    let mut pool = VertexPool::default();
    let mut triangles = Vec::new();
    let (mut tokens, mut corners) = (Vec::new(), Vec::new());
    let mut state = In::Nothing;
    for (n, line) in lines.by_ref() {
        tokenize(line, &mut tokens);
        let Some(&word) = tokens.first() else { continue };
        state = match (word, state) {
            ("solid", In::Nothing) => In::Solid,
            ("facet", In::Solid) => In::Facet,
            ("outer", In::Facet) => {
                corners.clear();
                In::Loop
            }
            ("vertex", In::Loop) => {
                let mut p = [0.0; 3];
                for (i, slot) in p.iter_mut().enumerate() {
                    let token = tokens
                        .get(i + 1)
                        .ok_or_else(|| Fault::line(n, "a vertex needs x, y and z"))?;
                    *slot = token.parse::<f64>().map_err(|_| {
                        Fault::line(n, format!("'{}' is not a number", shown(token)))
                    })?;
                }
                let p = finite_vertex(p, |e| Fault::line(n, e))?;
                corners.push(pool.add(p).ok_or_else(|| Fault::line(n, "more than 2^32 vertices"))?);
                In::Loop
            }
            ("endloop", In::Loop) => {
                if corners.len() < 3 {
                    let problem =
                        format!("a facet needs 3 or more vertices, this has {}", corners.len());
                    return Err(Fault::line(n, problem));
                }
                fan(&corners, &mut triangles);
                In::Facet
            }
            ("endfacet", In::Facet) => In::Solid,
            ("endsolid", In::Solid) => In::Nothing,
            _ => {
                let problem = format!("unexpected '{}' in an ASCII STL", shown(word));
                return Err(Fault::line(n, problem));
            }
        };
    }
    if !lines.at_end() {
        return Err(lines.ran_out(String::new()));
    }
    if state != In::Nothing {
        return Err(Fault::line(lines.number(), "truncated: the file ends before endsolid"));
    }
    Ok(Mesh { vertices: pool.vertices, triangles })
}
