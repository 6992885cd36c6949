//! `cad`'s registration (GMMCalib's CADCalib): every sensor onto fixed components sampled on
//! each copy of the target's model placed in the reference's points (`placed`).

use nalgebra::{Point3, Vector3};

use super::CalibError;
use super::placed::mesh_size;
use super::views::Views;
use crate::cad::{self, CadError, CadIteration, CadModel, CadViews, Copies};
use crate::jrmpc::{Control, IterationStats, Mixture, Registration};
use crate::mesh::Mesh;
use crate::se3::Pose;
use crate::targets::PlaceSettings;

/// One view's points as `cad` takes them: near each placed copy, and on the ground.
struct NearPlacements {
    by_copy: Vec<Vec<[f32; 3]>>,
    ground: Vec<[f32; 3]>,
}

/// `cad`'s registration: every sensor onto fixed components sampled on each placed copy of
/// the target's model (about 1.75 components per point of the median view, as CADCalib
/// sizes them), each view cut to the points near a placed copy and off the ground. As a
/// [`Registration`] (each view posed as its sensor, the mixture the fixed components) so
/// the rest of the pipeline takes it as it takes JRMPC's.
pub(super) fn register_cad(
    views: &Views,
    mut progress: impl FnMut(&CadIteration) -> Control,
) -> Result<Registration, CalibError> {
    let settings = views.stages.cad.clone().unwrap_or_default();
    let mesh = views.settings.target.model().ok_or(CalibError::NoTargetModel)?;
    if views.placements.is_empty() {
        return Err(CalibError::TargetNotFound(views.settings.target.label()));
    }
    // One cad view per (view, copy): the copy the points lie near.
    let near = near_placements(views, &mesh);
    let mut sizes: Vec<usize> = near.iter().map(|n| n.by_copy.iter().map(Vec::len).sum()).collect();
    sizes.sort_unstable();
    let copies = views.placements.len();
    let per_copy = (1.75 * sizes[sizes.len() / 2] as f64 / copies as f64).ceil().max(50.0) as usize;
    let mut samples: Vec<([f64; 3], [f64; 3])> = Vec::with_capacity(per_copy * copies);
    let mut copy_of_centre = Vec::with_capacity(per_copy * copies);
    for (c, placed) in views.placements.iter().enumerate() {
        let seed = views.settings.seed.wrapping_add(c as u64);
        for (p, n) in mesh.sample_with_normals(per_copy, seed) {
            let q = placed.pose * Point3::from(p);
            let m = placed.pose.rotation * Vector3::from(n);
            samples.push(([q.x, q.y, q.z], [m.x, m.y, m.z]));
            copy_of_centre.push(c);
        }
    }
    let model = CadModel::from_samples(&samples, settings.a_max);
    let (mut clouds, mut sensor_of_view, mut copy_of_view) = (Vec::new(), Vec::new(), Vec::new());
    for (view, n) in views.views.iter().zip(&near) {
        for (c, points) in n.by_copy.iter().enumerate() {
            clouds.push(points.as_slice());
            sensor_of_view.push(view.sensor);
            copy_of_view.push(c);
        }
    }
    let ground_lists: Vec<&[[f32; 3]]> = near.iter().map(|n| n.ground.as_slice()).collect();
    let ground_sensors: Vec<usize> = views.views.iter().map(|v| v.sensor).collect();
    let ground = views.ground.map(|g| cad::Ground {
        normal: g.normal.into(),
        offset: g.offset,
        points: &ground_lists,
        sensor_of: &ground_sensors,
    });
    let input =
        CadViews { points: &clouds, sensor_of: &sensor_of_view, sensors: views.sensors.len() };
    let reg = cad::register(
        &input,
        &model,
        Some(&Copies {
            of_centre: &copy_of_centre,
            of_view: &copy_of_view,
            fixed_sensor: views.reference,
            below_sigma: 0.1 * mesh_size(&mesh),
        }),
        ground.as_ref(),
        &settings,
        &mut progress,
    )
    .map_err(|e| match e {
        CadError::NoPoints { sensor } => CalibError::NoPointsInRoi(views.sensors[sensor].clone()),
        other => CalibError::StageFailed(format!("cad: {other}")),
    })?;
    // The mixture is the model where the data put its copies.
    let means: Vec<Vector3<f64>> = model
        .centres
        .iter()
        .zip(&copy_of_centre)
        .map(|(m, &c)| reg.copies[c].transform_point(&(*m).into()).coords)
        .collect();
    let k = means.len();
    Ok(Registration {
        poses: views.views.iter().map(|v| reg.poses[v.sensor]).collect(),
        mixture: Mixture {
            means,
            variances: vec![reg.sigma * reg.sigma; k],
            priors: vec![1.0 / k as f64; k],
        },
        iterations: reg.iterations,
        converged: reg.converged,
        cancelled: reg.cancelled,
        unsupported: Vec::new(),
        history: reg
            .history
            .iter()
            .map(|h| IterationStats { mean_sigma: h.sigma, max_change: h.max_change, terms: 0 })
            .collect(),
    })
}

/// Each view's points within a tenth of the model's size (at least 10 cm) of a placed
/// copy's bounding box, and off the ground, per copy (the first copy whose box holds a
/// point takes it); and its points on the ground: what `cad` registers.
fn near_placements(views: &Views, mesh: &Mesh) -> Vec<NearPlacements> {
    let b = mesh.bounds();
    let margin = (0.1 * mesh_size(mesh)).max(0.1);
    let ground_band = PlaceSettings::default().ground_band;
    let inverse: Vec<Pose> = views.placements.iter().map(|p| p.pose.inverse()).collect();
    views
        .views
        .iter()
        .map(|v| {
            let (mut by_copy, mut ground) = (vec![Vec::new(); inverse.len()], Vec::new());
            for p in &v.cloud.points {
                let x = Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                if views.ground.is_some_and(|g| g.distance(&x.coords).abs() <= ground_band) {
                    ground.push(*p);
                    continue;
                }
                let near = inverse.iter().position(|t| {
                    let q = t * x;
                    (0..3).all(|i| q[i] >= b.min[i] - margin && q[i] <= b.max[i] + margin)
                });
                if let Some(c) = near {
                    by_copy[c].push(*p);
                }
            }
            NearPlacements { by_copy, ground }
        })
        .collect()
}
