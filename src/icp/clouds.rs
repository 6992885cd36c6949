//! The two sides of a registration, each prepared once: the fixed cloud (held still; ICP's
//! "target": kd-tree plus normals or covariances, as the metric needs), reused for any number
//! of moving clouds, e.g. every sensor's view of one frame; and a moving cloud (ICP's "source":
//! tree order, GICP covariances) for several registrations, e.g. stages with a shrinking match
//! distance. Not "target": that is the calibration target (`crate::targets`).

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use super::gicp::Gicp;
use super::kdtree::KdTree;
use super::normals::{self, Neighbourhood, normals, plane_covariance, plane_covariances};
use super::plane::PointToPlane;
use super::point::PointToPoint;
use super::solver::{self, LevenbergMarquardt, Matcher};
use super::{Alignment, IcpError, IcpSettings, Metric, Role};
use crate::cloud::Cloud;
use crate::se3::Pose;

/// A cloud smaller than this cannot fix a rigid transform.
const MIN_POINTS: usize = 3;

/// A cloud whose second principal standard deviation is below this fraction of the first is
/// a line (1e-4: a 10 m line less than a millimetre thick): rotation about it is undetermined.
const MIN_SPREAD_RATIO: f64 = 1e-4;

/// Largest principal variance (m^2) below which all points coincide (to a micrometre).
const MIN_VARIANCE: f64 = 1e-12;

/// The fixed side of a registration, prepared for one [`Metric`].
#[derive(Clone, Debug)]
pub struct FixedCloud {
    metric: Metric,
    points: Vec<[f32; 3]>,
    tree: KdTree,
    normals: Vec<Vector3<f64>>,
    covariances: Vec<Matrix3<f64>>,
    /// Per point, its neighbourhood (from the same search as the covariances); empty unless
    /// asked for.
    neighbourhoods: Vec<Option<Neighbourhood>>,
    neighbours: usize,
}

impl FixedCloud {
    /// Checks and (when `settings.voxel` is set) downsamples `points`, builds the kd-tree and,
    /// from `settings.neighbours` nearest neighbours, the normals (point-to-plane) or the
    /// plane-regularised covariances (GICP).
    pub fn new(
        points: &[[f32; 3]],
        metric: Metric,
        settings: &IcpSettings,
    ) -> Result<Self, IcpError> {
        Self::build(points, metric, settings, false)
    }

    /// [`FixedCloud::new`] that also keeps each point's [`Neighbourhood`] from the search
    /// that gave its normals or covariances (a search of its own for point-to-point), for
    /// whoever reads the target's surface afterwards (the verdict's evidence). The same target
    /// otherwise, bit for bit.
    pub fn with_neighbourhoods(
        points: &[[f32; 3]],
        metric: Metric,
        settings: &IcpSettings,
    ) -> Result<Self, IcpError> {
        Self::build(points, metric, settings, true)
    }

    fn build(
        points: &[[f32; 3]],
        metric: Metric,
        settings: &IcpSettings,
        keep: bool,
    ) -> Result<Self, IcpError> {
        let (points, tree) = indexed(points, Role::Target, settings)?;
        let k = settings.neighbours;
        let ((normals, covariances), neighbourhoods) = match metric {
            Metric::PointToPlane => {
                let (normals, kept) = normals(&points, &tree, k, keep);
                ((normals, Vec::new()), kept)
            }
            Metric::Gicp => {
                let (covariances, kept) = plane_covariances(&points, &tree, k, keep);
                ((Vec::new(), covariances), kept)
            }
            Metric::PointToPoint if keep => {
                ((Vec::new(), Vec::new()), normals::neighbourhoods(&points, &tree, k))
            }
            Metric::PointToPoint => ((Vec::new(), Vec::new()), Vec::new()),
        };
        Ok(Self { metric, points, tree, normals, covariances, neighbourhoods, neighbours: k })
    }

    pub fn metric(&self) -> Metric {
        self.metric
    }

    /// The points used (after downsampling), in f32 as given.
    pub fn points(&self) -> &[[f32; 3]] {
        &self.points
    }

    pub fn tree(&self) -> &KdTree {
        &self.tree
    }

    /// Unit normals per point (zero where undefined); empty unless point-to-plane.
    pub fn normals(&self) -> &[Vector3<f64>] {
        &self.normals
    }

    /// Plane-regularised covariances per point (m^2); empty unless GICP.
    pub fn covariances(&self) -> &[Matrix3<f64>] {
        &self.covariances
    }

    /// Per point, its [`Neighbourhood`]; empty unless built with them.
    pub fn neighbourhoods(&self) -> &[Option<Neighbourhood>] {
        &self.neighbourhoods
    }

    /// How many nearest neighbours make a point's neighbourhood.
    pub fn neighbours(&self) -> usize {
        self.neighbours
    }

    /// Replaces the estimated surface normal of every target point for which `normal_at` knows
    /// better (a unit vector), e.g. ground points whose rings lie too far apart for a
    /// neighbourhood to show the plane. Sets the normal (point-to-plane) or plane covariance
    /// (GICP). Returns how many points changed.
    pub fn set_normals(&mut self, normal_at: impl Fn(&[f32; 3]) -> Option<Vector3<f64>>) -> usize {
        if self.metric == Metric::PointToPoint {
            return 0;
        }
        let mut changed = 0;
        for i in 0..self.points.len() {
            let Some(n) = normal_at(&self.points[i]) else {
                continue;
            };
            match self.metric {
                Metric::PointToPlane => self.normals[i] = n,
                _ => self.covariances[i] = plane_covariance(&n),
            }
            changed += 1;
        }
        changed
    }

    /// Registers `source` onto this target starting from `init` (`T_target_source`). Uses
    /// every setting but `neighbours` and `voxel` from `settings`, and those for the source.
    pub fn align(
        &self,
        source: &[[f32; 3]],
        init: &Pose,
        settings: &IcpSettings,
    ) -> Result<Alignment, IcpError> {
        self.align_prepared(&MovingCloud::new(source, self.metric, settings)?, init, settings)
    }

    /// [`FixedCloud::align`] for a source prepared once, with the same metric; `neighbours` and
    /// `voxel` were taken when it was.
    pub fn align_prepared(
        &self,
        source: &MovingCloud,
        init: &Pose,
        settings: &IcpSettings,
    ) -> Result<Alignment, IcpError> {
        self.align_stages(source, init, std::slice::from_ref(settings))
    }

    /// Registers a prepared source in stages (typically shrinking match distances), each from
    /// the pose the last one reached; the last stage's alignment. The matching carries from one
    /// stage to the next: a source point far from the target stays known as far.
    pub fn align_stages(
        &self,
        source: &MovingCloud,
        init: &Pose,
        stages: &[IcpSettings],
    ) -> Result<Alignment, IcpError> {
        stages.iter().try_for_each(IcpSettings::validate)?;
        if !solver::is_finite(init) {
            return Err(IcpError::InvalidInitialPose);
        }
        if source.metric != self.metric {
            return Err(IcpError::InvalidSettings("the source was prepared for another metric"));
        }
        let mut matcher = Matcher::new(&self.tree, &self.points, source.points.len());
        let mut pose = *init;
        let mut last = Err(IcpError::InvalidSettings("no stages"));
        for settings in stages {
            let alignment = self.run(&mut matcher, source, &pose, settings)?;
            pose = alignment.target_from_source;
            last = Ok(alignment);
        }
        last
    }

    /// One ICP run of `source` from `init` under this target's metric.
    fn run(
        &self,
        matcher: &mut Matcher,
        source: &MovingCloud,
        init: &Pose,
        settings: &IcpSettings,
    ) -> Result<Alignment, IcpError> {
        let MovingCloud { points: source, covariances: source_covariances, .. } = source;
        let target = &self.points[..];
        match self.metric {
            Metric::PointToPoint => {
                let mut step = PointToPoint { target, source };
                solver::run(matcher, source, &mut step, init, settings)
            }
            Metric::PointToPlane => {
                let factor =
                    PointToPlane::new(target, &self.normals, source, settings.robust_scale);
                solver::run(matcher, source, &mut LevenbergMarquardt::new(factor), init, settings)
            }
            Metric::Gicp => {
                let factor = Gicp::new(
                    target,
                    &self.covariances,
                    source,
                    source_covariances,
                    settings.robust_scale,
                );
                solver::run(matcher, source, &mut LevenbergMarquardt::new(factor), init, settings)
            }
        }
    }
}

/// The source side of a registration, prepared for one [`Metric`].
#[derive(Clone, Debug)]
pub struct MovingCloud {
    metric: Metric,
    /// In kd-tree order: consecutive queries then land close together in the target tree,
    /// which stays in cache (merged clouds are not spatially ordered).
    points: Vec<Vector3<f64>>,
    /// GICP: plane-regularised covariances from the source's own neighbourhoods, in that order.
    covariances: Vec<Matrix3<f64>>,
}

impl MovingCloud {
    /// Checks and (when `settings.voxel` is set) downsamples `points` and, for GICP, computes
    /// their covariances from `settings.neighbours` nearest neighbours.
    pub fn new(
        points: &[[f32; 3]],
        metric: Metric,
        settings: &IcpSettings,
    ) -> Result<Self, IcpError> {
        let (points, tree) = indexed(points, Role::Source, settings)?;
        let order: Vec<usize> = tree.tree_order().collect();
        let covariances = if metric == Metric::Gicp {
            let (covariances, _) = plane_covariances(&points, &tree, settings.neighbours, false);
            order.iter().map(|&i| covariances[i]).collect()
        } else {
            Vec::new()
        };
        let points = order.iter().map(|&i| Vector3::from(points[i].map(f64::from))).collect();
        Ok(Self { metric, points, covariances })
    }
}

/// One side's points checked and downsampled ([`prepare`]), and their kd-tree.
fn indexed(
    points: &[[f32; 3]],
    role: Role,
    settings: &IcpSettings,
) -> Result<(Vec<[f32; 3]>, KdTree), IcpError> {
    settings.validate()?;
    let points = prepare(points, role, settings)?;
    let tree = KdTree::new(&points);
    Ok((points, tree))
}

/// Rejects non-finite points, downsamples, then rejects clouds too small or without spread.
fn prepare(
    points: &[[f32; 3]],
    role: Role,
    settings: &IcpSettings,
) -> Result<Vec<[f32; 3]>, IcpError> {
    if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(IcpError::NonFinitePoint { cloud: role, index });
    }
    let points = match settings.voxel {
        Some(voxel) => Cloud::from_points(points.to_vec()).voxel_downsampled(voxel).points,
        None => points.to_vec(),
    };
    if points.len() < MIN_POINTS {
        return Err(IcpError::TooFewPoints {
            cloud: role,
            count: points.len(),
            required: MIN_POINTS,
        });
    }
    check_spread(&points).map_err(|reason| IcpError::Degenerate { cloud: role, reason })?;
    Ok(points)
}

/// `Err` with the reason when the points coincide or lie on one line.
fn check_spread(points: &[[f32; 3]]) -> Result<(), &'static str> {
    // Covariance relative to the first point, for precision far from the origin.
    let origin = Vector3::from(points[0].map(f64::from));
    let (mut sum, mut sum_sq) = (Vector3::zeros(), Matrix3::zeros());
    for p in points {
        let d = Vector3::from(p.map(f64::from)) - origin;
        sum += d;
        sum_sq += d * d.transpose();
    }
    let n = points.len() as f64;
    let covariance = sum_sq / n - (sum / n) * (sum / n).transpose();
    let eig = SymmetricEigen::try_new(covariance, f64::EPSILON, 1000)
        .ok_or("its spread cannot be computed")?;
    let mut values: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    values.sort_by(|a, b| b.total_cmp(a));
    if !values[0].is_finite() {
        return Err("its spread is not finite");
    }
    if values[0] <= MIN_VARIANCE {
        return Err("all points coincide");
    }
    if values[1].max(0.0) <= MIN_SPREAD_RATIO * MIN_SPREAD_RATIO * values[0] {
        return Err("all points lie on one line");
    }
    Ok(())
}
