//! Joint plane adjustment: the last word on `gmm`'s corrections (issue 6).
//!
//! The per-frame GICP matches each point to a neighbourhood of the reference's; on 0.5 m cubes
//! many neighbourhoods straddle an edge, and those matches bias the yaw (README, "Where the bias
//! comes from"). Planar targets have a maximum-likelihood estimator that needs no neighbours:
//!
//! 1. every sensor's views go into the vehicle frame with its averaged refined correction;
//! 2. per frame, the planes are found on the merged cloud: the reference's ground, and the
//!    planes of each cluster of points above it (sequential RANSAC, least-squares refits);
//! 3. each point is assigned to the nearest plane of its cluster (or the ground) within a few
//!    noise widths; points near two planes (an edge) or near none are dropped;
//! 4. Gauss-Newton over one 6-dof motion per non-reference sensor, shared by all its frames,
//!    and every plane's normal and offset, the reference fixed; residuals are point-to-plane
//!    distances with Cauchy weights;
//! 5. the covariance at the solution gives each sensor's [`Precision`].
//!
//! Planes are per frame, so a target that moves between frames costs nothing (for a static
//! scene the relative pose is as well determined: each plane compares the sensors' samples of
//! it). A motion beyond `max_departure` is not trusted and the refinement stays.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector, Matrix3, Point3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::average::robust_average;
use super::level::{Plane, principal_axes};
use crate::cloud::bounds;
use crate::se3::{Pose, rotation_about};

/// The plane adjustment's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneSettings {
    /// RANSAC inlier distance (m) when finding planes.
    pub inlier_distance: f64,
    /// Points farther than this (m) from every plane are left out.
    pub assign_distance: f64,
    /// Points within this distance (m) of a second plane of their cluster (an edge) are left
    /// out: about 3 times the range noise (2 cm measured worse on the twin, 4-5 cm no better).
    pub edge_distance: f64,
    /// Clusters above the ground: points closer than about this (m) join (grid cells).
    pub cluster_gap: f64,
    /// Fewest points that make a plane, and fewest per sensor for it to count.
    pub min_plane_points: usize,
    pub min_sensor_points: usize,
    /// Most planes per cluster.
    pub max_planes_per_cluster: usize,
    /// Cauchy scale (m) of the residuals: three times the range noise. Tighter scales and
    /// assignment cut the noise's tails unevenly and leave a yaw bias (twin: Cauchy 5 mm
    /// -0.015 deg); 3 cm beat 2 cm on 20 seeds x 5 (2 sensors 1.6 against 2.0 mm, 3 sensors
    /// 2.7 against 3.1 mm, median).
    pub robust_scale: f64,
    /// Gauss-Newton iterations (at most).
    pub iterations: usize,
    /// A sensor motion beyond this (rad, m) is rejected: the refinement stays.
    pub max_departure: (f64, f64),
    pub seed: u64,
}

impl Default for PlaneSettings {
    fn default() -> Self {
        Self {
            inlier_distance: 0.02,
            // Twin, 20 seeds x 1 (signed mean yaw / median): assign 3 cm, Cauchy 1 cm
            // -0.0104 / 0.0116 deg; 5 cm, 2 cm -0.0075 / 0.0094 deg; 5 cm, 3 cm -0.0068 /
            // 0.0091 deg; 8 cm, 3 cm -0.022 deg.
            assign_distance: 0.05,
            edge_distance: 0.03,
            cluster_gap: 0.15,
            min_plane_points: 30,
            min_sensor_points: 10,
            max_planes_per_cluster: 5,
            robust_scale: 0.03,
            iterations: 10,
            max_departure: (0.2f64.to_radians(), 0.02),
            seed: 0,
        }
    }
}

/// What the adjustment did for one non-reference sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Sensor index.
    pub sensor: usize,
    /// The motion found, applied on the left of every frame's correction when accepted.
    pub motion: Pose,
    /// Points of this sensor used (all frames).
    pub points: usize,
    pub accepted: bool,
    /// What the points allow: the spread of the motion's estimate.
    pub precision: Option<Precision>,
}

/// One-sigma uncertainty of a sensor's calibration as the plane adjustment measures it: the
/// covariance of its motion at the solution, from the point-to-plane residuals (see
/// `covariance`). That is the spread the point noise leaves (the twin's errors follow it;
/// README, "How precise"), not a bound on errors the plane model cannot see (a target that
/// moved, a wrong nominal beyond reach).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Precision {
    /// Rotation about the vehicle's x, y, z axes (rad).
    pub rotation: [f64; 3],
    /// The sensor's position along x, y, z (m).
    pub position: [f64; 3],
}

/// One point used: its sensor, its (frame-)plane, its position in the vehicle frame.
struct Observation {
    sensor: usize,
    plane: usize,
    point: Vector3<f64>,
}

/// A plane as normal and offset at a fixed centre: `normal . (p - centre) + offset = 0`
/// (the centre keeps the normal and offset uncorrelated at 10 m from the origin).
#[derive(Clone, Copy, Debug)]
struct FramePlane {
    normal: Vector3<f64>,
    centre: Vector3<f64>,
    offset: f64,
}

impl FramePlane {
    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(&(p - self.centre)) + self.offset
    }
}

/// Adjusts `corrections` (per sensor, per frame pair `(reference view, sensor view)`, as
/// the refinement leaves them) by one motion per non-reference sensor. `origins` are the
/// sensors' positions in the clouds' frame (for [`Precision::position`]); `ground` is the
/// reference's ground plane in the vehicle frame; without it nothing is done.
pub fn adjust(
    clouds: &[&[[f32; 3]]],
    origins: &[Vector3<f64>],
    pairs: &[Vec<(usize, usize)>],
    reference: usize,
    corrections: &mut [super::FrameCorrections],
    ground: Option<Plane>,
    settings: &PlaneSettings,
) -> Vec<Outcome> {
    let Some(ground) = ground else {
        return Vec::new();
    };
    let sensors = pairs.len();
    // Each sensor's calibration is constant: its frames go in with the averaged correction.
    let means: Vec<Option<Pose>> = (0..sensors)
        .map(|s| {
            if s == reference {
                return Some(Pose::identity());
            }
            let poses: Vec<Pose> = corrections[s].iter().map(|(_, c)| *c).collect();
            robust_average(&poses).map(|(m, _, _)| m)
        })
        .collect();
    // Frames by the reference's view: (sensor, view) of every sensor that has it.
    let mut frames: Vec<(usize, Vec<(usize, usize)>)> = Vec::new();
    for (s, list) in pairs.iter().enumerate() {
        if s == reference || means[s].is_none() {
            continue;
        }
        for &(r, v) in list {
            match frames.iter_mut().find(|(rv, _)| *rv == r) {
                Some((_, members)) => members.push((s, v)),
                None => frames.push((r, vec![(reference, r), (s, v)])),
            }
        }
    }
    let mut planes: Vec<FramePlane> = Vec::new();
    let mut observations: Vec<Observation> = Vec::new();
    for (f, (_, members)) in frames.iter().enumerate() {
        let points: Vec<(usize, Vector3<f64>)> = members
            .iter()
            .flat_map(|&(s, v)| {
                let pose = means[s].unwrap_or_else(Pose::identity);
                clouds[v].iter().map(move |p| {
                    let p = nalgebra::Point3::from(Vector3::from(p.map(f64::from)));
                    (s, (pose * p).coords)
                })
            })
            .collect();
        let seed = settings.seed.wrapping_add(f as u64);
        frame_observations(&points, &ground, settings, seed, &mut planes, &mut observations);
    }
    let solution = solve(&observations, &mut planes, sensors, reference, settings);
    let mut outcomes = Vec::new();
    for s in (0..sensors).filter(|&s| s != reference && means[s].is_some()) {
        let points = observations.iter().filter(|o| o.sensor == s).count();
        let motion = solution.motions[s];
        let origin = motion * means[s].unwrap_or_else(Pose::identity) * Point3::from(origins[s]);
        let precision = solution.precision(s, &origin.coords);
        let (angle, shift) = (motion.rotation.angle(), motion.translation.vector.norm());
        let accepted =
            points > 0 && angle <= settings.max_departure.0 && shift <= settings.max_departure.1;
        if accepted {
            corrections[s].iter_mut().for_each(|(_, c)| *c = motion * *c);
        }
        outcomes.push(Outcome { sensor: s, motion, points, accepted, precision });
    }
    outcomes
}

/// The outcome as a note on `sensor` (frame `all`).
pub fn note(outcome: &Outcome, sensor: &str) -> super::FrameNote {
    let (angle, shift) =
        (outcome.motion.rotation.angle().to_degrees(), outcome.motion.translation.vector.norm());
    let reason = if outcome.accepted {
        format!(
            "plane adjustment: moved {angle:.4} deg / {:.2} mm ({} points)",
            shift * 1e3,
            outcome.points
        )
    } else if outcome.points == 0 {
        "plane adjustment: no points on planes; kept the refinement".to_string()
    } else {
        format!(
            "plane adjustment moved {angle:.3} deg / {:.1} mm; kept the refinement",
            shift * 1e3
        )
    };
    super::FrameNote { sensor: sensor.to_string(), frame: "all".into(), reason }
}

/// Finds one frame's planes among `points` (sensor, vehicle-frame position) and appends them
/// and the points assigned to them.
fn frame_observations(
    points: &[(usize, Vector3<f64>)],
    ground: &Plane,
    settings: &PlaneSettings,
    seed: u64,
    planes: &mut Vec<FramePlane>,
    observations: &mut Vec<Observation>,
) {
    let mut rng = Pcg64::seed_from_u64(seed);
    // Clusters above the reference's ground, and their planes.
    let above: Vec<usize> = (0..points.len())
        .filter(|&i| ground.distance(&points[i].1) > settings.edge_distance)
        .collect();
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
    for (s, p) in points {
        let mut candidates: Vec<(f64, usize)> = vec![(frame_ground.distance(p).abs(), 0)];
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
    let mut keep = vec![false; local.len()];
    for (k, kept) in keep.iter_mut().enumerate() {
        let mut counts: HashMap<usize, usize> = HashMap::new();
        assigned.iter().filter(|a| a.1 == k).for_each(|a| *counts.entry(a.0).or_default() += 1);
        *kept = counts.values().filter(|&&n| n >= settings.min_sensor_points).count() >= 2;
    }
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
            let score = left.iter().filter(|p| within(&plane, p)).count();
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
/// (26-neighbourhood).
fn clusters(points: &[(usize, Vector3<f64>)], indices: &[usize], gap: f64) -> Vec<Vec<usize>> {
    let cell = |p: &Vector3<f64>| [0, 1, 2].map(|i| (p[i] / gap).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for &i in indices {
        grid.entry(cell(&points[i].1)).or_default().push(i);
    }
    let mut seen: HashMap<[i64; 3], bool> = HashMap::new();
    let mut keys: Vec<[i64; 3]> = grid.keys().copied().collect();
    keys.sort_unstable();
    let mut groups = Vec::new();
    for key in keys {
        if seen.contains_key(&key) {
            continue;
        }
        seen.insert(key, true);
        let mut stack = vec![key];
        let mut members = Vec::new();
        while let Some(k) = stack.pop() {
            members.extend(grid[&k].iter().copied());
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let n = [k[0] + dx, k[1] + dy, k[2] + dz];
                        if grid.contains_key(&n) && !seen.contains_key(&n) {
                            seen.insert(n, true);
                            stack.push(n);
                        }
                    }
                }
            }
        }
        groups.push(members);
    }
    groups
}

/// What [`solve`] found.
struct Solution {
    /// Per sensor (identity for the reference and for sensors without observations).
    motions: Vec<Pose>,
    pivot: Vector3<f64>,
    /// Covariance of the motions' unknowns `[rotation vector, shift]` per non-reference
    /// sensor (see `covariance`); `None` without observations or when singular.
    covariance: Option<DMatrix<f64>>,
    /// Each sensor's first unknown (`None` for the reference).
    slot: Vec<Option<usize>>,
}

/// The normal equations at one linearisation, planes apart: `a`, `g_a` for the motions, and
/// per plane its own 3x3 block `d`, gradient `g_d` and coupling `b` (motions x 3).
struct Normal {
    a: DMatrix<f64>,
    g_a: DVector<f64>,
    b: Vec<DMatrix<f64>>,
    d: Vec<Matrix3<f64>>,
    g_d: Vec<Vector3<f64>>,
}

/// Gauss-Newton with Cauchy weights over one motion per non-reference sensor (rotation about
/// `pivot`, the points' centroid, then a shift) and every plane's normal and offset. Each
/// point touches one plane and one motion, so the planes are eliminated plane by plane (Schur
/// complement) and only the motions' system is solved densely: the cost grows with the
/// frames, not with their cube.
fn solve(
    observations: &[Observation],
    planes: &mut [FramePlane],
    sensors: usize,
    reference: usize,
    settings: &PlaneSettings,
) -> Solution {
    let mut slot = Vec::with_capacity(sensors);
    let mut next = 0;
    for s in 0..sensors {
        slot.push((s != reference).then(|| {
            next += 6;
            next - 6
        }));
    }
    let mut solution = Solution {
        motions: vec![Pose::identity(); sensors],
        pivot: Vector3::zeros(),
        covariance: None,
        slot,
    };
    if observations.is_empty() || planes.is_empty() {
        return solution;
    }
    solution.pivot =
        observations.iter().map(|o| o.point).sum::<Vector3<f64>>() / observations.len() as f64;
    let Solution { motions, pivot, slot, .. } = &mut solution;
    let scale2 = settings.robust_scale * settings.robust_scale;
    for _ in 0..settings.iterations {
        let at = Linearisation::new(planes, motions, slot, *pivot, scale2);
        let normal = normal_equations(&at.terms(observations), &at);
        let Some((step, plane_steps)) = reduced_step(&normal) else {
            break;
        };
        for (s, base) in slot.iter().enumerate() {
            let Some(base) = *base else { continue };
            let omega = Vector3::new(step[base], step[base + 1], step[base + 2]);
            let shift = Vector3::new(step[base + 3], step[base + 4], step[base + 5]);
            motions[s] =
                rotation_about(UnitQuaternion::from_scaled_axis(omega), pivot, &shift) * motions[s];
        }
        for (plane, delta) in planes.iter_mut().zip(&plane_steps) {
            let (u, v) = tangent_basis(&plane.normal);
            plane.normal = (plane.normal + u * delta.x + v * delta.y).normalize();
            plane.offset += delta.z;
        }
        if step.amax() < 1e-9 {
            break;
        }
    }
    let at = Linearisation::new(planes, motions, slot, *pivot, scale2);
    solution.covariance = covariance(observations, &at);
    solution
}

impl Solution {
    /// Sensor `s`'s precision, its position `origin` (vehicle frame): a motion
    /// `(omega, shift)` about the pivot moves the sensor by `shift + omega x (origin - pivot)`.
    fn precision(&self, s: usize, origin: &Vector3<f64>) -> Option<Precision> {
        let (base, covariance) = (self.slot[s]?, self.covariance.as_ref()?);
        let block = covariance.fixed_view::<6, 6>(base, base).into_owned();
        let mut to_sensor = nalgebra::Matrix6::<f64>::identity();
        to_sensor.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-(origin - self.pivot).cross_matrix()));
        let spread = to_sensor * block * to_sensor.transpose();
        let sigma = |i: usize| spread[(i, i)].max(0.0).sqrt();
        Some(Precision { rotation: [0, 1, 2].map(sigma), position: [3, 4, 5].map(sigma) })
    }
}

/// One observation linearised: its Cauchy weight and residual, its Jacobian on its plane's
/// `(u, v, offset)` and, unless it is the reference's, on its sensor's motion at `base`.
struct Term {
    plane: usize,
    weight: f64,
    residual: f64,
    j_d: Vector3<f64>,
    j_a: Option<(usize, [f64; 6])>,
}

/// The linearisation of every observation at the current motions and planes.
struct Linearisation<'a> {
    planes: &'a [FramePlane],
    bases: Vec<(Vector3<f64>, Vector3<f64>)>,
    motions: &'a [Pose],
    slot: &'a [Option<usize>],
    pivot: Vector3<f64>,
    scale2: f64,
}

impl<'a> Linearisation<'a> {
    fn new(
        planes: &'a [FramePlane],
        motions: &'a [Pose],
        slot: &'a [Option<usize>],
        pivot: Vector3<f64>,
        scale2: f64,
    ) -> Self {
        let bases = planes.iter().map(|p| tangent_basis(&p.normal)).collect();
        Self { planes, bases, motions, slot, pivot, scale2 }
    }

    fn terms(&self, observations: &[Observation]) -> Vec<Term> {
        observations.iter().map(|o| self.term(o)).collect()
    }

    fn term(&self, o: &Observation) -> Term {
        let p = (self.motions[o.sensor] * Point3::from(o.point)).coords;
        let plane = &self.planes[o.plane];
        let r = plane.distance(&p);
        let (u, v) = self.bases[o.plane];
        let q = p - plane.centre;
        let j_a = self.slot[o.sensor].map(|base| {
            let rot = (p - self.pivot).cross(&plane.normal);
            (base, [rot.x, rot.y, rot.z, plane.normal.x, plane.normal.y, plane.normal.z])
        });
        Term {
            plane: o.plane,
            weight: 1.0 / (1.0 + r * r / self.scale2),
            residual: r,
            j_d: Vector3::new(u.dot(&q), v.dot(&q), 1.0),
            j_a,
        }
    }
}

/// The normal equations of `terms`, linearised at `at`.
fn normal_equations(terms: &[Term], at: &Linearisation) -> Normal {
    let unknowns = 6 * (at.motions.len() - 1);
    let planes = at.planes.len();
    let mut normal = Normal {
        a: DMatrix::zeros(unknowns, unknowns),
        g_a: DVector::zeros(unknowns),
        b: vec![DMatrix::zeros(unknowns, 3); planes],
        d: vec![Matrix3::zeros(); planes],
        g_d: vec![Vector3::zeros(); planes],
    };
    for &Term { plane: k, weight: w, residual: r, j_d, j_a } in terms {
        normal.d[k] += w * j_d * j_d.transpose();
        normal.g_d[k] += w * r * j_d;
        if let Some((base, j_a)) = j_a {
            for (i, &ji) in j_a.iter().enumerate() {
                normal.g_a[base + i] += w * ji * r;
                for (j, &jj) in j_a.iter().enumerate() {
                    normal.a[(base + i, base + j)] += w * ji * jj;
                }
                for c in 0..3 {
                    normal.b[k][(base + i, c)] += w * ji * j_d[c];
                }
            }
        }
    }
    normal
}

/// The motions' covariance at the solution, `S^-1 (sum w^2 r^2 j j^T) S^-1` with `j` each
/// observation's Jacobian once its plane is eliminated (`j_a - B D^-1 j_d`): the sandwich
/// form, because the residuals' variance differs from point to point (range noise moves a
/// point along its beam, so a face seen head-on scatters more than the ground at a grazing
/// angle) and one variance for all would misjudge every axis.
fn covariance(observations: &[Observation], at: &Linearisation) -> Option<DMatrix<f64>> {
    let terms = at.terms(observations);
    let normal = normal_equations(&terms, at);
    let Reduced { s, inverses, .. } = reduced(&normal)?;
    let s_inverse = s.try_inverse()?;
    let coupling: Vec<_> = normal.b.iter().zip(&inverses).map(|(b, inverse)| b * inverse).collect();
    let unknowns = s_inverse.nrows();
    let mut meat = DMatrix::<f64>::zeros(unknowns, unknowns);
    for term in &terms {
        let mut j = -(&coupling[term.plane] * term.j_d);
        if let Some((base, j_a)) = term.j_a {
            for (i, ji) in j_a.iter().enumerate() {
                j[base + i] += ji;
            }
        }
        let scale = (term.weight * term.residual).powi(2);
        meat.syger(scale, &j, &j, 1.0);
    }
    Some(&s_inverse * meat * &s_inverse)
}

/// The motions' system once every plane is eliminated.
struct Reduced {
    /// `S = A - sum B D^-1 B^T`.
    s: DMatrix<f64>,
    /// `-g_a + sum B D^-1 g_d`.
    rhs: DVector<f64>,
    /// Each plane's `D^-1`.
    inverses: Vec<Matrix3<f64>>,
}

/// Eliminates the planes from `normal`, with a little damping: directions the data leave free
/// stay where they are. `None` when a block is singular.
fn reduced(normal: &Normal) -> Option<Reduced> {
    let largest = (0..normal.a.nrows())
        .map(|i| normal.a[(i, i)])
        .chain(normal.d.iter().flat_map(|d| [d[(0, 0)], d[(1, 1)], d[(2, 2)]]))
        .fold(0.0, f64::max);
    let damping = 1e-9 * largest.max(1e-12);
    let mut s = normal.a.clone();
    for i in 0..s.nrows() {
        s[(i, i)] += damping;
    }
    let mut rhs = -&normal.g_a;
    let mut inverses = Vec::with_capacity(normal.d.len());
    for ((b, d), g_d) in normal.b.iter().zip(&normal.d).zip(&normal.g_d) {
        let inverse = (d + Matrix3::identity() * damping).try_inverse()?;
        let b_inv = b * inverse;
        s -= &b_inv * b.transpose();
        rhs += &b_inv * g_d;
        inverses.push(inverse);
    }
    Some(Reduced { s, rhs, inverses })
}

/// One Gauss-Newton step: the motions' unknowns, then each plane's `(u, v, offset)`.
fn reduced_step(normal: &Normal) -> Option<(DVector<f64>, Vec<Vector3<f64>>)> {
    let Reduced { s, rhs, inverses } = reduced(normal)?;
    let step = if s.nrows() == 0 { DVector::zeros(0) } else { s.cholesky()?.solve(&rhs) };
    let plane_steps = normal
        .b
        .iter()
        .zip(&inverses)
        .zip(&normal.g_d)
        .map(|((b, inverse), g_d)| inverse * (-g_d - b.transpose() * &step))
        .collect();
    Some((step, plane_steps))
}

/// Two unit vectors orthogonal to `n` and to each other.
fn tangent_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if n.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let u = n.cross(&helper).normalize();
    (u, n.cross(&u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;
    use rand_distr::{Distribution, Normal};

    /// Points on the visible faces of an axis-aligned cube (edge `a`, centre `c` at height
    /// `a / 2`) standing on z = 0 and a ground patch around it, sampled on a grid with noise along `beam` from the
    /// origin.
    fn scene(c: Vector3<f64>, a: f64, step: f64, noise: f64, seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let normal = Normal::new(0.0, noise).unwrap();
        let mut pts = Vec::new();
        let n = (a / step) as i64;
        for i in 0..=n {
            for j in 0..=n {
                let (s, t) = (i as f64 * step - a / 2.0, j as f64 * step);
                // Front face (facing -x), side face (facing -y), top.
                pts.push(Vector3::new(c.x - a / 2.0, c.y + s, t));
                pts.push(Vector3::new(c.x + s, c.y - a / 2.0, t));
                pts.push(Vector3::new(c.x + s, c.y + t - a / 2.0, a));
            }
        }
        for i in -30..=30 {
            for j in -30..=30 {
                let p = Vector3::new(c.x + i as f64 * 0.05, c.y + j as f64 * 0.05, 0.0);
                if (p.x - c.x).abs() > a / 2.0 + 0.01 || (p.y - c.y).abs() > a / 2.0 + 0.01 {
                    pts.push(p);
                }
            }
        }
        pts.iter().map(|p| p + p.normalize() * normal.sample(&mut rng)).collect()
    }

    /// Both sensors of these scenes sit at the origin.
    const ORIGINS: [Vector3<f64>; 2] = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 0.0)];

    fn as_f32(points: &[Vector3<f64>]) -> Vec<[f32; 3]> {
        points.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect()
    }

    /// Two sensors see the same scene of two cubes; the second one's points are moved by a
    /// small wrong correction. The adjustment must find the inverse, from a start that is off.
    #[test]
    fn recovers_a_small_motion_between_two_sensors() {
        let cubes = [Vector3::new(10.0, -1.0, 0.25), Vector3::new(11.0, 1.0, 0.25)];
        let truth = pose_from_xyz_rpy([0.004, -0.006, 0.002], [0.001, -0.0008, 0.0015]);
        let mut clouds = Vec::new();
        for frame in 0..3u64 {
            for sensor in 0..2u64 {
                let mut pts: Vec<Vector3<f64>> = Vec::new();
                // The sensors sample the faces on different grids.
                let step = 0.04 - 0.005 * sensor as f64;
                for (i, c) in cubes.iter().enumerate() {
                    pts.extend(scene(*c, 0.5, step, 0.003, frame * 10 + sensor + 100 * i as u64));
                }
                if sensor == 1 {
                    pts = pts
                        .iter()
                        .map(|p| (truth.inverse() * nalgebra::Point3::from(*p)).coords)
                        .collect();
                }
                clouds.push(as_f32(&pts));
            }
        }
        let refs: Vec<&[[f32; 3]]> = clouds.iter().map(|c| c.as_slice()).collect();
        let pairs = vec![vec![(0, 0), (2, 2), (4, 4)], vec![(0, 1), (2, 3), (4, 5)]];
        let mut corrections = vec![
            pairs[0].iter().map(|&p| (p, Pose::identity())).collect::<Vec<_>>(),
            pairs[1].iter().map(|&p| (p, Pose::identity())).collect::<Vec<_>>(),
        ];
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let outcomes = adjust(
            &refs,
            &ORIGINS,
            &pairs,
            0,
            &mut corrections,
            Some(ground),
            &PlaneSettings::default(),
        );
        assert_eq!(outcomes.len(), 1);
        assert!(outcomes[0].accepted, "{outcomes:?}");
        for (_, c) in &corrections[1] {
            let error = c.inverse() * truth;
            let (deg, m) = (error.rotation.angle().to_degrees(), error.translation.vector.norm());
            assert!(deg < 0.005 && m < 0.001, "{deg} deg, {m} m");
        }
        assert!(corrections[0].iter().all(|(_, c)| *c == Pose::identity()));
    }

    #[test]
    fn finds_the_faces_of_a_cube_and_drops_its_edges() {
        let points: Vec<(usize, Vector3<f64>)> =
            scene(Vector3::new(10.0, 0.0, 0.25), 0.5, 0.02, 0.0, 1)
                .into_iter()
                .enumerate()
                .map(|(i, p)| (i % 2, p))
                .collect();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let (mut planes, mut observations) = (Vec::new(), Vec::new());
        let settings = PlaneSettings::default();
        frame_observations(&points, &ground, &settings, 0, &mut planes, &mut observations);
        // Ground, front, side, top.
        assert_eq!(planes.len(), 4, "{planes:?}");
        for o in &observations {
            let d = planes[o.plane].distance(&o.point);
            assert!(d.abs() < 1e-6, "{d} {:?} {:?}", o.point, planes[o.plane]);
            // Near the cube, no point kept is near a second plane (the planes extend beyond).
            let near_cube = (o.point.x - 10.0).abs() < 0.3 && o.point.y.abs() < 0.3;
            let near =
                planes.iter().filter(|p| p.distance(&o.point).abs() <= settings.edge_distance);
            assert!(!near_cube || near.count() == 1, "{:?}", o.point);
        }
        // Edge points are out: the top's points keep 3 cm from the front and side faces.
        assert!(observations.len() < points.len());
    }

    #[test]
    fn a_motion_beyond_the_limit_is_rejected() {
        let cube = Vector3::new(10.0, 0.0, 0.25);
        // 0.057 deg of yaw about the origin: 1 cm at the cube.
        let truth = pose_from_xyz_rpy([0.0, 0.0, 0.0], [0.0, 0.0, 0.001]);
        let a = scene(cube, 0.5, 0.03, 0.0, 1);
        let b: Vec<Vector3<f64>> = scene(cube, 0.5, 0.03, 0.0, 2)
            .iter()
            .map(|p| (truth.inverse() * nalgebra::Point3::from(*p)).coords)
            .collect();
        let clouds = [as_f32(&a), as_f32(&b)];
        let refs: Vec<&[[f32; 3]]> = clouds.iter().map(|c| c.as_slice()).collect();
        let pairs = vec![vec![(0, 0)], vec![(0, 1)]];
        let mut corrections =
            vec![vec![((0, 0), Pose::identity())], vec![((0, 1), Pose::identity())]];
        let settings =
            PlaneSettings { max_departure: (0.03f64.to_radians(), 0.02), ..Default::default() };
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let outcomes =
            adjust(&refs, &ORIGINS, &pairs, 0, &mut corrections, Some(ground), &settings);
        assert!(!outcomes[0].accepted, "{outcomes:?}");
        assert!((outcomes[0].motion.rotation.angle() - 0.001).abs() < 1e-4, "{outcomes:?}");
        assert_eq!(corrections[1][0].1, Pose::identity());
    }
}
