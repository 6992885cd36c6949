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
use crate::io::mesh::{Mesh, parse_mesh};

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
    /// found from the data ([`place`]).
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
}
