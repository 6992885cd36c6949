//! CAD-informed registration (GMMCalib's CADCalib, TUMFTM/GMMCalib `src/cad_calib.py`): every
//! sensor's points are registered to a Gaussian mixture whose centres are FIXED samples of a
//! CAD mesh already placed in the vehicle frame, so the calibration is anchored to the known
//! geometry rather than to a mixture that floats with the data (as in [`crate::jrmpc`]).
//!
//! Following CADCalib (the `cad_calib.py` of commit df14b9c, whose anisotropy is the
//! percentile rule below; commit 77c1ba5 maps the curvature through a sigmoid instead):
//! - centre `k` has the precision `(I + a_k n_k n_k^T) / sigma^2`, one global `sigma^2`, its
//!   anisotropy `a_k` from the surface's curvature ([`CadModel::from_samples`]): flat faces act
//!   point-to-plane, edges point-to-point;
//! - the priors `1 / (K (gamma + 1))` with GMMBase's `gamma = 0.1`, the centre weights
//!   `F_k = f_X pk sqrt(1 + a_k)` and the uniform outlier class (ratio `outlier_weight`, over
//!   the bounding volume of all points and centres), whose constant `f_X` is fixed at the
//!   initial sigma; the initial `sigma^2` is the squared diagonal of that bounding box;
//! - each sensor has one rigid transform shared by all its views, starting at the identity
//!   (the views are pre-aligned); the M-step takes damped Gauss-Newton steps (2, damping 1e-6)
//!   on `sum_ik r_ik (T p_i - c_k)^T Lambda_k (T p_i - c_k)` with the responsibilities fixed,
//!   then re-estimates `sigma^2 = sum r d^T Lambda d / (3 sum r)` with
//!   `Lambda_k = I + a_k n_k n_k^T`. The centres never move.
//!
//! Where it differs, and why:
//! - the E-step is sparse: only centres within `radius_sigmas * sigma` of a point are
//!   evaluated (a grid of the centres), and of those only terms within that Mahalanobis
//!   distance; every Gaussian's broadest axis is `sigma`, so the isotropic bound misses no
//!   term that is kept. CADCalib evaluates every point against every centre (points x K per
//!   iteration). While sigma is large (the first iterations from the bounding box's diagonal)
//!   the ball still holds every centre, and those iterations take most of a run's time;
//! - the terms' exps are evaluated in f32 (about 1e-7 relative), their sums in f64;
//! - it stops once no parameter (a sensor's rotation in rad, its translation at its points'
//!   centroid in m, or sigma in m) changes by more than `tolerance` in an iteration, with
//!   `max_iterations` as a cap; CADCalib runs a fixed 100;
//! - any number of sensors, each view assigned explicitly (CADCalib: two sensors, views split
//!   in halves);
//! - the Gauss-Newton increment is a rotation about the centres' centroid and a shift in the
//!   vehicle frame (left-multiplied), not CADCalib's increment in the sensor frame
//!   (right-multiplied): the same stationary point, a better conditioned system; and each
//!   point's responsibilities are reduced to a few sums, so the two steps cost O(points),
//!   not O(points x K);
//! - sigma^2 is floored (`variance_floor`), so it cannot collapse on noiseless data, and
//!   stays as it is when no point has any support (CADCalib would set it to 0).

mod em;
mod model;

use std::fmt;

use nalgebra::Vector3;

pub use model::CadModel;

use crate::jrmpc::Control;
use crate::se3::Pose;
use em::{Grid, Mixture, Scratch, Summary};

/// GMMBase's `gamma` (`gmm_base.py`, `_initialize_common_parameters`): the priors are
/// `1 / (K (gamma + 1))`.
const GAMMA: f64 = 0.1;

/// Registration settings. Defaults are CADCalib's where it has them.
#[derive(Clone, Debug, PartialEq)]
pub struct CadSettings {
    /// Upper bound on EM iterations (CADCalib runs exactly 100).
    pub max_iterations: usize,
    /// Stop once no sensor's rotation (rad) or translation at its points' centroid (m), nor
    /// sigma (m), changes by more than this in one iteration. 0 runs all `max_iterations`.
    pub tolerance: f64,
    /// CADCalib's outlier ratio `w` (0.1), in [0, 1).
    pub outlier_weight: f64,
    /// Largest anisotropy, given to flat faces (CADCalib's `alimit`, 30; about 10 suits noisy
    /// real data). Used by [`CadModel::from_samples`]; kept here so one settings value
    /// describes a run.
    pub a_max: f64,
    /// Initial sigma (m). `None`: CADCalib's rule, the diagonal of the bounding box of all
    /// points and centres.
    pub initial_sigma: Option<f64>,
    /// Lower bound on sigma^2 (m^2).
    pub variance_floor: f64,
    /// Added to the Gauss-Newton system's diagonal (CADCalib: 1e-6).
    pub damping: f64,
    /// Gauss-Newton steps per M-step (CADCalib: 2).
    pub gauss_newton_steps: usize,
    /// The E-step's radius in sigmas: terms farther (in Mahalanobis distance) are skipped.
    pub radius_sigmas: f64,
}

impl Default for CadSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-7,
            outlier_weight: 0.1,
            a_max: 30.0,
            initial_sigma: None,
            variance_floor: 1e-6,
            damping: 1e-6,
            gauss_newton_steps: 2,
            radius_sigmas: 3.5,
        }
    }
}

/// What the progress callback sees after each iteration, and the history keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CadIteration {
    /// 1-based iteration just completed.
    pub iteration: usize,
    /// Sigma after the iteration (m).
    pub sigma: f64,
    /// Largest parameter change in the iteration: a rotation (rad), a translation at a
    /// sensor's points' centroid (m) or sigma's (m).
    pub max_change: f64,
}

/// The outcome of a registration.
#[derive(Clone, Debug)]
pub struct CadRegistration {
    /// Per sensor: maps the sensor's (already pre-aligned) points onto the model.
    pub poses: Vec<Pose>,
    /// Per copy of the model: maps its centres as given onto where the data put them (the
    /// identity without [`Copies`]).
    pub copies: Vec<Pose>,
    /// Final sigma (m).
    pub sigma: f64,
    /// Iterations run.
    pub iterations: usize,
    /// The tolerance was reached before `max_iterations`.
    pub converged: bool,
    /// The progress callback asked to stop.
    pub cancelled: bool,
    /// One entry per iteration run.
    pub history: Vec<CadIteration>,
    /// Per sensor: its points with any centre within reach at the last E-step.
    pub support: Vec<usize>,
    /// Per sensor: the anisotropic RMS residual `sqrt(sum r d^T (I + a n n^T) d / sum r)` (m)
    /// at the final poses with the last responsibilities; 0 without support.
    pub rms: Vec<f64>,
}

/// Why a registration could not start.
#[derive(Clone, Debug, PartialEq)]
pub enum CadError {
    /// The model has no centre.
    NoCentres,
    /// No view of this sensor has a point.
    NoPoints { sensor: usize },
    /// Point `index` of view `view` has a coordinate that is not finite.
    NonFinitePoint { view: usize, index: usize },
    /// The named setting or input is out of range: a field of [`CadSettings`], `"model"`
    /// (arrays of different lengths, a value that is not finite, a negative anisotropy),
    /// `"sensors"` (0), `"sensor_of_view"` (a length or a sensor out of range) or `"views"`
    /// (more than `u32::MAX` points).
    InvalidSetting(&'static str),
}

impl fmt::Display for CadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoCentres => write!(f, "the CAD model has no centres"),
            Self::NoPoints { sensor } => write!(f, "sensor {sensor} has no points"),
            Self::NonFinitePoint { view, index } => {
                write!(f, "view {view}: point {index} is not finite")
            }
            Self::InvalidSetting(what) => write!(f, "invalid setting: {what}"),
        }
    }
}

impl std::error::Error for CadError {}

/// What is registered: every view's points, already pre-aligned into the vehicle frame by the
/// nominal extrinsics, and the sensor of each view (in `0..sensors`); all of a sensor's views
/// share its one transform.
#[derive(Clone, Copy, Debug)]
pub struct CadViews<'a> {
    pub points: &'a [&'a [[f32; 3]]],
    pub sensor_of: &'a [usize],
    pub sensors: usize,
}

/// The model's copies, when the data refine where each one stands (our placement comes from
/// the reference's points, not from a survey): which copy each centre and each view belongs
/// to, and the sensor held at the identity so that the problem keeps one frame, its own.
#[derive(Clone, Copy, Debug)]
pub struct Copies<'a> {
    /// Copy of each centre of the model, numbered from 0.
    pub of_centre: &'a [usize],
    /// Copy of each view: a view holds the points of one sensor near one copy.
    pub of_view: &'a [usize],
    /// The sensor whose pose stays the identity.
    pub fixed_sensor: usize,
    /// Copies move once sigma is below this (m): while it is wider, the responsibilities blur
    /// a copy's shape into a blob whose turn nothing holds.
    pub below_sigma: f64,
}

/// The ground the targets stand on, in the fixed sensor's frame: an unbounded flat face of the
/// model with a flat face's precision across it and none along it. Targets a few decimetres
/// tall hold the tilt about themselves only weakly (at 12 m a 0.1 deg tilt about them moves a
/// sensor 2 cm), the ground holds it at every metre of its extent, as levelling does.
#[derive(Clone, Copy, Debug)]
pub struct Ground<'a> {
    /// Unit normal and offset of the plane `n . p + offset = 0` (vehicle frame).
    pub normal: [f64; 3],
    pub offset: f64,
    /// Points on the ground, pre-aligned like the views, and the sensor of each list.
    pub points: &'a [&'a [[f32; 3]]],
    pub sensor_of: &'a [usize],
}

/// Registers every sensor to the CAD mixture.
///
/// Without `copies` the centres stay where
/// they are (CADCalib); with them each copy of the model moves rigidly with the points of
/// every sensor near it, and one sensor stays fixed. `progress` runs after every iteration and
/// may stop the run (`Control::Stop`). Deterministic.
pub fn register(
    input: &CadViews,
    model: &CadModel,
    copies: Option<&Copies>,
    ground: Option<&Ground>,
    settings: &CadSettings,
    mut progress: impl FnMut(&CadIteration) -> Control,
) -> Result<CadRegistration, CadError> {
    let CadViews { points: views, sensor_of: sensor_of_view, sensors } = *input;
    validate(views, sensor_of_view, sensors, model, settings)?;
    let mut ground_points: Vec<Vec<Vector3<f64>>> = vec![Vec::new(); sensors];
    if let Some(g) = ground {
        let n = Vector3::from(g.normal);
        if !(g.offset.is_finite()
            && n.iter().all(|c| c.is_finite())
            && (n.norm() - 1.0).abs() < 1e-6)
        {
            return Err(CadError::InvalidSetting("ground"));
        }
        if g.sensor_of.len() != g.points.len() || g.sensor_of.iter().any(|&s| s >= sensors) {
            return Err(CadError::InvalidSetting("ground.sensor_of"));
        }
        for (list, &s) in g.points.iter().zip(g.sensor_of) {
            ground_points[s].extend(
                list.iter()
                    .filter(|p| p.iter().all(|c| c.is_finite()))
                    .map(|p| Vector3::from(p.map(f64::from))),
            );
        }
    }
    // A flat face's precision across the plane, in the same units as the model's terms.
    let ground_lambda = 1.0 + settings.a_max;
    let (mut gathered_points, mut gathered_summaries) = (Vec::new(), Vec::new());
    if let Some(c) = copies {
        if c.of_centre.len() != model.len() {
            return Err(CadError::InvalidSetting("copies.of_centre"));
        }
        if c.of_view.len() != views.len() {
            return Err(CadError::InvalidSetting("copies.of_view"));
        }
        if c.fixed_sensor >= sensors {
            return Err(CadError::InvalidSetting("copies.fixed_sensor"));
        }
    }
    let count =
        copies.map_or(1, |c| c.of_centre.iter().chain(c.of_view).max().map_or(1, |m| m + 1));
    let copy_of_view = |v: usize| copies.map_or(0, |c| c.of_view[v]);
    let centres_of: Vec<Vec<usize>> = (0..count)
        .map(|c| {
            (0..model.len()).filter(|&k| copies.map_or(0, |cs| cs.of_centre[k]) == c).collect()
        })
        .collect();

    // Raw points (f64), grouped by sensor: sensor s owns points[ranges[s]]; and by copy.
    let mut points: Vec<Vector3<f64>> = Vec::new();
    let mut copy_of_point: Vec<usize> = Vec::new();
    let mut ranges = Vec::with_capacity(sensors);
    for s in 0..sensors {
        let start = points.len();
        for (v, (view, _)) in
            views.iter().zip(sensor_of_view).enumerate().filter(|(_, (_, of))| **of == s)
        {
            points.extend(view.iter().map(|p| Vector3::from(p.map(f64::from))));
            copy_of_point.resize(points.len(), copy_of_view(v));
        }
        ranges.push(start..points.len());
    }
    let sensor_of_point: Vec<usize> =
        ranges.iter().enumerate().flat_map(|(s, r)| r.clone().map(move |_| s)).collect();
    let points_of: Vec<Vec<usize>> = (0..count)
        .map(|c| (0..points.len()).filter(|&i| copy_of_point[i] == c).collect())
        .collect();
    let centroids: Vec<Vector3<f64>> = ranges
        .iter()
        .map(|r| points[r.clone()].iter().sum::<Vector3<f64>>() / r.len() as f64)
        .collect();
    let copy_centroids: Vec<Vector3<f64>> = centres_of
        .iter()
        .map(|ks| {
            ks.iter().map(|&k| model.centres[k]).sum::<Vector3<f64>>() / ks.len().max(1) as f64
        })
        .collect();

    // CADCalib `_initialize_distribution_parameters` and `_initialize_bounding_volume`: the
    // box of all (identity-transformed) points and all centres; sigma^2 = its squared diagonal.
    let (volume, diagonal2) = em::bounding_box(points.iter().chain(&model.centres).copied());
    let sigma2_start = match settings.initial_sigma {
        Some(s) => s * s,
        None => diagonal2,
    }
    .max(settings.variance_floor);
    let mut sigma2 = sigma2_start;
    // The mixture's constants stay those of the initial sigma (CADCalib); only moved copies
    // rebuild it, with the same constants.
    let mut mixture = Mixture::new(model, GAMMA, settings.outlier_weight, sigma2, volume);
    let mut copy_poses = vec![Pose::identity(); count];
    let fixed = copies.map(|c| c.fixed_sensor);

    let mut poses = vec![Pose::identity(); sensors];
    let mut xs = vec![Vector3::zeros(); points.len()];
    let mut summaries = vec![Summary::default(); points.len()];
    let mut scratch = Scratch::default();
    let (mut copy_xs, mut copy_summaries) = (Vec::new(), Vec::new());
    let mut support = vec![0usize; sensors];
    let mut rms = vec![0.0; sensors];
    let mut history = Vec::new();
    let (mut converged, mut cancelled) = (false, false);

    for iteration in 1..=settings.max_iterations {
        // E-step over every point of every view, at the current poses, each point against
        // its own copy's centres.
        let sigma = sigma2.sqrt();
        let origin = mixture.origin;
        for (pose, range) in poses.iter().zip(&ranges) {
            for (x, y) in xs[range.clone()].iter_mut().zip(&points[range.clone()]) {
                *x = pose.transform_point(&(*y).into()).coords - origin;
            }
        }
        let outlier = mixture.outlier_term(sigma2);
        for (ks, members) in centres_of.iter().zip(&points_of) {
            let grid = Grid::new(&mixture.subset(ks), settings.radius_sigmas * sigma);
            copy_xs.clear();
            copy_xs.extend(members.iter().map(|&i| xs[i]));
            copy_summaries.resize(members.len(), Summary::default());
            grid.e_step(&copy_xs, 0.5 / sigma2, outlier, &mut scratch, &mut copy_summaries);
            for (&i, summary) in members.iter().zip(&copy_summaries) {
                summaries[i] = *summary;
            }
        }

        // M-step: each sensor's pose, each copy's, then sigma^2 (CADCalib `m_step`).
        let previous = poses.clone();
        for (s, range) in ranges.iter().enumerate() {
            if fixed == Some(s) {
                continue;
            }
            gathered_points.clear();
            gathered_points.extend_from_slice(&points[range.clone()]);
            gathered_points.extend_from_slice(&ground_points[s]);
            gathered_summaries.clear();
            gathered_summaries.extend_from_slice(&summaries[range.clone()]);
            if let Some(g) = ground {
                let n = Vector3::from(g.normal);
                let on_plane = -n * g.offset - origin;
                let term = Summary::plane(&n, &on_plane, ground_lambda);
                gathered_summaries.resize(gathered_points.len(), term);
            }
            em::gauss_newton(
                &mut poses[s],
                &origin,
                &gathered_points,
                &gathered_summaries,
                settings.gauss_newton_steps,
                settings.damping,
            );
        }
        // Moving a copy by M against its centres equals moving its points by M^-1 against
        // them as they stand (the precisions turn with the copy), so each copy takes the same
        // Gauss-Newton steps as a sensor, on every sensor's points near it.
        let mut moves = vec![Pose::identity(); count];
        let copies_move = copies.is_some_and(|c| sigma < c.below_sigma);
        if copies_move {
            for (c, members) in points_of.iter().enumerate() {
                let at: Vec<Vector3<f64>> = members
                    .iter()
                    .map(|&i| poses[sensor_of_point[i]].transform_point(&points[i].into()).coords)
                    .collect();
                copy_summaries.clear();
                copy_summaries.extend(members.iter().map(|&i| summaries[i]));
                em::gauss_newton(
                    &mut moves[c],
                    &origin,
                    &at,
                    &copy_summaries,
                    settings.gauss_newton_steps,
                    settings.damping,
                );
            }
        }
        let (mut num_all, mut den_all) = (0.0, 0.0);
        for (s, range) in ranges.iter().enumerate() {
            let (mut num, mut den) = (0.0, 0.0);
            for i in range.clone() {
                let summary = &summaries[i];
                if summary.w > 0.0 {
                    let at = poses[s].transform_point(&points[i].into());
                    let x = moves[copy_of_point[i]].transform_point(&at).coords - origin;
                    num += summary.anisotropic_sq(&x);
                    den += summary.w;
                }
            }
            support[s] = summaries[range.clone()].iter().filter(|summary| summary.w > 0.0).count();
            rms[s] = if den > 0.0 { (num / den).sqrt() } else { 0.0 };
            num_all += num;
            den_all += den;
        }
        // sigma^2 = sum r d^T Lambda d / (3 sum r + 1e-12); without any support there is
        // nothing to estimate it from, and it stays.
        if den_all > 0.0 {
            sigma2 = (num_all / (3.0 * den_all + 1e-12)).max(settings.variance_floor);
        }

        let mut max_change = (sigma2.sqrt() - sigma).abs();
        for ((now, before), centroid) in poses.iter().zip(&previous).zip(&centroids) {
            let c = (*centroid).into();
            let shift = (now.transform_point(&c) - before.transform_point(&c)).norm();
            max_change = max_change.max(before.rotation.angle_to(&now.rotation)).max(shift);
        }
        if copies_move {
            for ((copy, m), centroid) in copy_poses.iter_mut().zip(&moves).zip(&copy_centroids) {
                let at = copy.transform_point(&(*centroid).into());
                let shift = (m.inverse_transform_point(&at) - at).norm();
                max_change = max_change.max(m.rotation.angle()).max(shift);
                *copy = m.inverse() * *copy;
            }
            mixture = Mixture::new(
                &moved(model, &copy_poses, |k| copies.map_or(0, |c| c.of_centre[k])),
                GAMMA,
                settings.outlier_weight,
                sigma2_start,
                volume,
            );
        }
        let record = CadIteration { iteration, sigma: sigma2.sqrt(), max_change };
        history.push(record);
        converged = max_change < settings.tolerance;
        if progress(&record) == Control::Stop {
            cancelled = true;
            break;
        }
        if converged {
            break;
        }
    }

    Ok(CadRegistration {
        poses,
        copies: copy_poses,
        sigma: sigma2.sqrt(),
        iterations: history.len(),
        converged,
        cancelled,
        history,
        support,
        rms,
    })
}

/// The model with each centre (and its normal) carried by its copy's pose.
fn moved(model: &CadModel, poses: &[Pose], copy_of: impl Fn(usize) -> usize) -> CadModel {
    let (mut centres, mut normals) =
        (Vec::with_capacity(model.len()), Vec::with_capacity(model.len()));
    for k in 0..model.len() {
        let pose = &poses[copy_of(k)];
        centres.push(pose.transform_point(&model.centres[k].into()).coords);
        normals.push(pose.rotation * model.normals[k]);
    }
    CadModel { centres, normals, anisotropy: model.anisotropy.clone() }
}

fn validate(
    views: &[&[[f32; 3]]],
    sensor_of_view: &[usize],
    sensors: usize,
    model: &CadModel,
    settings: &CadSettings,
) -> Result<(), CadError> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if settings.max_iterations == 0 {
        return Err(CadError::InvalidSetting("max_iterations"));
    }
    if !(settings.tolerance.is_finite() && settings.tolerance >= 0.0) {
        return Err(CadError::InvalidSetting("tolerance"));
    }
    if !(settings.outlier_weight.is_finite() && (0.0..1.0).contains(&settings.outlier_weight)) {
        return Err(CadError::InvalidSetting("outlier_weight"));
    }
    if !(settings.a_max.is_finite() && settings.a_max >= 0.0) {
        return Err(CadError::InvalidSetting("a_max"));
    }
    if settings.initial_sigma.is_some_and(|s| !positive(s)) {
        return Err(CadError::InvalidSetting("initial_sigma"));
    }
    if !positive(settings.variance_floor) {
        return Err(CadError::InvalidSetting("variance_floor"));
    }
    if !(settings.damping.is_finite() && settings.damping >= 0.0) {
        return Err(CadError::InvalidSetting("damping"));
    }
    if !positive(settings.radius_sigmas) {
        return Err(CadError::InvalidSetting("radius_sigmas"));
    }
    if model.is_empty() {
        return Err(CadError::NoCentres);
    }
    if model.normals.len() != model.len() || model.anisotropy.len() != model.len() {
        return Err(CadError::InvalidSetting("model"));
    }
    let finite = |v: &Vector3<f64>| v.iter().all(|c| c.is_finite());
    if !model.centres.iter().all(finite)
        || !model.normals.iter().all(finite)
        || !model.anisotropy.iter().all(|a| a.is_finite() && *a >= 0.0)
    {
        return Err(CadError::InvalidSetting("model"));
    }
    if sensors == 0 {
        return Err(CadError::InvalidSetting("sensors"));
    }
    if sensor_of_view.len() != views.len() || sensor_of_view.iter().any(|&s| s >= sensors) {
        return Err(CadError::InvalidSetting("sensor_of_view"));
    }
    // The E-step indexes points with u32.
    if views.iter().map(|v| v.len()).sum::<usize>() > u32::MAX as usize {
        return Err(CadError::InvalidSetting("views"));
    }
    for (view, points) in views.iter().enumerate() {
        if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(CadError::NonFinitePoint { view, index });
        }
    }
    let mut has_points = vec![false; sensors];
    for (points, &s) in views.iter().zip(sensor_of_view) {
        has_points[s] |= !points.is_empty();
    }
    if let Some(sensor) = has_points.iter().position(|h| !h) {
        return Err(CadError::NoPoints { sensor });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
