//! The sampled scanner: a cube target (and optionally a ground patch) sampled afresh for every
//! view, with range noise along each sensor's ray. Cheaper and simpler than ray casting, and
//! any number of sensors and points: the tests' and benches' rigs.

use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use super::OrganizedScan;
use crate::cloud::{Aabb, Cloud};
use crate::se3::{Pose, pose_from_xyz_rpy};

/// What to sample. Lengths in m.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampling {
    pub sensors: usize,
    /// Points per view (target plus ground).
    pub points_per_view: usize,
    /// Standard deviation of the Gaussian range noise (m): each point moves along its sensor's
    /// ray, as a LiDAR's errors do (about 1 cm).
    pub noise: f64,
    /// Only the cube faces a sensor can see, plus a ground patch; otherwise all six faces.
    pub partial: bool,
    /// Share of a partial view's points on the ground (real ROIs: about 0.8).
    pub ground_fraction: f64,
    /// Cube edge (m).
    pub edge: f64,
    /// Distance of the cube centre ahead of the vehicle origin (m).
    pub target_distance: f64,
}

impl Default for Sampling {
    fn default() -> Self {
        Self {
            sensors: 2,
            points_per_view: 1500,
            noise: 0.01,
            partial: false,
            ground_fraction: 0.8,
            edge: 0.5,
            target_distance: 4.0,
        }
    }
}

impl Sampling {
    /// Sensor names: `sensor_1`, `sensor_2`, ... (GMMCalib's folders).
    pub fn names(&self) -> Vec<String> {
        (1..=self.sensors).map(|i| format!("sensor_{i}")).collect()
    }

    /// True `T_vehicle_sensor` of each sensor: on a 1.2 m wide bar 1.6 m up, spread evenly in
    /// y and rolled towards the middle (like the paper vehicle's front-left and front-right
    /// LiDARs).
    pub fn mounts(&self) -> Vec<Pose> {
        let n = self.sensors;
        (0..n)
            .map(|i| {
                let s = if n > 1 { i as f64 / (n - 1) as f64 * 2.0 - 1.0 } else { 0.0 };
                pose_from_xyz_rpy([0.0, 0.6 * s, 1.6], [-0.2 * s, 0.05, -0.1 * s])
            })
            .collect()
    }

    /// The cube's centre (vehicle frame, m).
    pub fn target_centre(&self) -> [f64; 3] {
        [self.target_distance, 0.0, self.edge / 2.0]
    }

    /// A region of interest around the cube and its ground patch.
    pub fn roi(&self) -> Aabb {
        let centre = self.target_centre();
        Aabb::new(
            [centre[0] - GROUND_HALF[0] - 0.2, centre[1] - GROUND_HALF[1] - 0.2, -0.3],
            [centre[0] + GROUND_HALF[0] + 0.2, centre[1] + GROUND_HALF[1] + 0.2, self.edge + 0.5],
        )
    }

    /// `frames` views per sensor seen from `mounts`, frame by frame, seeded.
    pub fn simulate(&self, frames: usize, seed: u64) -> Vec<OrganizedScan> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let noise = Normal::new(0.0, self.noise)
            .unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("zero sigma"));
        let h = self.edge / 2.0;
        let centre = self.target_centre();
        let (names, mounts) = (self.names(), self.mounts());
        let mut views = Vec::new();
        for frame in 1..=frames {
            for (name, mount) in names.iter().zip(&mounts) {
                let eye = mount.translation.vector;
                let faces: Vec<usize> = (0..6)
                    .filter(|&f| {
                        let (axis, sign) = (f / 2, if f % 2 == 0 { 1.0 } else { -1.0 });
                        !self.partial || sign * (eye[axis] - centre[axis]) > h
                    })
                    .collect();
                let ground = if self.partial {
                    (self.points_per_view as f64 * self.ground_fraction) as usize
                } else {
                    0
                };
                let vehicle_to_sensor = mount.inverse();
                let mut points = Vec::with_capacity(self.points_per_view);
                for n in 0..self.points_per_view {
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
                views.push(OrganizedScan {
                    sensor: name.clone(),
                    frame: frame.to_string(),
                    width: points.len(),
                    height: 1,
                    cloud: Cloud::from_points(points),
                });
            }
        }
        views
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
