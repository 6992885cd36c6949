//! Views from several sensors -> sensor-to-sensor calibration.
//!
//! 1. pre-align each view's raw points with its sensor's nominal `T_vehicle_sensor`;
//! 2. crop to the region of interest (views left with too few points are skipped and reported);
//! 3. per frame, the correction `C_ref_s(f)` that maps sensor s's pre-aligned points onto the
//!    reference sensor's, by the chosen [`Method`] (frames that lack either sensor are skipped):
//!    - `jrmpc`: register all views jointly to one floating mixture, starting from the target
//!      prior at the ROI centroid; `C_ref_s(f) = T_ref,f^-1 T_s,f`;
//!    - `gmm` (default): `jrmpc`, then GICP of each frame onto the reference's
//!      same frame from the JRMPC correction (README, "Why refine"), then one joint plane
//!      adjustment of every sensor over all frames (`planes`);
//!    - `p2p`, `p2l`, `gicp`: ICP of each frame onto the reference's, from the nominal;
//! 4. average over frames (chordal mean rotation, mean translation) with per-axis spread,
//!    leaving out and reporting frames far from the others;
//! 5. fit the prior shape to each target among the reconstructed means, a plausibility check.

mod average;
mod bev;
mod error;
mod level;
mod planes;
pub mod refine;
mod settings;

use nalgebra::Vector3;

use crate::cloud::{Aabb, Cloud};
use crate::jrmpc::{self, Control};
use crate::se3::Pose;
use crate::target_fit::{ShapeFit, fit_targets};
use average::{average, robust_average};
pub use bev::{BevAlignment, BevSettings};
pub use error::CalibError;
pub use level::{GroundSettings, Levelling, Plane};
pub use planes::{PlaneSettings, Precision};
pub use refine::{FrameCorrections, RefineSettings, Refinement};
pub use settings::{InitialSigma, Method, Settings};

/// One scan: points `x, y, z` in the sensor's own frame (m).
#[derive(Clone, Debug)]
pub struct View {
    pub sensor: String,
    pub frame: String,
    pub points: Vec<[f32; 3]>,
}

/// Everything about the rig the user supplies.
#[derive(Clone, Debug)]
pub struct Rig {
    pub views: Vec<View>,
    /// Nominal `T_vehicle_sensor` per sensor.
    pub nominal: Vec<(String, Pose)>,
    /// Region of interest in the vehicle frame (m), bounds inclusive.
    pub roi: Aabb,
    /// The sensor the others are calibrated to; default: the sensor of the first view.
    pub reference: Option<String>,
}

/// Per-axis standard deviation of the per-frame corrections around their mean.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    /// Translation, m.
    pub xyz: [f64; 3],
    /// Rotation about x, y, z (rad), from the rotation vector of `mean^-1 C(f)`.
    pub rpy: [f64; 3],
    /// Frames averaged.
    pub frames: usize,
}

#[derive(Clone, Debug)]
pub struct SensorResult {
    pub name: String,
    /// `C_ref_s`: maps this sensor's nominally pre-aligned points onto the reference's.
    pub correction: Pose,
    /// Corrected `T_vehicle_sensor = C_ref_s * T_vehicle_sensor_nominal`.
    pub extrinsic: Pose,
    /// `T_ref_s`: maps points from this sensor's frame into the reference sensor's frame.
    pub relative: Pose,
    pub spread: Spread,
    /// `gmm`: the plane adjustment's one-sigma uncertainty, when it applied its motion.
    pub precision: Option<Precision>,
}

/// The reconstructed target: the final mixture, mapped into the reference sensor's pre-aligned
/// (vehicle) frame by the mean of the reference views' JRMPC poses.
#[derive(Clone, Debug)]
pub struct Target {
    pub means: Vec<[f64; 3]>,
    /// Standard deviations (m).
    pub sigmas: Vec<f64>,
    pub priors: Vec<f64>,
    /// The prior shape fitted to each target among the means, off the reference's ground,
    /// largest first (empty for user-given means and ICP methods, which reconstruct nothing).
    pub fits: Vec<ShapeFit>,
}

#[derive(Clone, Debug)]
pub struct FrameNote {
    pub sensor: String,
    pub frame: String,
    pub reason: String,
}

#[derive(Clone, Debug)]
pub struct Calibration {
    pub method: Method,
    pub reference: String,
    pub sensors: Vec<SensorResult>,
    pub target: Target,
    pub iterations: usize,
    pub converged: bool,
    pub cancelled: bool,
    /// Views left out (too few points in the ROI, failed registration).
    pub skipped: Vec<FrameNote>,
    /// `gmm` frames whose refinement was rejected; they keep the JRMPC correction.
    pub kept_jrmpc: Vec<FrameNote>,
    /// `gmm`'s plane adjustment, per non-reference sensor: the motion it applied to every
    /// frame, or why the refinement was kept (frame `all`); empty when it is off.
    pub plane_adjustment: Vec<FrameNote>,
    /// Per sensor, the ground found and the levelling applied; empty when levelling is off.
    pub levelling: Vec<Levelling>,
    pub history: Vec<jrmpc::IterationStats>,
}

/// Which step a [`Progress`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// JRMPC's EM: `iteration` of `max_iterations`, with `mean_sigma` and `max_change`.
    Jrmpc,
    /// The frame pairs' ICP (`gmm`'s refinement, the ICP methods): `iteration` pairs done of
    /// `max_iterations`; `mean_sigma` and `max_change` are 0.
    FramePairs,
}

impl Stage {
    /// `"jrmpc"` or `"framePairs"`, as JS sees it.
    pub fn name(&self) -> &'static str {
        match self {
            Stage::Jrmpc => "jrmpc",
            Stage::FramePairs => "framePairs",
        }
    }
}

/// What the progress callback sees after each EM iteration and each frame pair.
pub struct Progress<'a> {
    pub stage: Stage,
    pub iteration: usize,
    pub max_iterations: usize,
    pub mean_sigma: f64,
    pub max_change: f64,
    /// Current `C_ref_s` per sensor, in the order of `Calibration::sensors`.
    pub corrections: &'a [Pose],
}

/// Calibrates every sensor of `rig` to the reference sensor: [`prepare`], JRMPC for the
/// methods that use it, then [`Prepared::finish`].
pub fn calibrate(
    rig: &Rig,
    settings: &Settings,
    mut progress: impl FnMut(&Progress) -> Control,
) -> Result<Calibration, CalibError> {
    let prepared = prepare(rig, settings)?;
    let registration = if settings.method.uses_jrmpc() {
        let input = prepared.jrmpc_input();
        let registration = jrmpc::register(&input.clouds, &input.means, &input.settings, |p| {
            progress(&Progress {
                stage: Stage::Jrmpc,
                iteration: p.iteration,
                max_iterations: input.settings.max_iterations,
                mean_sigma: p.mean_sigma,
                max_change: p.max_change,
                corrections: &prepared.jrmpc_corrections(&p.poses),
            })
        })?;
        Some(registration)
    } else {
        None
    };
    prepared.finish(registration, progress)
}

/// A rig checked, levelled and cropped (steps 1 and 2), ready for the registration; owns what
/// the later steps need, so a caller can drive JRMPC itself ([`Prepared::start_jrmpc`], e.g.
/// over several workers) and then [`Prepared::finish`].
pub struct Prepared {
    settings: Settings,
    sensors: Vec<String>,
    reference: String,
    /// Index of the reference in `sensors`.
    r: usize,
    /// Nominal `T_vehicle_sensor`, per sensor.
    nominals: Vec<Pose>,
    levelling: Vec<Levelling>,
    /// The levelling applied on top of each sensor's nominal (identity without levelling).
    applied: Vec<Pose>,
    /// Each sensor's levelled nominal, `applied * nominal`: what its points are pre-aligned by.
    pre_aligned: Vec<Pose>,
    /// The views left after cropping: (sensor index, frame, cloud).
    usable: Vec<(usize, String, Cloud)>,
    skipped: Vec<FrameNote>,
    /// Per sensor, its (reference view, sensor view) pairs; see [`frame_pairs`].
    pairs: Vec<Vec<(usize, usize)>>,
    /// The reference's ground, for the target fit.
    ground: Option<Plane>,
}

/// What JRMPC registers: the cropped views, the prior's means at their centroid, and the EM
/// settings.
pub struct JrmpcInput<'a> {
    pub clouds: Vec<&'a [[f32; 3]]>,
    pub means: Vec<[f64; 3]>,
    pub settings: jrmpc::Settings,
}

/// Steps 1 and 2: checks the rig and the settings, levels and crops.
pub fn prepare(rig: &Rig, settings: &Settings) -> Result<Prepared, CalibError> {
    let sensors = sensor_order(rig)?;
    let reference = rig.reference.clone().unwrap_or_else(|| sensors[0].clone());
    if !sensors.contains(&reference) {
        return Err(CalibError::UnknownReference(reference));
    }
    if settings.components == 0 {
        return Err(CalibError::InvalidSetting("components must be at least 1"));
    }
    // Per sensor, in `sensors` order (`sensor_order` checked that each has one).
    let nominals: Vec<Pose> = sensors
        .iter()
        .map(|s| rig.nominal.iter().find(|(n, _)| n == s).map_or_else(Pose::identity, |(_, p)| *p))
        .collect();
    let r = sensors.iter().position(|n| n == &reference).unwrap_or(0);
    for view in &rig.views {
        if let Some(index) = view.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(CalibError::NonFinitePoint {
                sensor: view.sensor.clone(),
                frame: view.frame.clone(),
                index,
            });
        }
    }

    // 1. Pre-align, levelled onto the reference's ground when asked.
    let levelling = if settings.levels_ground() {
        level_grounds(rig, &sensors, &nominals, r, settings)
    } else {
        Vec::new()
    };
    let applied: Vec<Pose> = (0..sensors.len())
        .map(|s| levelling.get(s).map_or_else(Pose::identity, |l| l.applied))
        .collect();

    // 2. Crop.
    let pre_aligned: Vec<Pose> = applied.iter().zip(&nominals).map(|(a, n)| a * n).collect();
    let (usable, skipped) = crop_views(rig, &sensors, &pre_aligned, settings);
    for (s, name) in sensors.iter().enumerate() {
        if !usable.iter().any(|(u, _, _)| *u == s) {
            return Err(CalibError::NoPointsInRoi(name.clone()));
        }
    }
    let pairs = frame_pairs(&usable, sensors.len(), r);
    for (s, name) in sensors.iter().enumerate() {
        if pairs[s].is_empty() {
            return Err(CalibError::NoCommonFrames(name.clone()));
        }
    }
    // Without levelling, the reference's ground is found for the target fit alone.
    let ground = match levelling.get(r) {
        Some(l) => l.ground,
        None if settings.method.uses_jrmpc() => {
            sensor_ground(rig, &sensors, &nominals, r, settings).1.map(|(g, _)| g)
        }
        None => None,
    };
    Ok(Prepared {
        settings: settings.clone(),
        sensors,
        reference,
        r,
        nominals,
        levelling,
        applied,
        pre_aligned,
        usable,
        skipped,
        pairs,
        ground,
    })
}

impl Prepared {
    /// Sensor names, in result order.
    pub fn sensors(&self) -> &[String] {
        &self.sensors
    }

    /// Step 3's JRMPC input: the cropped views, the prior's means at their centroid, and
    /// the EM settings.
    pub fn jrmpc_input(&self) -> JrmpcInput<'_> {
        let settings = &self.settings;
        let clouds: Vec<&[[f32; 3]]> =
            self.usable.iter().map(|(_, _, c)| c.points.as_slice()).collect();
        let centre =
            crate::cloud::centroid(clouds.iter().flat_map(|c| c.iter())).unwrap_or([0.0; 3]);
        let means = settings.prior.means(settings.components, centre, settings.seed);
        let jrmpc_settings = jrmpc::Settings {
            initial_sigma: match settings.initial_sigma {
                InitialSigma::PriorSize => settings.prior.size(),
                InitialSigma::BoundingBox => None,
                InitialSigma::Fixed(sigma) => Some(sigma),
            },
            ..settings.jrmpc.clone()
        };
        JrmpcInput { clouds, means, settings: jrmpc_settings }
    }

    /// JRMPC on [`Prepared::jrmpc_input`], to be driven step by step (see [`jrmpc::register`]).
    pub fn start_jrmpc(&self) -> Result<(jrmpc::Em, jrmpc::CentredViews), CalibError> {
        let input = self.jrmpc_input();
        Ok(jrmpc::Em::start(&input.clouds, &input.means, &input.settings)?)
    }

    /// The running correction per sensor from JRMPC's views' poses: the mean over frames of
    /// `T_ref,f^-1 T_s,f`, levelling included.
    pub fn jrmpc_corrections(&self, poses: &[Pose]) -> Vec<Pose> {
        self.pairs
            .iter()
            .zip(&self.applied)
            .map(|(frames, levelled)| {
                let per_frame: Vec<Pose> =
                    frames.iter().map(|&(r, s)| poses[r].inverse() * poses[s]).collect();
                average(&per_frame).map_or_else(Pose::identity, |(c, _)| c) * levelled
            })
            .collect()
    }

    /// The cropped, pre-aligned views, numbered as the refinement's jobs number them.
    pub fn clouds(&self) -> Vec<&[[f32; 3]]> {
        self.usable.iter().map(|(_, _, c)| c.points.as_slice()).collect()
    }

    /// Corrections of the pre-aligned clouds, one per sensor, as the caller sees them: of the
    /// nominal pre-alignment, levelling included.
    pub fn levelled(&self, corrections: &[Pose]) -> Vec<Pose> {
        corrections.iter().zip(&self.applied).map(|(c, l)| c * l).collect()
    }

    /// Step 3's frame pairs, for the methods that register them: `gmm`'s refinement from
    /// `registration`'s corrections, the ICP methods from the nominal; `None` for `jrmpc`.
    /// [`Prepared::finish`] runs them here; a caller may run them itself, e.g. on several
    /// workers, and hand them to [`Prepared::finish_with`].
    pub fn refinement(&self, registration: Option<&jrmpc::Registration>) -> Option<Refinement> {
        let settings = &self.settings;
        let plan = match settings.method {
            Method::Gmm => refine::Plan {
                method: settings.refine.method,
                settings: settings.refine.icp.clone(),
                match_distances: settings.refine.match_distances.clone(),
                early_tolerance: settings.refine.early_tolerance,
                max_departure: Some(settings.refine.max_departure),
                ground: self.reference_ground(),
            },
            Method::Icp(method) => refine::Plan {
                method,
                settings: settings.icp.clone(),
                match_distances: vec![settings.icp.max_correspondence_distance],
                early_tolerance: None,
                max_departure: None,
                ground: None,
            },
            Method::Jrmpc => return None,
        };
        let starts = match registration {
            Some(registration) => jrmpc_per_frame(&self.pairs, registration),
            None => vec![Vec::new(); self.sensors.len()],
        };
        Some(Refinement::new(plan, &self.pairs, self.r, &starts))
    }

    /// The reference's levelled ground plane and the band whose points take its normal.
    fn reference_ground(&self) -> Option<(Plane, f64)> {
        let ground = self.levelling.get(self.r).and_then(|l| l.ground)?;
        Some((ground, self.settings.ground.normal_band))
    }

    /// Steps 3 (the per-frame corrections: from `registration` for the GMM methods, refined
    /// for `gmm`; by ICP for the others), 4 and 5. `progress` sees the refinement's pairs.
    pub fn finish(
        self,
        registration: Option<jrmpc::Registration>,
        mut progress: impl FnMut(&Progress) -> Control,
    ) -> Result<Calibration, CalibError> {
        let mut refinement = self.refinement(registration.as_ref());
        if let Some(refinement) = &mut refinement {
            let all = 0..refinement.jobs().len();
            // The same threads as JRMPC's (native).
            self.refine(refinement, all, self.settings.jrmpc.threads, &mut progress);
        }
        self.finish_with(registration, refinement)
    }

    /// Registers `refinement`'s pairs `jobs` here ([`Refinement::run`] on this rig's cropped
    /// views); `progress` sees the corrections as the caller does, levelling included.
    pub fn refine(
        &self,
        refinement: &mut Refinement,
        jobs: impl IntoIterator<Item = usize>,
        threads: usize,
        progress: &mut impl FnMut(&Progress) -> Control,
    ) {
        refinement.run(&self.clouds(), jobs, threads, &mut |p: &Progress| {
            let corrections = self.levelled(p.corrections);
            progress(&Progress { corrections: &corrections, ..*p })
        });
    }

    /// Steps 4 and 5, after step 3: `registration` for the GMM methods, and the frame pairs of
    /// [`Prepared::refinement`] as far as they were registered.
    pub fn finish_with(
        self,
        registration: Option<jrmpc::Registration>,
        refinement: Option<Refinement>,
    ) -> Result<Calibration, CalibError> {
        let reference_ground = self.reference_ground();
        let Self {
            settings,
            sensors,
            reference,
            r,
            nominals,
            levelling,
            applied,
            pre_aligned,
            usable,
            mut skipped,
            pairs,
            ground,
        } = self;
        let mut kept_jrmpc = Vec::new();
        let clouds: Vec<&[[f32; 3]]> = usable.iter().map(|(_, _, c)| c.points.as_slice()).collect();
        let mut per_frame = match (&refinement, &registration) {
            (Some(refinement), _) => {
                let (per_frame, failures) = refinement.corrections();
                for failure in failures {
                    let (sensor, frame, _) = &usable[failure.view];
                    let note = FrameNote {
                        sensor: sensors[*sensor].clone(),
                        frame: frame.clone(),
                        reason: failure.reason,
                    };
                    if failure.kept_start {
                        kept_jrmpc.push(note);
                    } else {
                        skipped.push(note);
                    }
                }
                per_frame
            }
            (None, Some(registration)) => jrmpc_per_frame(&pairs, registration),
            (None, None) => return Err(CalibError::InvalidSetting("no registration to finish")),
        };
        let mut precision = vec![None; sensors.len()];
        let plane_adjustment = match (&settings.planes, settings.method) {
            (Some(plane_settings), Method::Gmm) => {
                let plane = reference_ground.map(|(plane, _)| plane);
                // The clouds are pre-aligned: each sensor sits at its levelled nominal.
                let origins: Vec<Vector3<f64>> =
                    pre_aligned.iter().map(|p| p.translation.vector).collect();
                let outcomes = planes::adjust(
                    &clouds,
                    &origins,
                    &pairs,
                    r,
                    &mut per_frame,
                    plane,
                    plane_settings,
                );
                for o in outcomes.iter().filter(|o| o.accepted) {
                    precision[o.sensor] = o.precision;
                }
                outcomes.iter().map(|o| planes::note(o, &sensors[o.sensor])).collect()
            }
            _ => Vec::new(),
        };

        // 4. Average over frames.
        let reference_nominal = nominals[r];
        let mut results = Vec::with_capacity(sensors.len());
        for (s, name) in sensors.iter().enumerate() {
            let corrections: Vec<Pose> = per_frame[s].iter().map(|(_, c)| c * applied[s]).collect();
            let Some((correction, spread, outliers)) = robust_average(&corrections) else {
                return Err(CalibError::FramesFailed {
                    sensor: name.clone(),
                    reason: "every frame failed".into(),
                });
            };
            for i in outliers {
                let (_, view) = per_frame[s][i].0;
                let d = correction.inverse() * corrections[i];
                let reason = format!(
                    "left out of the average: {:.3} deg / {:.1} mm from the other frames",
                    d.rotation.angle().to_degrees(),
                    d.translation.vector.norm() * 1e3
                );
                let frame = usable[view].1.clone();
                skipped.push(FrameNote { sensor: name.clone(), frame, reason });
            }
            let extrinsic = correction * nominals[s];
            results.push(SensorResult {
                name: name.clone(),
                correction,
                extrinsic,
                relative: reference_nominal.inverse() * extrinsic,
                spread,
                precision: precision[s],
            });
        }

        // 5. Plausibility of the reconstruction.
        let (target, iterations, converged, cancelled, history) = match registration {
            Some(reg) => {
                let reference_views: Vec<usize> = pairs[r].iter().map(|&(v, _)| v).collect();
                let target = reconstruction(&reg, &reference_views, ground, &settings.prior);
                (target, reg.iterations, reg.converged, reg.cancelled, reg.history)
            }
            None => {
                let empty = Target { means: vec![], sigmas: vec![], priors: vec![], fits: vec![] };
                (empty, 0, true, false, vec![])
            }
        };
        Ok(Calibration {
            method: settings.method,
            reference,
            sensors: results,
            target,
            iterations,
            converged,
            cancelled,
            skipped,
            kept_jrmpc,
            plane_adjustment,
            levelling,
            history,
        })
    }
}

/// Per sensor, JRMPC's correction of each of its frame pairs: `T_ref,f^-1 T_s,f`.
fn jrmpc_per_frame(
    pairs: &[Vec<(usize, usize)>],
    registration: &jrmpc::Registration,
) -> Vec<FrameCorrections> {
    let poses = &registration.poses;
    pairs
        .iter()
        .map(|p| p.iter().map(|&(r, s)| ((r, s), poses[r].inverse() * poses[s])).collect())
        .collect()
}

/// Step 2: each view pre-aligned by its sensor's pose and cropped to the ROI, as
/// (sensor index, frame, cloud); views left with too few points are noted instead.
fn crop_views(
    rig: &Rig,
    sensors: &[String],
    poses: &[Pose],
    settings: &Settings,
) -> (Vec<(usize, String, Cloud)>, Vec<FrameNote>) {
    let mut usable = Vec::new();
    let mut skipped = Vec::new();
    for view in &rig.views {
        let s = sensors.iter().position(|n| n == &view.sensor).unwrap_or(0);
        let cloud =
            Cloud::from_points(view.points.clone()).transformed(&poses[s]).cropped(&rig.roi);
        let distinct = cloud.points.iter().any(|p| p != &cloud.points[0]);
        let needed = settings.min_view_points.max(3);
        if cloud.len() < needed || !distinct {
            let reason = if distinct || cloud.is_empty() {
                format!("{} points in the ROI, need {needed}", cloud.len())
            } else {
                "all points in the ROI coincide".to_string()
            };
            skipped.push(FrameNote {
                sensor: view.sensor.clone(),
                frame: view.frame.clone(),
                reason,
            });
            continue;
        }
        usable.push((s, view.frame.clone(), cloud));
    }
    (usable, skipped)
}

/// Step 1's levelling: every sensor's ground in a box around the ROI (all its frames,
/// pre-aligned with its nominal), and the motion putting it on the reference's ground; then,
/// when on, the bird's-eye search for each levelled sensor's yaw and in-plane shift.
fn level_grounds(
    rig: &Rig,
    sensors: &[String],
    nominals: &[Pose],
    r: usize,
    settings: &Settings,
) -> Vec<Levelling> {
    let (near_roi, grounds): (Vec<_>, Vec<_>) =
        (0..sensors.len()).map(|s| sensor_ground(rig, sensors, nominals, s, settings)).unzip();
    let pivot = nalgebra::Vector3::from_fn(|i, _| 0.5 * (rig.roi.min[i] + rig.roi.max[i]));
    sensors
        .iter()
        .enumerate()
        .map(|(s, name)| {
            let (ground, inliers) = grounds[s].map_or((None, 0), |(p, n)| (Some(p), n));
            let (mut applied, note) = match (ground, grounds[r]) {
                (Some(_), _) if s == r => (Pose::identity(), None),
                (Some(own), Some((reference, _))) => {
                    (level::levelling(&own, &reference, &pivot), None)
                }
                (None, _) => (Pose::identity(), Some("no ground plane found near the ROI".into())),
                (Some(_), None) => (
                    Pose::identity(),
                    Some(format!("the reference sensor {} shows no ground plane", sensors[r])),
                ),
            };
            // The bird's-eye search runs for every non-reference sensor levelled.
            let searched = settings.bev.as_ref().filter(|_| s != r && note.is_none());
            let bev = searched.zip(grounds[r]).and_then(|(bev_settings, (reference, _))| {
                let levelled: Vec<_> = near_roi[s]
                    .iter()
                    .map(|p| (applied * nalgebra::Point3::from(*p)).coords)
                    .collect();
                let sensor = (applied * nominals[s]).translation.vector;
                bev::search(&levelled, &near_roi[r], &reference, &sensor, bev_settings)
            });
            if let Some(found) = &bev {
                applied = found.applied * applied;
            }
            let warning = searched.and_then(|b| bev::warning(bev.as_ref(), b));
            Levelling { sensor: name.clone(), ground, inliers, applied, bev, note, warning }
        })
        .collect()
}

/// Sensor `s`'s points (all frames, pre-aligned with its nominal) in the box around the ROI
/// where the ground is searched, and the ground plane found among them.
fn sensor_ground(
    rig: &Rig,
    sensors: &[String],
    nominals: &[Pose],
    s: usize,
    settings: &Settings,
) -> (Vec<nalgebra::Vector3<f64>>, Option<(Plane, usize)>) {
    let bounds = level::search_box(&rig.roi, settings.ground.margin);
    let points: Vec<_> = rig
        .views
        .iter()
        .filter(|v| v.sensor == sensors[s])
        .flat_map(|v| level::points_in(&v.points, &nominals[s], &bounds))
        .collect();
    let ground = level::fit_ground(&points, &settings.ground, settings.seed.wrapping_add(s as u64));
    (points, ground)
}

/// Step 5: the mixture in the vehicle frame (the mean of the reference views' poses puts it
/// where the reference sees it; the mixture itself floats) and the prior fitted to each target
/// standing on `ground`.
fn reconstruction(
    registration: &jrmpc::Registration,
    reference_views: &[usize],
    ground: Option<Plane>,
    prior: &jrmpc::Prior,
) -> Target {
    let mix = &registration.mixture;
    let poses: Vec<Pose> = reference_views.iter().map(|&v| registration.poses[v]).collect();
    let to_vehicle = average(&poses).map_or_else(Pose::identity, |(m, _)| m).inverse();
    let means: Vec<nalgebra::Vector3<f64>> =
        mix.means.iter().map(|m| (to_vehicle * nalgebra::Point3::from(*m)).coords).collect();
    let ground = ground.map(|g| (g.normal, g.offset));
    Target {
        means: means.iter().map(|m| [m.x, m.y, m.z]).collect(),
        sigmas: mix.variances.iter().map(|v| v.sqrt()).collect(),
        priors: mix.priors.clone(),
        fits: fit_targets(prior, &means, &mix.priors, ground),
    }
}

/// Sensor names in order of first appearance among the views: the order of
/// `Calibration::sensors` and `Progress::corrections`.
pub fn sensor_names(rig: &Rig) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for view in &rig.views {
        if !names.contains(&view.sensor) {
            names.push(view.sensor.clone());
        }
    }
    names
}

/// Sensor names in order of first appearance among the views, after checking the nominals.
fn sensor_order(rig: &Rig) -> Result<Vec<String>, CalibError> {
    if !rig.roi.is_valid() {
        return Err(CalibError::InvalidRoi);
    }
    let sensors = sensor_names(rig);
    for name in &sensors {
        let (_, pose) = rig
            .nominal
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| CalibError::UnknownSensor(name.clone()))?;
        let m = pose.to_homogeneous();
        if !m.iter().all(|x| x.is_finite()) {
            return Err(CalibError::NonFiniteNominal(name.clone()));
        }
    }
    if sensors.len() < 2 {
        return Err(CalibError::TooFewSensors(sensors.len()));
    }
    Ok(sensors)
}

/// For each sensor, the (reference view, sensor view) index pairs of the frames both have.
fn frame_pairs(
    usable: &[(usize, String, Cloud)],
    sensors: usize,
    r: usize,
) -> Vec<Vec<(usize, usize)>> {
    let mut pairs = vec![Vec::new(); sensors];
    for (i, (s, frame, _)) in usable.iter().enumerate() {
        if let Some(j) = usable.iter().position(|(u, f, _)| *u == r && f == frame) {
            pairs[*s].push((j, i));
        }
    }
    pairs
}
