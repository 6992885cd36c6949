//! Global initial alignment: from a tape-measure nominal (any yaw, tilts of tens of
//! degrees, metres off) to a start the local pipeline's basin holds.
//!
//! Per non-reference sensor, on its whole scan (all frames):
//! 1. its ground in its own frame ([`up::find_up`]), the nominal only a hint; the reference's
//!    likewise, with its nominal trusted (it defines the vehicle frame);
//! 2. level it: the shortest rotation putting its ground's normal on the reference's, about the
//!    sensor's nominal position, then the height its ground says;
//! 3. the yaw about the ground normal through the sensor and the shift along the ground, over
//!    the full turn and the shift range ([`correlate::search`]);
//! 4. when the ground is in doubt (several plausible planes), steps 2-3 for each, keeping the
//!    one whose overlay on the reference scores best.
//!
//! The result is a motion on top of each nominal; the local levelling, the bird's-eye search and
//! the registration start from it.

use nalgebra::{Point3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::correlate::{self, CorrelateSettings, YawShift};
use super::up::{self, GroundCandidate, NoGround, UpHint, UpSettings};
use crate::cloud::is_valid_point;
use crate::plane::Plane;
use crate::se3::{Pose, rotation_about};

/// The global stage's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GlobalSettings {
    pub up: UpSettings,
    pub correlate: CorrelateSettings,
    /// Standard deviation of a nominal's tilt error (rad): roll and pitch may be off by tens of
    /// degrees.
    pub tilt_sigma: f64,
    /// The same for the reference, whose nominal defines the vehicle frame (rad).
    pub reference_tilt_sigma: f64,
    /// Standard deviation of a nominal's height error (m).
    pub height_sigma: f64,
    /// Most ground candidates tried by their overlay when the ground is in doubt.
    pub grounds_tried: usize,
    /// A candidate is in doubt when its log-evidence is within this of the best's.
    pub ground_doubt: f64,
    /// Voxel edge (m) the scans are thinned to for the overlay.
    pub voxel: f64,
}

impl Default for GlobalSettings {
    fn default() -> Self {
        Self {
            up: UpSettings::default(),
            correlate: CorrelateSettings::default(),
            tilt_sigma: 45f64.to_radians(),
            reference_tilt_sigma: 10f64.to_radians(),
            height_sigma: 1.0,
            grounds_tried: 3,
            ground_doubt: 3.0,
            voxel: 0.1,
        }
    }
}

/// Most cells of a grid the global stage may build (`(2 reach / cell)^2`): 64 times the
/// defaults' fine grid, far below what a page's 4 GiB holds.
const MAX_GRID_CELLS: f64 = (1u64 << 25) as f64;
/// Most yaw steps a search may take (each coarse one is an FFT of the grid): the defaults
/// take 180 coarse, and 8 fine per coarse step.
const MAX_YAW_STEPS: f64 = 4096.0;

impl GlobalSettings {
    /// The first setting out of range, named: a number that is not one, or a grid or a search
    /// these would size beyond what a page's memory and patience hold. Settings reach a pool
    /// worker's `alignGlobal` from JS, where nothing else checks them.
    pub fn check(&self) -> Result<(), &'static str> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        let (c, u) = (&self.correlate, &self.up);
        let reach = c.radius + c.max_shift + 2.0 * c.coarse_cell;
        let grid = |cell: f64| (2.0 * reach / cell).powi(2) <= MAX_GRID_CELLS;
        let sigmas = [self.tilt_sigma, self.reference_tilt_sigma, self.height_sigma];
        let problem = if !sigmas.into_iter().all(positive) {
            "global: tilt_sigma, reference_tilt_sigma and height_sigma must be positive numbers"
        } else if !positive(self.voxel) || !positive(u.voxel) {
            "global: voxel and up.voxel must be positive numbers of metres"
        } else if !(self.ground_doubt.is_finite() && self.ground_doubt >= 0.0) {
            "global: ground_doubt must be a non-negative number"
        } else if !positive(u.max_range) || !positive(u.inlier_distance) || !positive(u.behind) {
            "global: up.max_range, up.inlier_distance and up.behind must be positive numbers"
        } else if !positive(u.min_extent) || !positive(u.footprint_cell) {
            "global: up.min_extent and up.footprint_cell must be positive numbers of metres"
        } else if (2.0 * u.max_range / u.footprint_cell).powi(2) > MAX_GRID_CELLS {
            "global: up.footprint_cell is too small for up.max_range"
        } else if !(u.heights.iter().all(|h| h.is_finite()) && u.heights[0] < u.heights[1]) {
            "global: up.heights must be two numbers, the lower first"
        } else if !(c.heights.iter().all(|h| h.is_finite()) && c.heights[0] < c.heights[1]) {
            "global: correlate.heights must be two numbers, the lower first"
        } else if !positive(c.radius) || !positive(c.max_shift) {
            "global: correlate.radius and correlate.max_shift must be positive numbers of metres"
        } else if !positive(c.coarse_cell) || !positive(c.fine_cell) || !positive(c.fine_blur) {
            "global: correlate's cells and blur must be positive numbers of metres"
        } else if !grid(c.coarse_cell) || !grid(c.fine_cell) {
            "global: correlate's cells are too small for its radius and shift"
        } else if !positive(c.coarse_yaw_step) || !positive(c.fine_yaw_step) {
            "global: correlate's yaw steps must be positive numbers of radians"
        } else if std::f64::consts::TAU / c.coarse_yaw_step > MAX_YAW_STEPS
            || c.coarse_yaw_step / c.fine_yaw_step > MAX_YAW_STEPS
        {
            "global: correlate's yaw steps are too small"
        } else if !positive(c.distinct_yaw) || !positive(c.distinct_shift) {
            "global: correlate.distinct_yaw and distinct_shift must be positive numbers"
        } else if !(0.0..=1.0).contains(&c.as_good) {
            "global: correlate.as_good must be a share between 0 and 1"
        } else {
            return Ok(());
        };
        Err(problem)
    }
}

/// Why a sensor's global alignment was not applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GlobalSkip {
    /// The reference sensor shows no ground.
    ReferenceGround(NoGround),
    /// This sensor shows no ground.
    Ground(NoGround),
    /// Levelled, but no structure above the ground in either scan to overlay.
    NoStructure,
}

/// One sensor's global alignment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GlobalAlignment {
    /// On top of the nominal: `applied * T_vehicle_sensor_nominal` is the new start. Identity
    /// for the reference and for a skipped sensor.
    pub applied: Pose,
    /// The ground chosen, in the sensor's frame (for the reference too).
    pub ground: Option<GroundCandidate>,
    /// Ground candidates tried by their overlay (1 when the ground was not in doubt).
    pub grounds_tried: usize,
    /// The overlay found after levelling: the best and the runners-up.
    pub overlay: Option<YawShift>,
    pub skipped: Option<GlobalSkip>,
}

impl GlobalAlignment {
    fn skipped(ground: Option<GroundCandidate>, why: Option<GlobalSkip>) -> Self {
        Self { applied: Pose::identity(), ground, grounds_tried: 0, overlay: None, skipped: why }
    }
}

/// The global alignment of every sensor onto `r`: `scans[s]` is sensor s's points in its own
/// frame (all frames), `nominals[s]` its nominal `T_vehicle_sensor`, `seeds[s]` the seed of its
/// searches.
pub fn align(
    scans: Vec<Vec<[f32; 3]>>,
    nominals: &[Pose],
    r: usize,
    settings: &GlobalSettings,
    seeds: &[u64],
) -> Vec<GlobalAlignment> {
    GlobalStage::new(scans, nominals, r, settings, seeds).into_alignments()
}

/// The reference's part of the global stage, found once: its ground and its thinned points,
/// both in the vehicle frame, which every other sensor is overlaid on.
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalReference {
    pub ground: Plane,
    pub points: Vec<Vector3<f64>>,
}

/// One sensor's alignment onto the reference (steps 1-4), all it needs: it depends on no other
/// sensor's, so a driver may run the sensors anywhere, in any order.
pub struct GlobalJob<'a> {
    /// The sensor's points in its own frame (all frames).
    pub scan: &'a [[f32; 3]],
    pub nominal: Pose,
    pub reference: &'a GlobalReference,
    pub settings: &'a GlobalSettings,
    pub seed: u64,
}

impl GlobalJob<'_> {
    pub fn run(&self) -> GlobalAlignment {
        align_sensor(self.scan, &self.nominal, self.reference, self.settings, self.seed)
    }
}

/// The global stage under way: the reference's ground found, the other sensors aligned here
/// ([`GlobalStage::align`]) or elsewhere ([`GlobalStage::job`], then [`GlobalStage::record`]).
pub struct GlobalStage {
    settings: GlobalSettings,
    scans: Vec<Vec<[f32; 3]>>,
    nominals: Vec<Pose>,
    seeds: Vec<u64>,
    r: usize,
    /// The reference's ground and points, or why it has no ground (then nothing is aligned).
    reference: Result<(GroundCandidate, GlobalReference), NoGround>,
    found: Vec<Option<GlobalAlignment>>,
}

impl GlobalStage {
    /// Finds the reference's ground (the stage's serial part); see [`align`] for the inputs.
    pub fn new(
        scans: Vec<Vec<[f32; 3]>>,
        nominals: &[Pose],
        r: usize,
        settings: &GlobalSettings,
        seeds: &[u64],
    ) -> Self {
        let hint = UpHint {
            up: nominals[r].rotation.inverse() * Vector3::z(),
            tilt_sigma: settings.reference_tilt_sigma,
            height: None,
        };
        let reference = up::find_up(&scans[r], &hint, &settings.up, seeds[r]).map(|found| {
            let own = found.candidates[0];
            let ground = in_vehicle(&own.plane, &nominals[r]);
            (
                own,
                GlobalReference {
                    ground,
                    points: thinned(&scans[r], &nominals[r], settings.voxel),
                },
            )
        });
        let found = match &reference {
            Ok((own, _)) => (0..scans.len())
                .map(|s| (s == r).then(|| GlobalAlignment::skipped(Some(*own), None)))
                .collect(),
            Err(why) => {
                let skip = GlobalAlignment::skipped(None, Some(GlobalSkip::ReferenceGround(*why)));
                vec![Some(skip); scans.len()]
            }
        };
        Self {
            settings: settings.clone(),
            scans,
            nominals: nominals.to_vec(),
            seeds: seeds.to_vec(),
            r,
            reference,
            found,
        }
    }

    pub fn settings(&self) -> &GlobalSettings {
        &self.settings
    }

    /// The sensors still to align, in order.
    pub fn pending(&self) -> Vec<usize> {
        (0..self.found.len()).filter(|&s| self.found[s].is_none()).collect()
    }

    /// Sensor `s`'s alignment, to run anywhere; `None` unless it is pending.
    pub fn job(&self, s: usize) -> Option<GlobalJob<'_>> {
        let (_, reference) = self.reference.as_ref().ok()?;
        (self.found.get(s)?.is_none() && s != self.r).then(|| GlobalJob {
            scan: &self.scans[s],
            nominal: self.nominals[s],
            reference,
            settings: &self.settings,
            seed: self.seeds[s],
        })
    }

    /// The sensors aligned so far and how many the stage aligns: all but the reference, none
    /// when the reference shows no ground.
    pub fn aligned(&self) -> (usize, usize) {
        let total = if self.reference.is_ok() { self.found.len() - 1 } else { 0 };
        (total - self.pending().len(), total)
    }

    /// Each sensor's motion so far, in sensor order: its alignment's `applied` once aligned,
    /// identity before.
    pub fn applied(&self) -> Vec<Pose> {
        self.found.iter().map(|f| f.as_ref().map_or_else(Pose::identity, |a| a.applied)).collect()
    }

    /// Records pending sensor `s`'s alignment, run elsewhere (ignored for any other sensor).
    pub fn record(&mut self, s: usize, alignment: GlobalAlignment) {
        if let Some(slot @ None) = self.found.get_mut(s) {
            *slot = Some(alignment);
        }
    }

    /// Aligns pending sensors `which` here, on up to `threads` threads (native only).
    pub fn align(&mut self, which: &[usize], threads: usize) {
        let jobs: Vec<(usize, GlobalJob)> =
            which.iter().filter_map(|&s| Some((s, self.job(s)?))).collect();
        let done =
            crate::on_threads(&jobs, crate::threads_here(threads), |(s, job)| (*s, job.run()));
        for (s, alignment) in done {
            self.record(s, alignment);
        }
    }

    /// Every sensor's alignment, in sensor order; the pending ones are aligned here first.
    pub fn into_alignments(mut self) -> Vec<GlobalAlignment> {
        self.align(&self.pending(), 1);
        self.found.into_iter().map(|f| f.expect("every sensor aligned")).collect()
    }
}

/// Steps 1-4 for one sensor against the reference's thinned points and ground (vehicle frame).
fn align_sensor(
    scan: &[[f32; 3]],
    nominal: &Pose,
    reference: &GlobalReference,
    settings: &GlobalSettings,
    seed: u64,
) -> GlobalAlignment {
    let GlobalReference { ground, points: reference } = reference;
    let position = nominal.translation.vector;
    let hint = UpHint {
        up: nominal.rotation.inverse() * Vector3::z(),
        tilt_sigma: settings.tilt_sigma,
        height: Some((ground.distance(&position), settings.height_sigma)),
    };
    let found = match up::find_up(scan, &hint, &settings.up, seed) {
        Ok(found) => found,
        Err(why) => return GlobalAlignment::skipped(None, Some(GlobalSkip::Ground(why))),
    };
    let best_evidence = found.candidates[0].score;
    let in_doubt: Vec<&GroundCandidate> = found
        .candidates
        .iter()
        .filter(|c| c.score >= best_evidence - settings.ground_doubt)
        .take(settings.grounds_tried.max(1))
        .collect();
    let points = thinned(scan, &Pose::identity(), settings.voxel);
    let mut best: Option<(GroundCandidate, Pose, YawShift)> = None;
    for candidate in &in_doubt {
        let level = levelling(&candidate.plane, nominal, ground);
        let start = level * nominal;
        let moved: Vec<Vector3<f64>> =
            points.iter().map(|p| (start * Point3::from(*p)).coords).collect();
        let pivot = start.translation.vector;
        let Some(overlay) =
            correlate::search(&moved, reference, ground, &pivot, &settings.correlate)
        else {
            continue;
        };
        if best.as_ref().is_none_or(|(_, _, b)| overlay.best.score > b.best.score) {
            best = Some((**candidate, level, overlay));
        }
    }
    match best {
        Some((chosen, level, overlay)) => GlobalAlignment {
            applied: overlay.best.applied * level,
            ground: Some(chosen),
            grounds_tried: in_doubt.len(),
            overlay: Some(overlay),
            skipped: None,
        },
        None => GlobalAlignment::skipped(Some(found.candidates[0]), Some(GlobalSkip::NoStructure)),
    }
}

/// Step 2: the motion, on top of `nominal`, that puts the sensor's ground `own` (sensor frame)
/// on `ground` (vehicle frame): the shortest rotation between the normals about the sensor's
/// nominal position, then a shift along the normal to the height `own` says.
pub fn levelling(own: &Plane, nominal: &Pose, ground: &Plane) -> Pose {
    let normal = nominal.rotation * own.normal;
    let rotation = UnitQuaternion::rotation_between(&normal, &ground.normal).unwrap_or_else(|| {
        // Opposite normals: half a turn about any axis in the plane.
        let axis = normal.cross(&Vector3::x()).try_normalize(1e-9).unwrap_or(Vector3::y());
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), std::f64::consts::PI)
    });
    let position = nominal.translation.vector;
    let lift = ground.normal * (own.offset - ground.distance(&position));
    rotation_about(rotation, &position, &lift)
}

/// A plane in frame b mapped into frame a by `t_a_b`.
pub fn in_vehicle(plane: &Plane, t_a_b: &Pose) -> Plane {
    let normal = t_a_b.rotation * plane.normal;
    Plane { normal, offset: plane.offset - normal.dot(&t_a_b.translation.vector) }
}

/// The valid points of `scan` mapped by `pose`, one per voxel of edge `voxel` (first seen).
fn thinned(scan: &[[f32; 3]], pose: &Pose, voxel: f64) -> Vec<Vector3<f64>> {
    let mut seen = std::collections::HashSet::new();
    scan.iter()
        .filter(|p| is_valid_point(p))
        .filter(|p| seen.insert(p.map(|c| (c as f64 / voxel).floor() as i64)))
        .map(|p| (pose * Point3::new(p[0] as f64, p[1] as f64, p[2] as f64)).coords)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    /// The defaults pass; a number that is not one, or a grid or search too large for a page,
    /// is named; and `calibrate` refuses such settings before any stage runs.
    #[test]
    fn settings_out_of_range_are_named() {
        let ok = GlobalSettings::default();
        assert_eq!(ok.check(), Ok(()));
        let mut tiny = ok.clone();
        tiny.correlate.fine_cell = 1e-4;
        assert_eq!(
            tiny.check(),
            Err("global: correlate's cells are too small for its radius and shift")
        );
        let mut steps = ok.clone();
        steps.correlate.coarse_yaw_step = 1e-4;
        assert_eq!(steps.check(), Err("global: correlate's yaw steps are too small"));
        let mut nan = ok.clone();
        nan.height_sigma = f64::NAN;
        assert!(nan.check().unwrap_err().contains("height_sigma"));
        let mut heights = ok.clone();
        heights.up.heights = [2.0, 1.0];
        assert!(heights.check().unwrap_err().contains("up.heights"));
        let settings = crate::calib::Settings { global: tiny, ..Default::default() };
        let draw = crate::twin::Miscalibration::default();
        let sampled = crate::twin::Model::Sampled(crate::twin::Sampling::default());
        let rig = crate::twin::Twin::new(&sampled, 1, 1, &draw).rig();
        let refused = crate::calib::calibrate(&rig, Default::default(), &settings, |_| {
            crate::jrmpc::Control::Continue
        });
        assert!(refused.unwrap_err().to_string().contains("correlate's cells are too small"));
    }

    #[test]
    fn levelling_puts_the_ground_under_the_sensor_at_its_height() {
        let d = std::f64::consts::PI / 180.0;
        let truth = pose_from_xyz_rpy([1.0, 0.5, 1.7], [170.0 * d, 40.0 * d, 60.0 * d]);
        let own = in_vehicle(&Plane { normal: Vector3::z(), offset: 0.0 }, &truth.inverse());
        assert!((own.offset - 1.7).abs() < 1e-12);
        let ground = Plane { normal: Vector3::z(), offset: 0.2 };
        for error in [[30.0, -40.0, 170.0], [0.0, 0.0, 0.0], [-45.0, 45.0, -90.0]] {
            let delta = pose_from_xyz_rpy([0.0; 3], error.map(|a| a * d));
            let nominal = pose_from_xyz_rpy([0.4, -0.7, 0.3], [0.0; 3]) * truth * delta;
            let start = levelling(&own, &nominal, &ground) * nominal;
            // The sensor's ground now lies on the reference's; only a yaw and shift remain.
            let mapped = in_vehicle(&own, &start);
            assert!((mapped.normal - ground.normal).norm() < 1e-9, "{mapped:?}");
            assert!((mapped.offset - ground.offset).abs() < 1e-9, "{mapped:?}");
            let moved = start.translation.vector - nominal.translation.vector;
            assert!(moved.xy().norm() < 1e-9, "{moved:?}");
        }
    }

    #[test]
    fn no_ground_anywhere_skips_and_says_why() {
        // A vertical wall in front of each sensor, nothing else.
        let wall: Vec<[f32; 3]> = (0..4000)
            .map(|i| [5.0, -10.0 + 0.1 * (i % 200) as f32, -1.0 + 0.1 * (i / 200) as f32])
            .collect();
        let nominals = [Pose::identity(), pose_from_xyz_rpy([0.0, 1.0, 0.0], [0.0; 3])];
        let found =
            align(vec![wall.clone(), wall], &nominals, 0, &GlobalSettings::default(), &[1, 2]);
        for g in &found {
            assert_eq!(g.applied, Pose::identity());
            assert!(
                matches!(
                    g.skipped,
                    Some(GlobalSkip::ReferenceGround(NoGround::NonePlausible { .. }))
                ),
                "{g:?}"
            );
        }
    }
}
