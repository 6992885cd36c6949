//! Triangle meshes (a target's CAD model) as geometry: area, bounds, the mesh stood on the
//! ground, and seeded surface samples. Read from files by [`crate::io::mesh::parse_mesh`].

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

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

impl Mesh {
    /// The corners of triangle `t`. Indices are valid in every mesh
    /// [`crate::io::mesh::parse_mesh`] returns; a
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
}

fn cross(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
}

pub(crate) fn triangle_area([a, b, c]: [[f64; 3]; 3]) -> f64 {
    let n = cross(a, b, c);
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
}

fn unit_normal([a, b, c]: [[f64; 3]; 3]) -> [f64; 3] {
    let n = cross(a, b, c);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|v| v / len)
}
