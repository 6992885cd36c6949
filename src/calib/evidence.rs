//! Evidence for a calibration, measured after it on the same views: how much of each sensor's
//! structure lands on the reference's surfaces (before and after), which directions the data
//! constrain, and whether the frames agree with each other as well as their noise allows.
//! Typed numbers only; `verdict` judges them and `report` words them.
//!
//! Each sensor's views are compared with the reference's view of the same frame: every
//! (sampled) point is mapped by the calibration, its nearest reference point found, and its
//! distance taken along that point's surface normal. Points with no reference surface near do
//! not overlap and count neither way: a small residual over nothing is no evidence.

use std::borrow::Cow;

use nalgebra::{Matrix6, Point3, SymmetricEigen, Vector3, Vector6};

use crate::icp::normals::{self, Neighbourhood};
use crate::icp::{FixedCloud, KdTree};
use crate::plane::Plane;
use crate::se3::Pose;

/// Sensor points taken per view (strided, deterministic): enough for shares to a percent and
/// the information matrix, at a few milliseconds per view.
const SAMPLE: usize = 4000;
/// Neighbours whose spread gives a reference point its surface normal and thickness.
const NEIGHBOURS: usize = 20;
/// A neighbourhood is a surface when its second-largest spread (m) exceeds this: along one
/// scan ring the points lie on a line, which has no normal.
const MIN_SURFACE_EXTENT: f64 = 0.02;
/// Noise floor (m): below a LiDAR's range noise, so it never binds on real data.
const MIN_NOISE: f64 = 0.003;
/// The noise (m) a point's agreement is judged at, at least: a LiDAR's range noise (1-3 cm)
/// beside the other's. A dense sensor's neighbourhoods are thinner than that, and a sparse
/// 32-beam scan's rings show no thickness across at all; judged by their own thickness, a right
/// calibration of a sparse pair read 28 % agreeing.
const AGREEMENT_NOISE: f64 = 0.01;
/// Edge (m) of the blocks whose residuals the observability takes as one (cluster-robust):
/// neighbouring points share what the surface model misses.
const BLOCK: f64 = 1.0;
/// Points at least this high above the reference's ground (m) are structure.
const STRUCTURE_HEIGHT: f64 = 0.1;
/// Reference points this near its fitted ground (m) take the ground's normal: ground rings
/// lie too far apart for neighbour normals, whose tilt would fake constraints on yaw and the
/// shift along the ground.
const GROUND_BAND: f64 = 0.03;

/// How much of a sensor's structure lands on the reference's surfaces.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Agreement {
    /// Sensor points compared (sampled).
    pub points: usize,
    /// Of those, the points with a reference surface within `radius`.
    pub overlapping: usize,
    /// Of those, the points within `tolerance` of that surface.
    pub agreeing: usize,
    /// The same three counts for the points standing above the reference's ground (all
    /// points when no ground is known): the structure that fixes yaw and the shift.
    pub structure: [usize; 3],
    /// How near a reference point must be for a surface to count as overlapping (m).
    pub radius: f64,
    /// Distance to the surface within which a point agrees (m): three noise widths.
    pub tolerance: f64,
}

impl Agreement {
    /// Share of the overlapping points that agree (0 when nothing overlaps).
    pub fn share(&self) -> f64 {
        ratio(self.agreeing, self.overlapping)
    }

    /// Share of the points compared that overlap the reference.
    pub fn overlap(&self) -> f64 {
        ratio(self.overlapping, self.points)
    }

    /// Share of the overlapping structure that agrees.
    pub fn structure_share(&self) -> f64 {
        ratio(self.structure[2], self.structure[1])
    }

    fn add(&mut self, other: &Agreement) {
        self.points += other.points;
        self.overlapping += other.overlapping;
        self.agreeing += other.agreeing;
        for (a, b) in self.structure.iter_mut().zip(other.structure) {
            *a += b;
        }
        self.radius = self.radius.max(other.radius);
        self.tolerance = self.tolerance.max(other.tolerance);
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

/// How well the agreeing points pin each direction down: the one-sigma spread of a motion
/// about their centroid, from the point-to-surface information (the Cramér-Rao bound of these
/// data for the noise measured). A direction nothing constrains has a spread in the metres or
/// radians.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Observability {
    /// Rotation about the vehicle's x, y, z axes (rad).
    pub rotation: [f64; 3],
    /// Translation along x, y, z (m).
    pub translation: [f64; 3],
}

/// The evidence on one non-reference sensor.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SensorEvidence {
    /// The JSON keys the evidence by its sensor already.
    #[serde(skip)]
    pub sensor: String,
    /// Under the nominal (levelling and search undone) and under the calibration.
    pub before: Agreement,
    pub after: Agreement,
    /// All frames together, under the calibration.
    pub observability: Observability,
    /// One frame's, on average: what a frame's correction can be trusted to.
    pub frame_observability: Observability,
    /// The residual noise measured on the agreeing points (m).
    pub noise: f64,
}

/// A reference view prepared once: its tree, and per point a surface normal (zero where the
/// neighbourhood is a line or a point) and the surface's thickness.
pub(super) struct ReferenceSurface<'a> {
    points: &'a [[f32; 3]],
    tree: Cow<'a, KdTree>,
    normals: Vec<Vector3<f64>>,
    radius: f64,
    noise: f64,
}

impl<'a> ReferenceSurface<'a> {
    pub(super) fn new(points: &'a [[f32; 3]], ground: Option<&Plane>) -> Self {
        let tree = KdTree::new(points);
        let neighbourhoods = normals::neighbourhoods(points, &tree, NEIGHBOURS);
        Self::from_neighbourhoods(points, Cow::Owned(tree), &neighbourhoods, ground)
    }

    /// The surface of `points` from the ICP fixed cloud built on them, whose tree and neighbourhoods
    /// it takes instead of searching again: the same surface as [`ReferenceSurface::new`]'s.
    /// `None` unless the target kept its neighbourhoods, of as many neighbours, on the same
    /// points (not downsampled).
    pub(super) fn of_target(
        target: &'a FixedCloud,
        points: &[[f32; 3]],
        ground: Option<&Plane>,
    ) -> Option<Self> {
        let neighbourhoods = target.neighbourhoods();
        let same = target.neighbours() == NEIGHBOURS && target.points() == points;
        (same && neighbourhoods.len() == points.len()).then(|| {
            let tree = Cow::Borrowed(target.tree());
            Self::from_neighbourhoods(target.points(), tree, neighbourhoods, ground)
        })
    }

    fn from_neighbourhoods(
        points: &'a [[f32; 3]],
        tree: Cow<'a, KdTree>,
        neighbourhoods: &[Option<Neighbourhood>],
        ground: Option<&Plane>,
    ) -> Self {
        let mut normals = vec![Vector3::zeros(); points.len()];
        let (mut thickness, mut spacing) = (Vec::new(), Vec::new());
        for (normal, n) in normals.iter_mut().zip(neighbourhoods) {
            let Some(n) = n else { continue };
            spacing.push(n.reach);
            let Some((variances, least)) = n.shape else { continue };
            if variances[1].max(0.0).sqrt() < MIN_SURFACE_EXTENT {
                continue;
            }
            *normal = least;
            thickness.push(variances[0].max(0.0).sqrt());
        }
        if let Some(g) = ground {
            for (p, n) in points.iter().zip(&mut normals) {
                if g.distance(&Vector3::from(p.map(f64::from))).abs() <= GROUND_BAND {
                    *n = g.normal;
                }
            }
        }
        // Twice the typical reach of a neighbourhood: a surface sampled this sparsely is
        // still near, one further away is not there.
        let radius = (2.0 * median(&mut spacing)).max(0.1);
        let noise = median(&mut thickness).max(MIN_NOISE);
        Self { points, tree, normals, radius, noise }
    }

    /// `cloud` (sampled) under `pose` against this surface; adds each agreeing point's
    /// information (about `centre`, rotation first) to `information` when given.
    fn compare(
        &self,
        cloud: &[[f32; 3]],
        pose: &Pose,
        ground: Option<&Plane>,
        mut information: Option<&mut Information>,
    ) -> Agreement {
        let tolerance = 3.0 * self.noise.max(AGREEMENT_NOISE);
        let mut a = Agreement { radius: self.radius, tolerance, ..Agreement::default() };
        let stride = cloud.len().div_ceil(SAMPLE).max(1);
        for p in cloud.iter().step_by(stride) {
            let q = (pose * Point3::from(Vector3::from(p.map(f64::from)))).coords;
            a.points += 1;
            let structure = ground.is_none_or(|g| g.distance(&q) > STRUCTURE_HEIGHT);
            if structure {
                a.structure[0] += 1;
            }
            let Some(near) = self.tree.nearest_within([q.x, q.y, q.z], self.radius) else {
                continue;
            };
            let normal = self.normals[near.index];
            if normal == Vector3::zeros() {
                continue;
            }
            let on = Vector3::from(self.points[near.index].map(f64::from));
            let distance = normal.dot(&(q - on));
            a.overlapping += 1;
            a.structure[1] += usize::from(structure);
            if distance.abs() > tolerance {
                continue;
            }
            a.agreeing += 1;
            a.structure[2] += usize::from(structure);
            if let Some(info) = information.as_mut() {
                info.add(&q, &normal, distance);
            }
        }
        a
    }
}

/// A point-to-surface residual's derivative by a motion `(omega, t)` about `centre`.
fn jacobian(q: &Vector3<f64>, normal: &Vector3<f64>, centre: &Vector3<f64>) -> Vector6<f64> {
    let r = (q - centre).cross(normal);
    Vector6::new(r.x, r.y, r.z, normal.x, normal.y, normal.z)
}

/// The evidence on one sensor: its views `(reference view, view)`, each mapped onto the
/// reference by `after` (and `before`) from the clouds' frame; the surfaces per reference
/// view; the reference's ground, when known.
pub(super) fn sensor_evidence(
    sensor: &str,
    pairs: &[(usize, usize)],
    clouds: &[&[[f32; 3]]],
    surfaces: &[Option<ReferenceSurface>],
    before: &Pose,
    after: &Pose,
    ground: Option<&Plane>,
) -> SensorEvidence {
    let mut evidence = SensorEvidence {
        sensor: sensor.to_string(),
        before: Agreement::default(),
        after: Agreement::default(),
        observability: Observability::default(),
        frame_observability: Observability::default(),
        noise: MIN_NOISE,
    };
    // The motion is taken about the centroid of the sensor's points in the vehicle frame.
    let centre: Vector3<f64> =
        crate::cloud::centroid(pairs.iter().flat_map(|&(_, v)| clouds[v].iter()))
            .map_or_else(Vector3::zeros, |c| (after * Point3::from(Vector3::from(c))).coords);
    let mut total = Matrix6::zeros();
    let mut frames = Vec::new();
    let mut info =
        Information { centre, h: Matrix6::zeros(), residuals: Vec::new(), blocks: Blocks::new() };
    for &(r, v) in pairs {
        let Some(surface) = surfaces[r].as_ref() else { continue };
        evidence.before.add(&surface.compare(clouds[v], before, ground, None));
        info.h = Matrix6::zeros();
        evidence.after.add(&surface.compare(clouds[v], after, ground, Some(&mut info)));
        total += info.h;
        frames.push(info.h);
    }
    let (residuals, blocks) = (info.residuals, info.blocks);
    let noise = rms(&residuals).max(MIN_NOISE);
    evidence.noise = noise;
    // Cluster-robust: the residuals' spread within and between blocks, not per point; never
    // below what independent noise alone leaves.
    let meat: Matrix6<f64> = blocks.values().map(|g| g * g.transpose()).sum();
    evidence.observability = widest(spread(&total, noise), sandwich(&total, &meat));
    let per_frame: Vec<Observability> = frames.iter().map(|h| spread(h, noise)).collect();
    evidence.frame_observability = mean_observability(&per_frame);
    evidence
}

fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// Per block of space, the sum of the agreeing points' `j r` (their gradient).
type Blocks = std::collections::BTreeMap<[i64; 3], Vector6<f64>>;

/// What the agreeing points of one view add to a sensor's precision: the information `h`
/// (about `centre`, rotation first), the residuals, and their gradients per block.
struct Information {
    centre: Vector3<f64>,
    h: Matrix6<f64>,
    residuals: Vec<f64>,
    blocks: Blocks,
}

impl Information {
    fn add(&mut self, q: &Vector3<f64>, normal: &Vector3<f64>, distance: f64) {
        let j = jacobian(q, normal, &self.centre);
        self.h += j * j.transpose();
        self.residuals.push(distance);
        let key = [q.x, q.y, q.z].map(|c| (c / BLOCK).floor() as i64);
        *self.blocks.entry(key).or_insert_with(Vector6::zeros) += j * distance;
    }
}

/// The one-sigma spread per axis of the sandwich `h^-1 meat h^-1`, with `h`'s free directions
/// free as in [`spread`].
fn sandwich(h: &Matrix6<f64>, meat: &Matrix6<f64>) -> Observability {
    let inverse = pseudo_inverse(h);
    let covariance = inverse * meat * inverse;
    let sigma = |i: usize| covariance[(i, i)].max(0.0).sqrt();
    Observability { rotation: [0, 1, 2].map(sigma), translation: [3, 4, 5].map(sigma) }
}

/// Per axis, the wider of two spreads.
fn widest(a: Observability, b: Observability) -> Observability {
    Observability {
        rotation: [0, 1, 2].map(|i| a.rotation[i].max(b.rotation[i])),
        translation: [0, 1, 2].map(|i| a.translation[i].max(b.translation[i])),
    }
}

/// `h`'s inverse on the directions it constrains; directions with (almost) no information get
/// an enormous variance.
fn pseudo_inverse(h: &Matrix6<f64>) -> Matrix6<f64> {
    let eigen = SymmetricEigen::new(*h);
    let largest = eigen.eigenvalues.amax();
    let mut covariance = Matrix6::zeros();
    for k in 0..6 {
        let value = eigen.eigenvalues[k];
        let v = eigen.eigenvectors.column(k);
        // Directions below a millionth of the best constrained one hold no information.
        let inverse = if largest > 0.0 && value > 1e-6 * largest { 1.0 / value } else { 1e12 };
        covariance += v * v.transpose() * inverse;
    }
    covariance
}

/// The one-sigma spread per axis of a motion whose information is `h` for residual noise
/// `noise`: `noise^2 h^-1`. A direction with (almost) no information gets an infinite spread.
fn spread(h: &Matrix6<f64>, noise: f64) -> Observability {
    let covariance = pseudo_inverse(h);
    let sigma = |i: usize| noise * covariance[(i, i)].max(0.0).sqrt();
    Observability { rotation: [0, 1, 2].map(sigma), translation: [3, 4, 5].map(sigma) }
}

fn mean_observability(all: &[Observability]) -> Observability {
    let n = all.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Observability) -> f64| all.iter().map(f).sum::<f64>() / n;
    Observability {
        rotation: [0, 1, 2].map(|i| mean(&|o| o.rotation[i])),
        translation: [0, 1, 2].map(|i| mean(&|o| o.translation[i])),
    }
}

/// The middle value (the upper one of an even count); 0 for none.
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::verdict::{WEAK_ROTATION, WEAK_TRANSLATION};
    use crate::se3::pose_from_xyz_rpy;

    /// A floor and a wall corner, sampled on a grid: every direction constrained.
    fn corner(step: f64) -> Vec<[f32; 3]> {
        let mut points = Vec::new();
        for i in 0..60 {
            for j in 0..60 {
                let (a, b) = (i as f64 * step, j as f64 * step);
                points.push([5.0 + a, -1.5 + b, 0.0]);
                points.push([5.0, -1.5 + a, b]);
                points.push([5.0 + a, -1.5, b]);
            }
        }
        points.into_iter().map(|p| p.map(|c| c as f32)).collect()
    }

    #[test]
    fn agreement_falls_with_a_wrong_pose_and_a_floor_leaves_three_directions_free() {
        let reference = corner(0.05);
        let surface = ReferenceSurface::new(&reference, None);
        let sensor = corner(0.043);
        let clouds: Vec<&[[f32; 3]]> = vec![&reference, &sensor];
        let surfaces = vec![Some(surface), None];
        let wrong = pose_from_xyz_rpy([0.2, -0.1, 0.05], [0.0, 0.0, 0.05]);
        let e =
            sensor_evidence("s", &[(0, 1)], &clouds, &surfaces, &wrong, &Pose::identity(), None);
        assert!(e.after.share() > 0.95 && e.after.overlap() > 0.9, "{:?}", e.after);
        assert!(e.before.share() < 0.5, "{:?}", e.before);
        // Constrained means within the verdict's own limit for a weak direction.
        let o = e.observability;
        assert!(o.rotation.iter().all(|s| *s < WEAK_ROTATION), "{o:?}");
        assert!(o.translation.iter().all(|s| *s < WEAK_TRANSLATION), "{o:?}");

        // A floor alone: yaw and the shift along it are free.
        let floor: Vec<[f32; 3]> = reference.iter().copied().filter(|p| p[2] == 0.0).collect();
        let floor_sensor: Vec<[f32; 3]> = sensor.iter().copied().filter(|p| p[2] == 0.0).collect();
        let clouds: Vec<&[[f32; 3]]> = vec![&floor, &floor_sensor];
        let surfaces = vec![Some(ReferenceSurface::new(&floor, None)), None];
        let e =
            sensor_evidence("s", &[(0, 1)], &clouds, &surfaces, &wrong, &Pose::identity(), None);
        let o = e.observability;
        assert!(o.rotation[2] > 1.0 && o.translation[0] > 1.0 && o.translation[1] > 1.0, "{o:?}");
        assert!(o.rotation[0] < WEAK_ROTATION && o.rotation[1] < WEAK_ROTATION, "{o:?}");
        assert!(o.translation[2] < WEAK_TRANSLATION, "{o:?}");
    }

    #[test]
    fn nothing_overlapping_is_no_agreement() {
        let reference = corner(0.05);
        let far: Vec<[f32; 3]> = reference.iter().map(|p| [p[0] + 30.0, p[1], p[2]]).collect();
        let clouds: Vec<&[[f32; 3]]> = vec![&reference, &far];
        let surfaces = vec![Some(ReferenceSurface::new(&reference, None)), None];
        let e = sensor_evidence(
            "s",
            &[(0, 1)],
            &clouds,
            &surfaces,
            &Pose::identity(),
            &Pose::identity(),
            None,
        );
        assert_eq!((e.after.overlapping, e.after.share()), (0, 0.0));
    }

    #[test]
    fn a_frame_pairs_target_gives_the_surface_searched_again() {
        use crate::icp::{IcpSettings, Metric};
        // A corner with centimetre ripples, so thickness and normals are not exact.
        let reference: Vec<[f32; 3]> = corner(0.05)
            .into_iter()
            .enumerate()
            .map(|(i, p)| p.map(|c| c + 0.01 * ((i as f32) * 0.7).sin()))
            .collect();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let settings = IcpSettings::default();
        let searched = ReferenceSurface::new(&reference, Some(&ground));
        assert!(searched.noise > MIN_NOISE, "{}", searched.noise);
        for metric in [Metric::Gicp, Metric::PointToPlane, Metric::PointToPoint] {
            let target = FixedCloud::with_neighbourhoods(&reference, metric, &settings).unwrap();
            let shared = ReferenceSurface::of_target(&target, &reference, Some(&ground)).unwrap();
            assert_eq!(shared.normals, searched.normals, "{metric:?}");
            assert_eq!((shared.radius, shared.noise), (searched.radius, searched.noise));
        }
        let target = FixedCloud::with_neighbourhoods(&reference, Metric::Gicp, &settings).unwrap();

        // ICP sees the same target; the surface is not taken when the target's points or
        // neighbourhoods differ from its own.
        let plain = FixedCloud::new(&reference, Metric::Gicp, &settings).unwrap();
        assert_eq!(plain.covariances(), target.covariances());
        let kept = FixedCloud::with_neighbourhoods(&reference, Metric::PointToPlane, &settings);
        let plain_p2l = FixedCloud::new(&reference, Metric::PointToPlane, &settings).unwrap();
        assert_eq!(plain_p2l.normals(), kept.unwrap().normals());
        let fewer = IcpSettings { neighbours: 10, ..settings.clone() };
        let thinned = IcpSettings { voxel: Some(0.1), ..settings.clone() };
        for other in [
            plain,
            FixedCloud::with_neighbourhoods(&reference, Metric::Gicp, &fewer).unwrap(),
            FixedCloud::with_neighbourhoods(&reference, Metric::Gicp, &thinned).unwrap(),
        ] {
            assert!(ReferenceSurface::of_target(&other, &reference, None).is_none());
        }
        assert!(ReferenceSurface::of_target(&target, &reference[1..], None).is_none());
    }
}
