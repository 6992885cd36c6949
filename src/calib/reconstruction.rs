//! The mixture as the reconstructed target: mapped into the vehicle frame (the mean of the
//! reference views' poses puts it where the reference sees it; the mixture itself floats),
//! with the target's shape fitted to each target standing on the reference's ground.

use nalgebra::{Point3, Vector3};

use super::average::average;
use super::result::Reconstruction;
use crate::jrmpc::Registration;
use crate::plane::Plane;
use crate::se3::Pose;
use crate::targets::{Target, fit_targets};

pub(super) fn reconstruct(
    registration: &Registration,
    reference_views: &[usize],
    ground: Option<Plane>,
    target: &Target,
) -> Reconstruction {
    let mix = &registration.mixture;
    let poses: Vec<Pose> = reference_views.iter().map(|&v| registration.poses[v]).collect();
    let to_vehicle = average(&poses).map_or_else(Pose::identity, |(m, _)| m).inverse();
    let means: Vec<Vector3<f64>> =
        mix.means.iter().map(|m| (to_vehicle * Point3::from(*m)).coords).collect();
    let ground = ground.map(|g| (g.normal, g.offset));
    Reconstruction {
        means: means.iter().map(|m| [m.x, m.y, m.z]).collect(),
        sigmas: mix.variances.iter().map(|v| v.sqrt()).collect(),
        priors: mix.priors.clone(),
        fits: fit_targets(target, &means, &mix.priors, ground),
        placements: Vec::new(),
    }
}
