//! Triangle meshes (a target's CAD model): OBJ, PLY and STL readers into [`Mesh`].
//!
//! [`parse_mesh`] picks the reader by extension (`.obj`, `.ply`, `.stl`, any case). Polygons are
//! fanned into triangles; STL's repeated corners are merged (exactly equal coordinates) so every
//! format gives an indexed mesh. Every failure is an [`IoError`]: no faces, a point cloud given
//! as a mesh, NaN/inf coordinates, an index out of range, truncated data. Coordinates are kept
//! as stored (metres are assumed; no unit conversion).

mod obj;
mod stl;

use std::collections::HashMap;

use super::{Fault, IoError};
pub use crate::mesh::Mesh;

/// Parses a triangle mesh, choosing the reader from the extension of `file_name` (`.obj`,
/// `.ply`, `.stl`, any case). `file_name` also labels every error.
pub fn parse_mesh(bytes: &[u8], file_name: &str) -> Result<Mesh, IoError> {
    let extension = file_name.rsplit_once('.').map(|(_, ext)| ext.to_ascii_lowercase());
    match extension.as_deref() {
        Some("obj") => obj::read(bytes),
        Some("ply") => super::ply::read_mesh(bytes),
        Some("stl") => stl::read(bytes),
        _ => Err(Fault::whole("unknown mesh extension: expected .obj, .ply or .stl")),
    }
    .and_then(|mesh| check(&mesh).map(|()| mesh))
    .map_err(|fault| fault.in_file(file_name))
}

/// The checks every parsed mesh passes: at least one triangle, finite coordinates, indices
/// in range, and a finite, positive area (what sampling needs).
fn check(mesh: &Mesh) -> Result<(), Fault> {
    if mesh.triangles.is_empty() {
        return Err(Fault::whole("no faces: a mesh needs at least one triangle"));
    }
    if let Some(i) = mesh.vertices.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(Fault::whole(format!("vertex {i} has a NaN or infinite coordinate")));
    }
    let n = mesh.vertices.len();
    for (f, t) in mesh.triangles.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i as usize >= n) {
            let problem = format!("index out of range: triangle {f} uses vertex {i} of {n}");
            return Err(Fault::whole(problem));
        }
    }
    let area = mesh.area();
    if !area.is_finite() {
        return Err(Fault::whole("the surface area overflows: coordinates are too large"));
    }
    if area <= 0.0 {
        return Err(Fault::whole("every face has zero area"));
    }
    Ok(())
}

/// Checks one decoded coordinate triple: the reader's error for NaN/inf.
pub(crate) fn finite_vertex(
    p: [f64; 3],
    at: impl FnOnce(String) -> Fault,
) -> Result<[f64; 3], Fault> {
    match p.iter().all(|c| c.is_finite()) {
        true => Ok(p),
        false => Err(at(format!("vertex ({}, {}, {}) is not finite", p[0], p[1], p[2]))),
    }
}

/// Adds the triangles of the polygon `corners` (fanned from its first corner) to `out`.
pub(crate) fn fan(corners: &[u32], out: &mut Vec<[u32; 3]>) {
    for pair in corners.windows(2).skip(1) {
        out.push([corners[0], pair[0], pair[1]]);
    }
}

/// Merges exactly equal corners (STL stores each triangle's corners on their own).
#[derive(Default)]
pub(crate) struct VertexPool {
    index: HashMap<[u64; 3], u32>,
    pub vertices: Vec<[f64; 3]>,
}

impl VertexPool {
    /// The index of `p`, added when new; `None` beyond `u32::MAX` vertices.
    pub fn add(&mut self, p: [f64; 3]) -> Option<u32> {
        // `+ 0.0` turns -0.0 into 0.0, so the two zeros are one corner.
        let key = p.map(|c| (c + 0.0).to_bits());
        if let Some(&i) = self.index.get(&key) {
            return Some(i);
        }
        let i = u32::try_from(self.vertices.len()).ok()?;
        self.vertices.push(p);
        self.index.insert(key, i);
        Some(i)
    }
}

#[cfg(test)]
mod tests;
