//! Finding each frame's planes on the merged cloud of every sensor (the reference's ground,
//! and the faces of the clusters standing on it), and which points belong to which plane.

use std::collections::HashMap;

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::{FramePlane, Observation, PlaneSettings};
use crate::cloud::bounds;
use crate::plane::{Plane, principal_axes};

/// Finds one frame's planes among `points` (sensor, vehicle-frame position) on the
/// reference's `ground`, where points up to `above_ground` (m) above it may still be ground,
/// and appends them and the points assigned to them.
pub(super) fn frame_observations(
    points: &[(usize, Vector3<f64>)],
    ground: &Plane,
    above_ground: f64,
    settings: &PlaneSettings,
    seed: u64,
    planes: &mut Vec<FramePlane>,
    observations: &mut Vec<Observation>,
) {
    let mut rng = Pcg64::seed_from_u64(seed);
    // Clusters above the reference's ground, and their planes.
    let above: Vec<usize> =
        (0..points.len()).filter(|&i| ground.distance(&points[i].1) > above_ground).collect();
    let mut cluster_planes: Vec<(Vector3<f64>, Vector3<f64>, Vec<FramePlane>)> = Vec::new();
    let margin = Vector3::repeat(2.0 * settings.assign_distance);
    for cluster in clusters(points, &above, settings.cluster_gap) {
        let members: Vec<Vector3<f64>> = cluster.iter().map(|&i| points[i].1).collect();
        let mut found = sequential_ransac(&members, settings, &mut rng);
        refit_away_from_edges(&members, &mut found, settings);
        if found.is_empty() {
            continue;
        }
        let (lo, hi) = bounds(&members);
        cluster_planes.push((lo - margin, hi + margin, found));
    }
    let inside = |p: &Vector3<f64>, lo: &Vector3<f64>, hi: &Vector3<f64>| {
        (0..3).all(|i| p[i] >= lo[i] && p[i] <= hi[i])
    };
    // The ground, refitted to this frame's points near it and away from the clusters (the
    // foot of a face would tilt it).
    let near: Vec<Vector3<f64>> = points
        .iter()
        .map(|(_, p)| *p)
        .filter(|p| ground.distance(p).abs() <= settings.assign_distance)
        .filter(|p| !cluster_planes.iter().any(|(lo, hi, _)| inside(p, lo, hi)))
        .collect();
    let frame_ground = fit_plane(&near).unwrap_or_else(|| {
        let centre = near.first().map_or_else(Vector3::zeros, |p| ground.project(p));
        FramePlane { normal: ground.normal, centre, offset: ground.distance(&centre) }
    });
    // Assign: nearest candidate plane within reach, none other near.
    let mut local: Vec<FramePlane> = vec![frame_ground];
    for (_, _, found) in &cluster_planes {
        local.extend(found.iter().copied());
    }
    let mut assigned: Vec<(usize, usize, Vector3<f64>)> = Vec::new();
    let mut candidates: Vec<(f64, usize)> = Vec::new();
    for (s, p) in points {
        candidates.clear();
        candidates.push((frame_ground.distance(p).abs(), 0));
        let mut index = 1;
        for (lo, hi, found) in &cluster_planes {
            let near_cluster = inside(p, lo, hi);
            for plane in found {
                if near_cluster {
                    candidates.push((plane.distance(p).abs(), index));
                }
                index += 1;
            }
        }
        candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (d, k) = candidates[0];
        let second = candidates.get(1).map_or(f64::INFINITY, |c| c.0);
        if d <= settings.assign_distance && second > settings.edge_distance {
            assigned.push((*s, k, *p));
        }
    }
    // Keep the planes that at least two sensors see.
    let mut counts: HashMap<(usize, usize), usize> = HashMap::new();
    assigned.iter().for_each(|a| *counts.entry((a.1, a.0)).or_default() += 1);
    let mut seen_by = vec![0; local.len()];
    for (&(k, _), &n) in &counts {
        if n >= settings.min_sensor_points {
            seen_by[k] += 1;
        }
    }
    let keep: Vec<bool> = seen_by.iter().map(|&sensors| sensors >= 2).collect();
    let mut index = vec![usize::MAX; local.len()];
    for (k, plane) in local.iter().enumerate() {
        if keep[k] {
            index[k] = planes.len();
            planes.push(*plane);
        }
    }
    observations.extend(
        assigned.into_iter().filter(|a| keep[a.1]).map(|(sensor, k, point)| Observation {
            sensor,
            plane: index[k],
            point,
        }),
    );
}

/// Least-squares plane through `points` (normal: smallest principal direction), `None` with
/// fewer than 3. The normal points to +z when it has a z component, else away from the origin.
fn fit_plane(points: &[Vector3<f64>]) -> Option<FramePlane> {
    if points.len() < 3 {
        return None;
    }
    let (centre, eigen) = principal_axes(points)?;
    let k = eigen.eigenvalues.imin();
    let mut normal: Vector3<f64> = eigen.eigenvectors.column(k).into_owned();
    if normal.z < -1e-3 || (normal.z.abs() <= 1e-3 && normal.dot(&centre) > 0.0) {
        normal = -normal;
    }
    Some(FramePlane { normal, centre, offset: 0.0 })
}

/// Up to `max_planes_per_cluster` planes among `points`, best first, each refitted to its
/// inliers; stops when the best plane has fewer than `min_plane_points` inliers.
fn sequential_ransac(
    points: &[Vector3<f64>],
    settings: &PlaneSettings,
    rng: &mut Pcg64,
) -> Vec<FramePlane> {
    const TRIALS: usize = 200;
    const BLOCK: usize = 256;
    let mut left: Vec<Vector3<f64>> = points.to_vec();
    let mut found: Vec<FramePlane> = Vec::new();
    let within =
        |plane: &FramePlane, p: &Vector3<f64>| plane.distance(p).abs() <= settings.inlier_distance;
    while found.len() < settings.max_planes_per_cluster && left.len() >= settings.min_plane_points {
        let mut best: Option<(FramePlane, usize)> = None;
        for _ in 0..TRIALS {
            let [a, b, c] = [(); 3].map(|_| left[rng.random_range(0..left.len())]);
            let Some(normal) = (b - a).cross(&(c - a)).try_normalize(1e-9) else {
                continue;
            };
            let plane = FramePlane { normal, centre: a, offset: 0.0 };
            // Counted in blocks, stopping once the points left cannot lift the score above the
            // best's: most random planes are poor, and such a plane would not be taken anyway.
            let needed = best.map_or(0, |(_, s)| s + 1);
            let mut score = 0;
            let mut unseen = left.len();
            for block in left.chunks(BLOCK) {
                score += block.iter().filter(|p| within(&plane, p)).count();
                unseen -= block.len();
                if score + unseen < needed {
                    break;
                }
            }
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((plane, score));
            }
        }
        let Some((plane, score)) = best else { break };
        if score < settings.min_plane_points {
            break;
        }
        // Two least-squares refits on the inliers.
        let mut plane = plane;
        for _ in 0..2 {
            let inliers: Vec<Vector3<f64>> =
                left.iter().copied().filter(|p| within(&plane, p)).collect();
            plane = fit_plane(&inliers).unwrap_or(plane);
        }
        let (inliers, rest): (Vec<_>, Vec<_>) = left.iter().partition(|p| within(&plane, p));
        if inliers.len() < settings.min_plane_points {
            break;
        }
        // The leftovers of a plane already found (noise tails) are not a new plane.
        let duplicate = found.iter().any(|f| {
            f.normal.dot(&plane.normal).abs() > 10f64.to_radians().cos()
                && f.distance(&plane.centre).abs() < 3.0 * settings.inlier_distance
        });
        left = rest;
        if !duplicate {
            found.push(plane);
        }
    }
    found
}

/// Refits each plane to the points near it and away from every other plane: the strip of a
/// neighbouring face along an edge, taken as inliers by RANSAC, tilts a face.
fn refit_away_from_edges(
    points: &[Vector3<f64>],
    planes: &mut [FramePlane],
    settings: &PlaneSettings,
) {
    for _ in 0..2 {
        let current = planes.to_vec();
        for (k, plane) in planes.iter_mut().enumerate() {
            let own: Vec<Vector3<f64>> = points
                .iter()
                .filter(|p| current[k].distance(p).abs() <= settings.inlier_distance)
                .filter(|p| {
                    current.iter().enumerate().all(|(j, other)| {
                        j == k || other.distance(p).abs() > settings.edge_distance
                    })
                })
                .copied()
                .collect();
            if own.len() >= 3 {
                *plane = fit_plane(&own).unwrap_or(*plane);
            }
        }
    }
}

/// Groups of `indices` (into `points`) joined through occupied grid cells of size `gap`
/// (26-neighbourhood), each in the order its cells are reached from its smallest cell, a
/// cell's points in `indices`' order.
pub(super) fn clusters(
    points: &[(usize, Vector3<f64>)],
    indices: &[usize],
    gap: f64,
) -> Vec<Vec<usize>> {
    let cell = |p: &Vector3<f64>| [0, 1, 2].map(|i| (p[i] / gap).floor() as i64);
    // The occupied cells, sorted, each with its run of `members` (a stable sort keeps
    // `indices`' order within a cell); no hashing of every neighbour (a fifth of the plane
    // adjustment on a road scene).
    let mut members: Vec<([i64; 3], usize)> =
        indices.iter().map(|&i| (cell(&points[i].1), i)).collect();
    members.sort_by_key(|m| m.0);
    let mut cells: Vec<([i64; 3], usize, usize)> = Vec::new();
    for (at, (key, _)) in members.iter().enumerate() {
        match cells.last_mut() {
            Some((last, _, end)) if last == key => *end = at + 1,
            _ => cells.push((*key, at, at + 1)),
        }
    }
    // The cells at [x + dx, y + dy, z - 1..=z + 1] lie together in the sorted order, and where
    // they start grows with the cell's place in it: one walk through the cells per (dx, dy).
    let offsets: [[i64; 2]; 9] = std::array::from_fn(|o| [o as i64 / 3 - 1, o as i64 % 3 - 1]);
    let mut starts = vec![[0usize; 9]; cells.len()];
    for (o, [dx, dy]) in offsets.into_iter().enumerate() {
        let mut at = 0;
        for (c, (k, _, _)) in cells.iter().enumerate() {
            let key = [k[0] + dx, k[1] + dy, k[2] - 1];
            while at < cells.len() && cells[at].0 < key {
                at += 1;
            }
            starts[c][o] = at;
        }
    }
    let mut seen = vec![false; cells.len()];
    let mut groups = Vec::new();
    for first in 0..cells.len() {
        if seen[first] {
            continue;
        }
        seen[first] = true;
        let mut stack = vec![first];
        let mut group = Vec::new();
        while let Some(c) = stack.pop() {
            let (k, start, end) = cells[c];
            group.extend(members[start..end].iter().map(|m| m.1));
            for (&first, [dx, dy]) in starts[c].iter().zip(offsets) {
                let column = [k[0] + dx, k[1] + dy];
                let end = (first + 3).min(cells.len());
                for n in first..end {
                    if cells[n].0[..2] == column && cells[n].0[2] <= k[2] + 1 && !seen[n] {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
        groups.push(group);
    }
    groups
}
