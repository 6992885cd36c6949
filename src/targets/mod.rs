//! The calibration target: its shape ([`Target`]), the points on its surface that seed
//! JRMPC's mixture ([`Target::surface`]), and the fit of the shape to the reconstruction
//! ([`fit_targets`]), the plausibility check of a calibration.

mod fit;
pub mod place;
mod sample;

pub use fit::{ShapeFit, fit_shape, fit_targets};
pub use place::{ModelCloud, PlaceSettings, Placement, place};
pub use sample::{box_surface, cube_surface, sphere_surface};

use std::sync::Arc;

use crate::io::IoError;
use crate::io::mesh::parse_mesh;
use crate::mesh::Mesh;

/// The shape of the calibration target (m).
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A cube of this edge: GMMCalib's target.
    Cube { edge: f64 },
    /// A box of these edges: width (x), depth (y), height (z) as it stands.
    Box { size: [f64; 3] },
    /// A sphere of this diameter.
    Sphere { diameter: f64 },
    /// A CAD model (OBJ, PLY or STL), upright as its file gives it (z up); where it stands is
    /// found from the data ([`place()`]).
    Mesh(MeshTarget),
    /// No target: the scene is the target (its ground, walls, poles, cars).
    None,
}

/// A CAD model target: its file's name (for reports) and the mesh, base centre at the origin
/// ([`Mesh::centred`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshTarget {
    pub name: String,
    pub mesh: Arc<Mesh>,
}

impl Default for Target {
    /// GMMCalib's target: a 0.5 m cube.
    fn default() -> Self {
        Target::Cube { edge: 0.5 }
    }
}

impl std::str::FromStr for Target {
    type Err = String;

    /// `cube:EDGE`, `box:W,D,H`, `sphere:DIAMETER` (m) or `none`. A `mesh:PATH` needs its
    /// file read: the caller reads it and calls [`Target::from_mesh_file`].
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        let expected = || {
            format!("unknown target '{s}' (expected cube:EDGE, box:W,D,H, sphere:DIAMETER or none)")
        };
        let (kind, sizes) = s.split_once(':').unwrap_or((s, ""));
        let numbers: Result<Vec<f64>, _> =
            sizes.split(',').filter(|x| !x.trim().is_empty()).map(|x| x.trim().parse()).collect();
        let numbers = numbers.map_err(|_| expected())?;
        let target = match (kind.to_ascii_lowercase().as_str(), numbers.as_slice()) {
            ("cube", &[edge]) => Target::Cube { edge },
            ("box", &[w, d, h]) => Target::Box { size: [w, d, h] },
            ("sphere", &[diameter]) => Target::Sphere { diameter },
            ("none", &[]) => Target::None,
            ("mesh", _) => {
                return Err(format!("target '{s}': a mesh target is read from its file"));
            }
            _ => return Err(expected()),
        };
        target.checked()
    }
}

impl Target {
    /// A CAD model target from its file's bytes (`.obj`, `.ply` or `.stl`, by `file_name`'s
    /// extension); the errors name the file and the place.
    pub fn from_mesh_file(bytes: &[u8], file_name: &str) -> Result<Target, IoError> {
        let mesh = parse_mesh(bytes, file_name)?;
        Ok(Target::Mesh(MeshTarget { name: file_name.to_string(), mesh: Arc::new(mesh.centred()) }))
    }

    /// The target, if every size it has is a positive finite number.
    pub fn checked(self) -> Result<Target, String> {
        let sizes: Vec<f64> = match &self {
            Target::Cube { edge } => vec![*edge],
            Target::Box { size } => size.to_vec(),
            Target::Sphere { diameter } => vec![*diameter],
            Target::Mesh(m) => vec![m.mesh.area(), self.size().unwrap_or(0.0)],
            Target::None => vec![],
        };
        match sizes.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            Some(bad) => Err(format!("target size must be a positive number (m), got {bad}")),
            None => Ok(self),
        }
    }

    /// `"cube"`, `"box"`, `"sphere"` or `"none"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Target::Cube { .. } => "cube",
            Target::Box { .. } => "box",
            Target::Sphere { .. } => "sphere",
            Target::Mesh(_) => "mesh",
            Target::None => "none",
        }
    }

    /// What messages call the target: a CAD model's file name, else its kind.
    pub fn label(&self) -> String {
        match self {
            Target::Mesh(m) => m.name.clone(),
            other => other.kind().to_string(),
        }
    }

    /// The target's overall size (m): cube edge, a box's largest edge, sphere diameter, a
    /// mesh's largest extent; `None` without a target.
    pub fn size(&self) -> Option<f64> {
        match self {
            Target::Cube { edge } => Some(*edge),
            Target::Box { size } => Some(size.iter().copied().fold(0.0, f64::max)),
            Target::Sphere { diameter } => Some(*diameter),
            Target::Mesh(m) => {
                let b = m.mesh.bounds();
                Some((0..3).map(|i| b.max[i] - b.min[i]).fold(0.0, f64::max))
            }
            Target::None => None,
        }
    }

    /// The target's surface as a triangle mesh standing at the origin (base centre at 0, z up),
    /// as placement and `cad` use it: the CAD model itself, or the cube's, box's or sphere's
    /// surface; `None` without a target.
    pub fn model(&self) -> Option<Arc<Mesh>> {
        match self {
            Target::Mesh(m) => Some(m.mesh.clone()),
            Target::Cube { edge } => Some(Arc::new(box_mesh([*edge; 3]))),
            Target::Box { size } => Some(Arc::new(box_mesh(*size))),
            Target::Sphere { diameter } => Some(Arc::new(sphere_mesh(0.5 * diameter))),
            Target::None => None,
        }
    }

    /// `k` points on the surface centred on `centre`; `seed` drives the samplers. Empty
    /// without a target.
    pub fn surface(&self, k: usize, centre: [f64; 3], seed: u64) -> Vec<[f64; 3]> {
        let offset = |p: [f64; 3]| [p[0] + centre[0], p[1] + centre[1], p[2] + centre[2]];
        let points = match self {
            Target::Cube { edge } => cube_surface(*edge, k, seed),
            Target::Box { size } => box_surface(*size, k, seed),
            Target::Sphere { diameter } => sphere_surface(0.5 * diameter, k),
            // The mesh's middle on `centre`.
            Target::Mesh(m) => {
                let b = m.mesh.bounds();
                let middle: [f64; 3] = std::array::from_fn(|i| 0.5 * (b.min[i] + b.max[i]));
                let points = m.mesh.sample(k, seed);
                points.into_iter().map(|p| std::array::from_fn(|i| p[i] - middle[i])).collect()
            }
            Target::None => Vec::new(),
        };
        points.into_iter().map(offset).collect()
    }
}

/// A box of edges `[w, d, h]` (x, y, z) standing on z = 0, centred on the z axis; faces wound
/// counter-clockwise seen from outside.
fn box_mesh([w, d, h]: [f64; 3]) -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            let pick = |bit: usize, a: f64, b: f64| if i & bit == 0 { a } else { b };
            [pick(1, -w / 2.0, w / 2.0), pick(2, -d / 2.0, d / 2.0), pick(4, 0.0, h)]
        })
        .collect();
    let quads =
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles = quads.iter().flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]]).collect();
    Mesh { vertices, triangles }
}

/// A sphere of `radius` resting on z = 0: a 24 x 12 latitude-longitude mesh.
fn sphere_mesh(radius: f64) -> Mesh {
    const RINGS: u32 = 12;
    const SEGMENTS: u32 = 24;
    let mut vertices = vec![[0.0, 0.0, 0.0], [0.0, 0.0, 2.0 * radius]];
    for ring in 1..RINGS {
        let polar = std::f64::consts::PI * ring as f64 / RINGS as f64;
        for segment in 0..SEGMENTS {
            let azimuth = std::f64::consts::TAU * segment as f64 / SEGMENTS as f64;
            let (s, c) = polar.sin_cos();
            vertices.push([
                radius * s * azimuth.cos(),
                radius * s * azimuth.sin(),
                radius * (1.0 - c),
            ]);
        }
    }
    let at = |ring: u32, segment: u32| 2 + (ring - 1) * SEGMENTS + segment % SEGMENTS;
    let mut triangles = Vec::new();
    for segment in 0..SEGMENTS {
        triangles.push([0, at(1, segment + 1), at(1, segment)]);
        triangles.push([1, at(RINGS - 1, segment), at(RINGS - 1, segment + 1)]);
        for ring in 1..RINGS - 1 {
            let (a, b) = (at(ring, segment), at(ring, segment + 1));
            let (c, d) = (at(ring + 1, segment), at(ring + 1, segment + 1));
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    Mesh { vertices, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_from_their_short_form() {
        assert_eq!("cube:0.5".parse(), Ok(Target::Cube { edge: 0.5 }));
        assert_eq!("box:1, 0.5,2".parse(), Ok(Target::Box { size: [1.0, 0.5, 2.0] }));
        assert_eq!("sphere:0.3".parse(), Ok(Target::Sphere { diameter: 0.3 }));
        assert_eq!("none".parse(), Ok(Target::None));
        assert!("cube:-1".parse::<Target>().unwrap_err().contains("positive"));
        assert!("chair".parse::<Target>().unwrap_err().contains("unknown target 'chair'"));
        assert!("box:1,2".parse::<Target>().is_err());
    }

    #[test]
    fn models_have_the_targets_area_and_stand_on_the_ground() {
        let cube = Target::Cube { edge: 0.5 }.model().unwrap();
        assert!((cube.area() - 1.5).abs() < 1e-12);
        let sphere = Target::Sphere { diameter: 1.0 }.model().unwrap();
        assert!((sphere.area() - std::f64::consts::PI).abs() < 0.05, "{}", sphere.area());
        for mesh in [cube, sphere, Target::Box { size: [1.0, 0.5, 2.0] }.model().unwrap()] {
            let b = mesh.bounds();
            assert!(b.min[2].abs() < 1e-12 && (b.min[0] + b.max[0]).abs() < 1e-12, "{b:?}");
            // Outward normals: a sample's normal points away from the middle.
            let middle = [0.0, 0.0, 0.5 * b.max[2]];
            for (p, n) in mesh.sample_with_normals(50, 1) {
                let out: f64 = (0..3).map(|i| (p[i] - middle[i]) * n[i]).sum();
                assert!(out > 0.0, "{p:?} {n:?}");
            }
        }
        assert!(Target::None.model().is_none());
    }
}
