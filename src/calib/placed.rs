//! Where copies of the target's model stand in the reference's points, and the region of
//! interest around them when the user gave none. `cad`'s registration onto them is
//! `cad_registration`'s.

use nalgebra::{Point3, Vector3};

use super::CalibError;
use super::settings::Stages;
use crate::cloud::Aabb;
use crate::mesh::Mesh;
use crate::plane::Plane;
use crate::targets::{ModelCloud, PlaceSettings, Placement, Target};

/// Where the target's model stands in the reference's views (`reference`: each view's points,
/// vehicle frame), on its ground
/// (or, without one, on the vehicle's z = 0 plane): for a CAD-model target, and for `cad` with
/// any target; empty otherwise. A model larger than the region of interest cannot be in it.
pub(super) fn place_targets(
    target: &Target,
    stages: &Stages,
    reference: &[&[[f32; 3]]],
    ground: Option<&Plane>,
    roi: &Aabb,
) -> Result<Vec<Placement>, CalibError> {
    if !(matches!(target, Target::Mesh(_)) || stages.cad.is_some()) {
        return Ok(Vec::new());
    }
    let Some(mesh) = target.model() else { return Err(CalibError::NoTargetModel) };
    let size = target.size().unwrap_or(0.0);
    let roi_size = (0..3).map(|i| roi.max[i] - roi.min[i]).fold(0.0, f64::max);
    if size > roi_size {
        let target = target.label();
        return Err(CalibError::TargetLargerThanRoi { target, size, roi: roi_size });
    }
    Ok(find_targets(&mesh, reference, ground))
}

/// Every copy of `mesh` standing in the reference's views' points (on `ground`, else on the
/// vehicle's z = 0 plane). The views are joined only here, where a model is to be placed.
fn find_targets(mesh: &Mesh, reference: &[&[[f32; 3]]], ground: Option<&Plane>) -> Vec<Placement> {
    let settings = PlaceSettings::default();
    let Some(model) = ModelCloud::new(mesh, &settings) else { return Vec::new() };
    let level = Plane { normal: Vector3::z(), offset: 0.0 };
    crate::targets::place(&model, &reference.concat(), ground.unwrap_or(&level), &settings)
}

/// Without a ROI from the user, a target of known shape found standing in the reference's
/// points (every copy, as `cad` places them) gives the region: their boxes grown by a metre
/// (at least the target's size) across and half a metre above and below, within the overlap.
/// JRMPC and the refinement then see the targets and the ground around them, not tens of
/// metres of mostly ground (the paper twin's full scans: an overlap of 77 m x 24 m, where the
/// targets are a handful of the verdict's sampled points). `None` when nothing is found; else
/// the region and the number of copies found.
pub(super) fn roi_around_targets(
    target: &Target,
    reference: &[&[[f32; 3]]],
    ground: Option<&Plane>,
    overlap: &Aabb,
) -> Option<(Aabb, usize)> {
    let mesh = target.model()?;
    let placements = find_targets(&mesh, reference, ground);
    if placements.is_empty() {
        return None;
    }
    let b = mesh.bounds();
    let corners = placements.iter().flat_map(|p| {
        (0..8).map(move |i| {
            let c = Point3::new(
                if i & 1 == 0 { b.min[0] } else { b.max[0] },
                if i & 2 == 0 { b.min[1] } else { b.max[1] },
                if i & 4 == 0 { b.min[2] } else { b.max[2] },
            );
            p.pose * c
        })
    });
    let (mut min, mut max) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
    for c in corners {
        min = min.inf(&c.coords);
        max = max.sup(&c.coords);
    }
    let across = mesh_size(&mesh).max(1.0);
    let grow = Vector3::new(across, across, 0.5);
    let (lo, hi) = (min - grow, max + grow);
    let clip = |i: usize| (lo[i].max(overlap.min[i]), hi[i].min(overlap.max[i]));
    let [(x0, x1), (y0, y1), (z0, z1)] = [0, 1, 2].map(clip);
    (x0 < x1 && y0 < y1 && z0 < z1)
        .then(|| (Aabb::new([x0, y0, z0], [x1, y1, z1]), placements.len()))
}

/// The model's largest extent (m).
pub(super) fn mesh_size(mesh: &Mesh) -> f64 {
    let b = mesh.bounds();
    (0..3).map(|i| b.max[i] - b.min[i]).fold(0.0, f64::max)
}
