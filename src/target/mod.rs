//! The calibration target: its shape ([`Target`]), the points on its surface that seed
//! JRMPC's mixture ([`Target::surface`]), and the fit of the shape to the reconstruction
//! ([`fit_targets`]), the plausibility check of a calibration.

mod fit;
mod sample;

pub use fit::{ShapeFit, fit_shape, fit_targets};
pub use sample::{cube_surface, sphere_surface};

/// The shape of the calibration target (m).
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// A cube of this edge: GMMCalib's target.
    Cube { edge: f64 },
    /// A sphere of this diameter.
    Sphere { diameter: f64 },
}

impl Default for Target {
    /// GMMCalib's target: a 0.5 m cube.
    fn default() -> Self {
        Target::Cube { edge: 0.5 }
    }
}

impl Target {
    /// The target, if its size is a positive finite number.
    pub fn checked(self) -> Result<Target, String> {
        let size = self.size();
        if size.is_finite() && size > 0.0 {
            Ok(self)
        } else {
            Err(format!("target size must be a positive number (m), got {size}"))
        }
    }

    /// `"cube"` or `"sphere"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Target::Cube { .. } => "cube",
            Target::Sphere { .. } => "sphere",
        }
    }

    /// The target's overall size (m): cube edge or sphere diameter.
    pub fn size(&self) -> f64 {
        match self {
            Target::Cube { edge } => *edge,
            Target::Sphere { diameter } => *diameter,
        }
    }

    /// `k` points on the surface centred on `centre`; `seed` drives the cube's sampler.
    pub fn surface(&self, k: usize, centre: [f64; 3], seed: u64) -> Vec<[f64; 3]> {
        let offset = |p: [f64; 3]| [p[0] + centre[0], p[1] + centre[1], p[2] + centre[2]];
        match self {
            Target::Cube { edge } => cube_surface(*edge, k, seed).into_iter().map(offset).collect(),
            Target::Sphere { diameter } => {
                sphere_surface(0.5 * diameter, k).into_iter().map(offset).collect()
            }
        }
    }
}
