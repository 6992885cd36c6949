//! Wavefront OBJ: `v x y z [w]` vertices and `f` faces whose corners are `i`, `i/t`, `i//n` or
//! `i/t/n` with 1-based indices, negative ones counting back from the latest vertex. Every other
//! statement (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, ...) and `#` comments are
//! skipped: they add nothing to the surface.

use super::super::Fault;
use super::super::text::{TextLines, shown, tokenize};
use super::{Mesh, fan, finite_vertex};

/// Reads an OBJ file.
pub(super) fn read(bytes: &[u8]) -> Result<Mesh, Fault> {
    let mut lines = TextLines::new(bytes, 1);
    let mut mesh = Mesh::default();
    let (mut tokens, mut corners) = (Vec::new(), Vec::new());
    for (n, line) in lines.by_ref() {
        let line = line.split_once('#').map_or(line, |(data, _)| data);
        tokenize(line, &mut tokens);
        match tokens.first().copied() {
            Some("v") => {
                let [x, y, z] = [1, 2, 3].map(|k| tokens.get(k).copied());
                let (Some(x), Some(y), Some(z)) = (x, y, z) else {
                    return Err(Fault::line(n, "a vertex needs x, y and z"));
                };
                let p = [coordinate(x, n)?, coordinate(y, n)?, coordinate(z, n)?];
                mesh.vertices.push(finite_vertex(p, |e| Fault::line(n, e))?);
            }
            Some("f") => {
                corners.clear();
                for token in &tokens[1..] {
                    corners.push(corner(token, mesh.vertices.len(), n)?);
                }
                if corners.len() < 3 {
                    let problem =
                        format!("a face needs 3 or more corners, this has {}", corners.len());
                    return Err(Fault::line(n, problem));
                }
                fan(&corners, &mut mesh.triangles);
            }
            _ => {}
        }
    }
    if !lines.at_end() {
        return Err(lines.ran_out(String::new()));
    }
    Ok(mesh)
}

/// One coordinate, as f64 (OBJ writers print doubles).
fn coordinate(token: &str, line: usize) -> Result<f64, Fault> {
    let problem = || format!("'{}' is not a number", shown(token));
    token.parse::<f64>().map_err(|_| Fault::line(line, problem()))
}

/// The 0-based vertex of a face corner `i[/t[/n]]`, given `seen` vertices so far.
fn corner(token: &str, seen: usize, line: usize) -> Result<u32, Fault> {
    let index = token.split('/').next().unwrap_or_default();
    let Ok(i) = index.parse::<i64>() else {
        let problem = format!("'{}' is not a vertex index", shown(token));
        return Err(Fault::line(line, problem));
    };
    // 1-based from the start, or -1 for the latest vertex; 0 names nothing.
    let resolved = match i {
        1.. => usize::try_from(i - 1).ok(),
        ..0 => usize::try_from(i.unsigned_abs()).ok().and_then(|back| seen.checked_sub(back)),
        0 => None,
    };
    match resolved.filter(|&r| r < seen).and_then(|r| u32::try_from(r).ok()) {
        Some(r) => Ok(r),
        None => {
            let problem =
                format!("index out of range: vertex {i} with {seen} vertices defined so far");
            Err(Fault::line(line, problem))
        }
    }
}
