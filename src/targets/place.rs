//! Where a CAD-model target stands: its pose in the vehicle frame found from the reference's
//! points, so that a user gives only the shape (GMMCalib's CADCalib needs the model placed by
//! hand).
//!
//! 1. The structure above the ground (up to the model's height) splits into groups separated
//!    by gaps; a group about the model's size is a candidate.
//! 2. For each candidate, the model stands upright on the ground at the group's centre, at
//!    every yaw in `yaw_step`s, and point-to-plane ICP (the group's points onto dense samples
//!    of the model, each with its face's normal) fits its pose from each start.
//! 3. A candidate whose best fit holds most of its points within the tolerance is a placement;
//!    several targets (the paper's three) give several.
//!
//! The model is assumed upright as the file gives it (z up) and is used as
//! [`Mesh::centred`] gives it: base centre at the origin.

use std::collections::HashMap;

use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};

use crate::icp::{FixedCloud, IcpSettings, Metric};
use crate::mesh::Mesh;
use crate::plane::Plane;
use crate::se3::Pose;

/// The placement search's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceSettings {
    /// Surface samples of the model the fit matches against.
    pub samples: usize,
    /// Yaw step of the starts (rad).
    pub yaw_step: f64,
    /// A data point within this distance (m) of the fitted model's surface is an inlier.
    pub tolerance: f64,
    /// A placement needs at least this share of its group's points as inliers.
    pub min_inliers: f64,
    /// Groups with fewer points are clutter.
    pub min_points: usize,
    /// Points within this height (m) of the ground are ground.
    pub ground_band: f64,
    /// Seed of the model's samples.
    pub seed: u64,
}

impl Default for PlaceSettings {
    fn default() -> Self {
        Self {
            samples: 4000,
            yaw_step: 20f64.to_radians(),
            tolerance: 0.03,
            min_inliers: 0.7,
            min_points: 30,
            ground_band: 0.05,
            seed: 0,
        }
    }
}

/// One placed copy of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// `T_vehicle_model`: maps the centred model's points into the vehicle frame.
    pub pose: Pose,
    /// The group's points fitted, and the share of them within the tolerance.
    pub points: usize,
    pub inliers: f64,
    /// RMS point-to-surface distance of the inliers (m).
    pub rms: f64,
}

/// The model's dense samples with their faces' normals, ready for ICP: the fixed cloud of
/// every fit.
pub struct ModelCloud {
    cloud: FixedCloud,
    /// Model height (m) and the radius of its footprint (m).
    height: f64,
    reach: f64,
}

impl ModelCloud {
    /// `None` when the model has no area.
    pub fn new(mesh: &Mesh, settings: &PlaceSettings) -> Option<Self> {
        let mesh = mesh.centred();
        let samples = mesh.sample_with_normals(settings.samples, settings.seed);
        if samples.len() < 3 {
            return None;
        }
        let points: Vec<[f32; 3]> = samples.iter().map(|(p, _)| p.map(|c| c as f32)).collect();
        let normal_of: HashMap<[u32; 3], Vector3<f64>> = points
            .iter()
            .zip(&samples)
            .map(|(p, (_, n))| (p.map(f32::to_bits), (*n).into()))
            .collect();
        let icp = icp_settings(settings);
        let mut cloud = FixedCloud::new(&points, Metric::PointToPlane, &icp).ok()?;
        // The faces' own normals: a thin slab's two sides would blur a neighbourhood's PCA.
        cloud.set_normals(|p| normal_of.get(&p.map(f32::to_bits)).copied());
        let b = mesh.bounds();
        let reach = 0.5 * (b.max[0] - b.min[0]).hypot(b.max[1] - b.min[1]);
        Some(Self { cloud, height: b.max[2] - b.min[2], reach })
    }

    /// Fits the model to `points` (vehicle frame) from `start` (`T_vehicle_model`).
    fn fit(
        &self,
        points: &[[f32; 3]],
        start: &Pose,
        settings: &PlaceSettings,
    ) -> Option<Placement> {
        let icp = icp_settings(settings);
        let aligned = self.cloud.align(points, &start.inverse(), &icp).ok()?;
        let model_from_data = aligned.target_from_source;
        let tree = self.cloud.tree();
        let normals = self.cloud.normals();
        let model = self.cloud.points();
        let (mut inliers, mut sum) = (0usize, 0.0);
        for p in points {
            let q = model_from_data * Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let Some(n) = tree.nearest([q.x, q.y, q.z]) else { continue };
            let s = model[n.index];
            let d = (q.coords - Vector3::new(s[0] as f64, s[1] as f64, s[2] as f64))
                .dot(&normals[n.index]);
            // The normal's distance only counts near the surface, not across a gap.
            if n.sq_distance.sqrt() <= 3.0 * settings.tolerance && d.abs() <= settings.tolerance {
                inliers += 1;
                sum += d * d;
            }
        }
        Some(Placement {
            pose: model_from_data.inverse(),
            points: points.len(),
            inliers: inliers as f64 / points.len().max(1) as f64,
            rms: (sum / inliers.max(1) as f64).sqrt(),
        })
    }
}

impl ModelCloud {
    /// The best of the fits of the model to `points` standing upright (`up`) on `base` at
    /// every yaw step: most inliers, then the smallest RMS.
    pub fn best_fit(
        &self,
        points: &[[f32; 3]],
        base: &Vector3<f64>,
        up: &Vector3<f64>,
        settings: &PlaceSettings,
    ) -> Option<Placement> {
        let tilt = UnitQuaternion::rotation_between(&Vector3::z(), up).unwrap_or_default();
        let axis = nalgebra::Unit::new_normalize(*up);
        let steps = (std::f64::consts::TAU / settings.yaw_step).round().max(1.0) as usize;
        (0..steps)
            .filter_map(|k| {
                let yaw = UnitQuaternion::from_axis_angle(&axis, k as f64 * settings.yaw_step);
                let start = Pose::from_parts(Translation3::from(*base), yaw * tilt);
                self.fit(points, &start, settings)
            })
            .max_by(|a, b| a.inliers.total_cmp(&b.inliers).then(b.rms.total_cmp(&a.rms)))
    }
}

fn icp_settings(settings: &PlaceSettings) -> IcpSettings {
    IcpSettings {
        max_correspondence_distance: 10.0 * settings.tolerance,
        max_iterations: 30,
        robust_scale: Some(settings.tolerance),
        ..IcpSettings::default()
    }
}

/// Every copy of the model found in `points` (the reference's, vehicle frame) standing on
/// `ground`, best first.
pub fn place(
    model: &ModelCloud,
    points: &[[f32; 3]],
    ground: &Plane,
    settings: &PlaceSettings,
) -> Vec<Placement> {
    let up = ground.normal;
    let above: Vec<[f32; 3]> = points
        .iter()
        .filter(|p| {
            let h = ground.distance(&Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            h > settings.ground_band && h < model.height + 0.2
        })
        .copied()
        .collect();
    let mut placements: Vec<Placement> = groups(&above, 0.5 * model.height.max(2.0 * model.reach))
        .into_iter()
        .filter(|g| g.len() >= settings.min_points)
        .filter_map(|group| {
            let members: Vec<[f32; 3]> = group.iter().map(|&i| above[i]).collect();
            let centre = members.iter().fold(Vector3::zeros(), |c, p| {
                c + Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
            }) / members.len() as f64;
            // Footprints much larger than the model's are walls, cars, other scenery.
            let spread = members
                .iter()
                .map(|p| {
                    let d = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) - centre;
                    (d - up * up.dot(&d)).norm()
                })
                .fold(0.0, f64::max);
            if spread > 2.0 * model.reach + 0.2 {
                return None;
            }
            // The base on the ground below the group's centre.
            let base = centre - up * ground.distance(&centre);
            model.best_fit(&members, &base, &up, settings)
        })
        .filter(|p| p.inliers >= settings.min_inliers)
        .collect();
    placements.sort_by(|a, b| b.inliers.total_cmp(&a.inliers));
    placements
}

/// Single-linkage groups of `points` joined by steps no longer than `gap`, on a hash grid of
/// cell `gap` (each point looks at its own and the 26 neighbouring cells).
pub(super) fn groups(points: &[[f32; 3]], gap: f64) -> Vec<Vec<usize>> {
    let key = |p: &[f32; 3]| p.map(|c| (c as f64 / gap).floor() as i64);
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        cells.entry(key(p)).or_default().push(i);
    }
    let mut group_of = vec![usize::MAX; points.len()];
    let mut groups = Vec::new();
    let gap2 = (gap * gap) as f32;
    for seed in 0..points.len() {
        if group_of[seed] != usize::MAX {
            continue;
        }
        let id = groups.len();
        group_of[seed] = id;
        let mut members = vec![seed];
        let mut next = 0;
        while next < members.len() {
            let a = points[members[next]];
            next += 1;
            let [x, y, z] = key(&a);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(cell) = cells.get(&[x + dx, y + dy, z + dz]) else { continue };
                        for &b in cell {
                            let q = points[b];
                            let d2 = (0..3).map(|i| (q[i] - a[i]).powi(2)).sum::<f32>();
                            if group_of[b] == usize::MAX && d2 <= gap2 {
                                group_of[b] = id;
                                members.push(b);
                            }
                        }
                    }
                }
            }
        }
        groups.push(members);
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::{Preset, shapes};

    #[test]
    fn finds_the_three_chairs_of_the_chair_twin() {
        let preset = Preset::paper_chair();
        let views = preset.simulate(1, 4);
        let reference = &views[0];
        let mount = preset.sensors[0].mount;
        let points: Vec<[f32; 3]> = reference
            .cloud
            .points
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .map(|p| {
                let q = mount * Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                [q.x as f32, q.y as f32, q.z as f32]
            })
            .filter(|p| preset.roi.contains(p.map(f64::from)))
            .collect();
        let settings = PlaceSettings::default();
        let model = ModelCloud::new(&shapes::chair(), &settings).unwrap();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let found = place(&model, &points, &ground, &settings);
        let truth: Vec<Pose> = preset.scene.meshes.iter().map(|m| m.pose).collect();
        assert_eq!(found.len(), truth.len(), "{found:?}");
        for t in &truth {
            let best = found
                .iter()
                .map(|p| {
                    (p.pose.inverse() * t).translation.vector.norm()
                        + (p.pose.inverse() * t).rotation.angle()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(best < 0.05, "chair at {t:?}: {found:?}");
        }
    }
}
