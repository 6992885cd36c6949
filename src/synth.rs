//! Synthetic calibration rigs with known truth: a cube target (and optionally a ground patch)
//! sampled afresh for every view, seen by several sensors whose nominal extrinsics are wrong by
//! a seeded random amount. Used by the tests, the benchmarks and the built-in demo; the ray-cast
//! digital twin lives in `sim`.

use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use crate::cloud::Aabb;
use crate::se3::{Pose, pose_from_xyz_rpy};
use crate::sim::miscalibrate;

/// What to generate. Angles in rad, lengths in m.
#[derive(Clone, Debug)]
pub struct RigSpec {
    pub sensors: usize,
    pub frames: usize,
    /// Points per view (target plus ground).
    pub points_per_view: usize,
    /// Standard deviation of the Gaussian range noise (m): each point moves along its sensor's
    /// ray, as a LiDAR's errors do (DESIGN: sigma about 1 cm).
    pub noise: f64,
    /// Only the cube faces a sensor can see, plus a ground patch; otherwise all six faces.
    pub partial: bool,
    /// Share of a partial view's points on the ground (real ROIs: about 0.8).
    pub ground_fraction: f64,
    /// Cube edge (m).
    pub edge: f64,
    /// Distance of the cube centre ahead of the vehicle origin (m).
    pub target_distance: f64,
    /// Each non-reference sensor's nominal is off by up to this per axis (rad).
    pub max_rotation_error: f64,
    /// ... and by up to this per axis (m).
    pub max_translation_error: f64,
    pub seed: u64,
}

impl Default for RigSpec {
    fn default() -> Self {
        Self {
            sensors: 2,
            frames: 10,
            points_per_view: 1500,
            noise: 0.01,
            partial: false,
            ground_fraction: 0.8,
            edge: 0.5,
            target_distance: 4.0,
            max_rotation_error: 3f64.to_radians(),
            max_translation_error: 0.1,
            seed: 1,
        }
    }
}

/// One scan: points in the sensor's own frame.
#[derive(Clone, Debug)]
pub struct SyntheticView {
    pub sensor: String,
    pub frame: String,
    pub points: Vec<[f32; 3]>,
}

/// A generated rig: views, the (wrong) nominal and the true `T_vehicle_sensor` per sensor, and
/// a region of interest around the target.
#[derive(Clone, Debug)]
pub struct SyntheticRig {
    pub views: Vec<SyntheticView>,
    pub nominal: Vec<(String, Pose)>,
    pub truth: Vec<(String, Pose)>,
    pub roi: Aabb,
    pub target_centre: [f64; 3],
}

impl SyntheticRig {
    /// The correction that maps sensor `i`'s nominally pre-aligned points onto the truth
    /// (`T_true * T_nominal^-1`); identity for the reference, whose nominal is right.
    pub fn true_correction(&self, i: usize) -> Pose {
        self.truth[i].1 * self.nominal[i].1.inverse()
    }
}

/// Sensors sit on a 1.2 m wide bar 1.6 m up, spread evenly in y and rolled towards the middle
/// (like the front-left and front-right LiDARs of the paper's vehicle).
fn true_mount(i: usize, n: usize) -> Pose {
    let s = if n > 1 { i as f64 / (n - 1) as f64 * 2.0 - 1.0 } else { 0.0 };
    pose_from_xyz_rpy([0.0, 0.6 * s, 1.6], [-0.2 * s, 0.05, -0.1 * s])
}

pub fn generate(spec: &RigSpec) -> SyntheticRig {
    let mut rng = Pcg64::seed_from_u64(spec.seed);
    let noise =
        Normal::new(0.0, spec.noise).unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("zero sigma"));
    let h = spec.edge / 2.0;
    let centre = [spec.target_distance, 0.0, h];
    let names: Vec<String> = (1..=spec.sensors).map(|i| format!("sensor_{i}")).collect();
    let truth: Vec<Pose> = (0..spec.sensors).map(|i| true_mount(i, spec.sensors)).collect();
    let nominal: Vec<Pose> = truth
        .iter()
        .enumerate()
        .map(|(i, t)| {
            if i == 0 {
                return *t;
            }
            // The nominal is the truth with an error applied in the vehicle frame.
            miscalibrate(t, spec.max_rotation_error, spec.max_translation_error, &mut rng)
        })
        .collect();

    let mut views = Vec::new();
    for frame in 1..=spec.frames {
        for (i, name) in names.iter().enumerate() {
            let eye = truth[i].translation.vector;
            let faces: Vec<usize> = (0..6)
                .filter(|&f| {
                    let (axis, sign) = (f / 2, if f % 2 == 0 { 1.0 } else { -1.0 });
                    !spec.partial || sign * (eye[axis] - centre[axis]) > h
                })
                .collect();
            let ground = if spec.partial {
                (spec.points_per_view as f64 * spec.ground_fraction) as usize
            } else {
                0
            };
            let vehicle_to_sensor = truth[i].inverse();
            let mut points = Vec::with_capacity(spec.points_per_view);
            for n in 0..spec.points_per_view {
                let p = if n < ground {
                    ground_point(&mut rng, centre, h)
                } else {
                    cube_point(&mut rng, centre, h, &faces)
                };
                let q = vehicle_to_sensor * nalgebra::Point3::new(p[0], p[1], p[2]);
                let range = q.coords.norm();
                let q = q * ((range + noise.sample(&mut rng)) / range);
                points.push([q.x as f32, q.y as f32, q.z as f32]);
            }
            views.push(SyntheticView { sensor: name.clone(), frame: frame.to_string(), points });
        }
    }
    let roi = Aabb::new(
        [centre[0] - GROUND_HALF[0] - 0.2, centre[1] - GROUND_HALF[1] - 0.2, -0.3],
        [centre[0] + GROUND_HALF[0] + 0.2, centre[1] + GROUND_HALF[1] + 0.2, spec.edge + 0.5],
    );
    SyntheticRig {
        views,
        nominal: names.iter().cloned().zip(nominal).collect(),
        truth: names.into_iter().zip(truth).collect(),
        roi,
        target_centre: centre,
    }
}

fn cube_point(rng: &mut Pcg64, centre: [f64; 3], h: f64, faces: &[usize]) -> [f64; 3] {
    let face = faces[rng.random_range(0..faces.len())];
    let (axis, sign) = (face / 2, if face % 2 == 0 { 1.0 } else { -1.0 });
    let mut p = [rng.random_range(-h..=h), rng.random_range(-h..=h), rng.random_range(-h..=h)];
    p[axis] = sign * h;
    [p[0] + centre[0], p[1] + centre[1], p[2] + centre[2]]
}

/// Half-extent of the ground patch around the cube (m): 2.5 m deep and 6 m wide, the shape of
/// GMMCalib's own ROI (a wide strip across the road ahead).
const GROUND_HALF: [f64; 2] = [1.25, 3.0];

/// A point on the ground (z = 0) in the patch around the cube, outside the cube's footprint.
fn ground_point(rng: &mut Pcg64, centre: [f64; 3], h: f64) -> [f64; 3] {
    loop {
        let x = rng.random_range(-GROUND_HALF[0]..=GROUND_HALF[0]);
        let y = rng.random_range(-GROUND_HALF[1]..=GROUND_HALF[1]);
        if x.abs() > h || y.abs() > h {
            return [centre[0] + x, centre[1] + y, 0.0];
        }
    }
}
