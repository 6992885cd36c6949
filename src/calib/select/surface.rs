//! One scan as a surface the selection score compares others against: thinned to voxel
//! centroids in the sensor's own frame, each point with its neighbourhood's normal, thickness
//! and reach, and a strided sample of query points weighted so that no one surface orientation
//! (the ground, on a road) outweighs the rest (normal-space balancing, Rusinkiewicz & Levoy
//! 2001). Everything here depends on the scan alone, never on a hypothesis, so every hypothesis
//! is scored against the same points.

use nalgebra::Vector3;

use super::SelectSettings;
use super::sight::Sight;
use crate::cloud::{Cloud, is_valid_point};
use crate::icp::KdTree;
use crate::icp::normals;

/// One scan prepared for scoring.
pub struct Surface {
    /// Voxel centroids (m, sensor frame).
    pub points: Vec<[f32; 3]>,
    pub tree: KdTree,
    /// Unit normal per point; `None` where the neighbourhood is a line, a point or too thick to
    /// be a surface (foliage): such a point is no surface to land on.
    pub normals: Vec<Option<Vector3<f64>>>,
    /// Per point, the neighbourhood's thickness (m, floored at the settings' noise floor): the
    /// noise and curvature a distance to this surface is measured against.
    pub noise: Vec<f32>,
    /// Per point, the distance to its farthest neighbour (m): how sparsely the surface is
    /// sampled there, so how far a point may lie beside it and still be on it.
    pub reach: Vec<f32>,
    /// Query points: indices into `points`, strided within each class.
    pub samples: Vec<usize>,
    /// Per sample, its class: 0 on the scan's dominant plane (the ground, mostly), 1 the rest
    /// (the structure). Each class counts half of a score, so the plane, which holds tilt and
    /// height, cannot outweigh the structure, which holds yaw and the shift along it.
    pub classes: Vec<u8>,
    /// Per sample, its normal-space weight (at most 1).
    pub weights: Vec<f64>,
    /// Per sample, its block (a cell of `block` m in the sensor's frame), numbered densely.
    pub blocks: Vec<u32>,
    pub block_count: usize,
    /// The farthest (m) a point may be from this scan's nearest point to land on it.
    gate: f64,
    /// The voxel edge (m) the scan was thinned to: the finest motion the score resolves.
    pub voxel: f64,
    /// What the scan saw through, from every return (not the thinned points): its rays are
    /// as dense as the sensor made them.
    pub sight: Sight,
}

impl Surface {
    /// The point of this surface a point `q` (this scan's frame) lands beside, and its
    /// normal: the nearest point, when `q` lies within twice its neighbourhood's reach (the
    /// surface's sampling there) and the neighbourhood is a surface.
    pub fn landing(&self, q: [f64; 3]) -> Option<(usize, Vector3<f64>)> {
        let near = self.tree.nearest_within(q, self.gate)?;
        let j = near.index;
        if near.sq_distance.sqrt() > 2.0 * self.reach[j] as f64 {
            return None;
        }
        Some((j, self.normals[j]?))
    }

    /// `None` when the scan holds too few valid points to say anything.
    pub fn new(scan: &[[f32; 3]], settings: &SelectSettings) -> Option<Self> {
        let valid: Vec<[f32; 3]> = scan.iter().copied().filter(is_valid_point).collect();
        if valid.len() < settings.neighbours {
            return None;
        }
        let sight = Sight::new(&valid);
        let cloud = Cloud::from_points(valid);
        // A dense scan is thinned with a larger voxel until it fits: the score needs the
        // surfaces' shape, not every return.
        let mut voxel = settings.voxel;
        let mut points = cloud.voxel_downsampled(voxel).points;
        while points.len() > settings.max_points {
            // A surface's voxels go as the inverse square of their edge: one guess, then
            // small steps.
            let ratio = (points.len() as f64 / settings.max_points as f64).sqrt();
            voxel *= ratio.max(1.1);
            points = cloud.voxel_downsampled(voxel).points;
        }
        if points.len() < settings.neighbours {
            return None;
        }
        let tree = KdTree::new(&points);
        let hoods = normals::neighbourhoods(&points, &tree, settings.neighbours);
        let mut normals = vec![None; points.len()];
        let mut noise = vec![settings.min_noise as f32; points.len()];
        let mut reach = vec![voxel as f32; points.len()];
        for (i, hood) in hoods.iter().enumerate() {
            let Some(hood) = hood else { continue };
            reach[i] = hood.reach.max(voxel) as f32;
            let Some((variances, least)) = hood.shape else { continue };
            let thickness = variances[0].max(0.0).sqrt();
            // A line (one scan ring) has no normal; a thick cloud is no surface.
            let flat = variances[1].max(0.0).sqrt() >= settings.min_extent;
            if flat && thickness <= settings.max_noise {
                normals[i] = Some(least);
                noise[i] = thickness.max(settings.min_noise) as f32;
            }
        }
        // Wide enough for a crowned road's slope over the scan, yet below a target's top.
        let on_plane = dominant_plane(&points, &normals, (2.0 * voxel).max(0.3));
        let (mut samples, mut classes) = (Vec::new(), Vec::new());
        for class in [0u8, 1] {
            let members: Vec<usize> =
                (0..points.len()).filter(|&i| u8::from(!on_plane[i]) == class).collect();
            let stride = members.len().div_ceil((settings.samples / 2).max(1)).max(1);
            let picked = members.iter().step_by(stride);
            classes.extend(picked.clone().map(|_| class));
            samples.extend(picked);
        }
        let weights = balance(&samples, &normals);
        let (blocks, block_count) = blocks(&samples, &points, settings.block);
        Some(Self {
            points,
            tree,
            normals,
            noise,
            reach,
            samples,
            classes,
            weights,
            blocks,
            block_count,
            gate: settings.max_gate,
            voxel,
            sight,
        })
    }
}

/// Which points lie on the scan's dominant plane: of planes through a strided sample of
/// points along their normals, the one most points lie on (within `band` m, their own normal
/// within 20 deg of its); then every point within `band` of it whose normal agrees or which has
/// none (far ground seen as separate rings has no normal, yet holds only what the ground
/// holds: tilt and height). Deterministic; all false when no point has a normal.
fn dominant_plane(points: &[[f32; 3]], normals: &[Option<Vector3<f64>>], band: f64) -> Vec<bool> {
    const CANDIDATES: usize = 200;
    let parallel = 20f64.to_radians().cos();
    let at = |i: usize| Vector3::from(points[i].map(f64::from));
    let with_normal: Vec<usize> = (0..points.len()).filter(|&i| normals[i].is_some()).collect();
    let near = |c: usize, i: usize| -> Option<bool> {
        let n = normals[c]?;
        let within = n.dot(&(at(i) - at(c))).abs() <= band;
        Some(within && normals[i].is_none_or(|m| n.dot(&m).abs() >= parallel))
    };
    let on = |c: usize, i: usize| normals[i].is_some() && near(c, i) == Some(true);
    let stride = with_normal.len().div_ceil(CANDIDATES).max(1);
    // Counted on a strided subset, then the winner labels every point.
    let check: Vec<usize> =
        with_normal.iter().copied().step_by(stride.div_ceil(4).max(1)).collect();
    let best = with_normal
        .iter()
        .copied()
        .step_by(stride)
        .max_by_key(|&c| (check.iter().filter(|&&i| on(c, i)).count(), std::cmp::Reverse(c)));
    match best {
        Some(c) => (0..points.len()).map(|i| near(c, i) == Some(true)).collect(),
        None => vec![false; points.len()],
    }
}

/// Normal-space weights: samples binned by their normal's direction (sign-free), each bin's
/// total weight capped at an equal share of the samples, so a dominant orientation counts no
/// more than any other well-sampled one; samples without a normal form a bin of their own.
fn balance(samples: &[usize], normals: &[Option<Vector3<f64>>]) -> Vec<f64> {
    const BINS: usize = 22;
    let bin = |n: &Option<Vector3<f64>>| -> usize {
        let Some(n) = n else { return BINS - 1 };
        let n = if n.z < 0.0 { -n } else { *n };
        let polar = n.z.clamp(-1.0, 1.0).acos().to_degrees();
        let azimuth = n.y.atan2(n.x).to_degrees().rem_euclid(360.0);
        if polar < 22.5 {
            0
        } else if polar < 45.0 {
            1 + (azimuth / 45.0) as usize % 8
        } else if polar < 67.5 {
            9 + (azimuth / 45.0) as usize % 8
        } else {
            // Near the horizon n and -n look alike: fold the azimuth onto half a turn.
            17 + (azimuth.rem_euclid(180.0) / 45.0) as usize % 4
        }
    };
    let bins: Vec<usize> = samples.iter().map(|&i| bin(&normals[i])).collect();
    let mut counts = [0usize; BINS];
    bins.iter().for_each(|&b| counts[b] += 1);
    let occupied = counts.iter().filter(|&&c| c > 0).count().max(1);
    let cap = samples.len() as f64 / occupied as f64;
    bins.iter().map(|&b| (counts[b] as f64).min(cap) / counts[b] as f64).collect()
}

/// Each sample's block (a cube of edge `edge` m), numbered densely in order of first sight.
fn blocks(samples: &[usize], points: &[[f32; 3]], edge: f64) -> (Vec<u32>, usize) {
    let mut numbers = std::collections::HashMap::new();
    let blocks = samples
        .iter()
        .map(|&i| {
            let key = points[i].map(|c| (c as f64 / edge).floor() as i64);
            let next = numbers.len() as u32;
            *numbers.entry(key).or_insert(next)
        })
        .collect();
    (blocks, numbers.len())
}
