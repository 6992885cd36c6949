//! Triangle meshes (a target's CAD model): OBJ, PLY and STL readers, and the mesh's area,
//! bounds and seeded surface samples.
//!
//! [`parse_mesh`] picks the reader by extension (`.obj`, `.ply`, `.stl`, any case). Polygons are
//! fanned into triangles; STL's repeated corners are merged (exactly equal coordinates) so every
//! format gives an indexed mesh. Every failure is an [`IoError`]: no faces, a point cloud given
//! as a mesh, NaN/inf coordinates, an index out of range, truncated data. Coordinates are kept
//! as stored (metres are assumed; no unit conversion).

mod obj;
mod stl;

use std::collections::HashMap;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::{Fault, IoError};
use crate::cloud::Aabb;

/// An indexed triangle mesh: each triangle names three entries of `vertices` (0-based).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Corner positions (m).
    pub vertices: Vec<[f64; 3]>,
    /// Corner indices into `vertices`; the winding (counter-clockwise seen from outside, as the
    /// formats write it) gives each face's normal.
    pub triangles: Vec<[u32; 3]>,
}

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
    .and_then(|mesh| mesh.check().map(|()| mesh))
    .map_err(|fault| fault.in_file(file_name))
}

impl Mesh {
    /// The corners of triangle `t`. Indices are valid in every mesh [`parse_mesh`] returns; a
    /// hand-built mesh with a bad index panics here.
    fn corners(&self, t: &[u32; 3]) -> [[f64; 3]; 3] {
        t.map(|i| self.vertices[i as usize])
    }

    /// Surface area (m^2): the sum of the triangles' areas.
    pub fn area(&self) -> f64 {
        self.triangles.iter().map(|t| triangle_area(self.corners(t))).sum()
    }

    /// The box around every triangle's corners (vertices no face uses are left out); invalid
    /// ([`Aabb::is_valid`] false) when there are no triangles.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::new([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in self.triangles.iter().flat_map(|t| self.corners(t)) {
            b.min = std::array::from_fn(|i| b.min[i].min(p[i]));
            b.max = std::array::from_fn(|i| b.max[i].max(p[i]));
        }
        b
    }

    /// The mesh moved so that its base sits at the origin: the bounding box's x and y centre at
    /// 0 and its lowest point at z = 0. This is how a target stands on the ground at a place
    /// (x, y): add (x, y, 0). Unchanged when there are no triangles.
    pub fn centred(&self) -> Mesh {
        let b = self.bounds();
        if !b.is_valid() {
            return self.clone();
        }
        let shift = [(b.min[0] + b.max[0]) / 2.0, (b.min[1] + b.max[1]) / 2.0, b.min[2]];
        let vertices =
            self.vertices.iter().map(|p| std::array::from_fn(|i| p[i] - shift[i])).collect();
        Mesh { vertices, triangles: self.triangles.clone() }
    }

    /// `k` points drawn uniformly over the surface (each triangle by its area, uniformly within
    /// it), from a [`Pcg64`] seeded with `seed`: the same mesh, `k` and seed give the same
    /// points. Empty when the mesh has no area.
    pub fn sample(&self, k: usize, seed: u64) -> Vec<[f64; 3]> {
        self.sample_with_normals(k, seed).into_iter().map(|(p, _)| p).collect()
    }

    /// [`Mesh::sample`] with each point's unit face normal (from the triangle's winding).
    pub fn sample_with_normals(&self, k: usize, seed: u64) -> Vec<([f64; 3], [f64; 3])> {
        // Cumulative areas: a uniform draw over [0, total) lands in a triangle with probability
        // proportional to its area; zero-area triangles are never picked.
        let mut total = 0.0;
        let cumulative: Vec<f64> = self
            .triangles
            .iter()
            .map(|t| {
                total += triangle_area(self.corners(t));
                total
            })
            .collect();
        if !(total > 0.0 && total.is_finite()) {
            return Vec::new();
        }
        let mut rng = Pcg64::seed_from_u64(seed);
        (0..k)
            .map(|_| {
                let r = rng.random::<f64>() * total;
                let t = cumulative.partition_point(|&c| c <= r).min(cumulative.len() - 1);
                let [a, b, c] = self.corners(&self.triangles[t]);
                // Uniform in the triangle: sqrt of the first draw spreads points evenly from
                // corner a to the opposite edge (Osada et al. 2002, eq. 1).
                let (s, v) = (rng.random::<f64>().sqrt(), rng.random::<f64>());
                let (wa, wb, wc) = (1.0 - s, s * (1.0 - v), s * v);
                let p = std::array::from_fn(|i| wa * a[i] + wb * b[i] + wc * c[i]);
                (p, unit_normal([a, b, c]))
            })
            .collect()
    }

    /// The checks every parsed mesh passes: at least one triangle, finite coordinates, indices
    /// in range, and a finite, positive area (what sampling needs).
    fn check(&self) -> Result<(), Fault> {
        if self.triangles.is_empty() {
            return Err(Fault::whole("no faces: a mesh needs at least one triangle"));
        }
        if let Some(i) = self.vertices.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Fault::whole(format!("vertex {i} has a NaN or infinite coordinate")));
        }
        let n = self.vertices.len();
        for (f, t) in self.triangles.iter().enumerate() {
            if let Some(&i) = t.iter().find(|&&i| i as usize >= n) {
                let problem = format!("index out of range: triangle {f} uses vertex {i} of {n}");
                return Err(Fault::whole(problem));
            }
        }
        let area = self.area();
        if !area.is_finite() {
            return Err(Fault::whole("the surface area overflows: coordinates are too large"));
        }
        if area <= 0.0 {
            return Err(Fault::whole("every face has zero area"));
        }
        Ok(())
    }
}

fn cross(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
}

fn triangle_area([a, b, c]: [[f64; 3]; 3]) -> f64 {
    let n = cross(a, b, c);
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
}

fn unit_normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    let n = cross(a, b, c);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|v| v / len)
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
