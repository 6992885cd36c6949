//! A rotating LiDAR: a fan of channels at fixed elevations swept through 360 deg, producing an
//! organized scan (rows = channels, columns = azimuth steps) in the sensor's own frame.

use nalgebra::{Point3, Vector3};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Normal};

use super::float16;
use super::scene::Scene;
use crate::cloud::Cloud;
use crate::se3::Pose;

/// Sensor model. Beam `(row, col)` leaves the sensor origin at elevation
/// `vertical_angles[row]` (rad, up positive) and azimuth `2 pi col / horizontal_steps` (rad,
/// counter-clockwise about the sensor's +z, starting at +x).
#[derive(Clone, Debug, PartialEq)]
pub struct Spinning {
    /// Elevation of each channel (rad); one row of the scan per entry.
    pub vertical_angles: Vec<f64>,
    /// Columns over 360 deg.
    pub horizontal_steps: usize,
    /// Returns farther than this are misses (m).
    pub max_range: f64,
    /// Standard deviation of the Gaussian range noise (m), applied along the beam.
    pub range_noise: f64,
    /// Probability that a return is lost (0..=1).
    pub dropout: f64,
    /// Coordinates rounded to IEEE binary16 after the noise, as drivers and recordings that
    /// store half floats give them ([`float16`]).
    pub float16: bool,
}

impl Spinning {
    /// `channels` beams spread evenly from `fov_max` (row 0, the top, as real sensors order their
    /// rows) down to `fov_min` (rad); a single channel sits in the middle of the FoV. No dropout,
    /// f32 coordinates.
    pub fn uniform(
        channels: usize,
        fov_min: f64,
        fov_max: f64,
        horizontal_steps: usize,
        max_range: f64,
        noise: f64,
    ) -> Self {
        let vertical_angles = match channels {
            1 => vec![(fov_min + fov_max) / 2.0],
            n => {
                (0..n).map(|i| fov_max - (fov_max - fov_min) * i as f64 / (n - 1) as f64).collect()
            }
        };
        Self {
            vertical_angles,
            horizontal_steps,
            max_range,
            range_noise: noise,
            dropout: 0.0,
            float16: false,
        }
    }

    /// Columns of a scan.
    pub fn width(&self) -> usize {
        self.horizontal_steps
    }

    /// Rows of a scan (channels).
    pub fn height(&self) -> usize {
        self.vertical_angles.len()
    }

    /// Unit direction of beam `(row, col)` in the sensor frame.
    pub fn beam(&self, row: usize, col: usize) -> Vector3<f64> {
        let azimuth = std::f64::consts::TAU * col as f64 / self.horizontal_steps as f64;
        let (se, ce) = self.vertical_angles[row].sin_cos();
        let (sa, ca) = azimuth.sin_cos();
        Vector3::new(ce * ca, ce * sa, se)
    }

    /// One revolution from pose `t_world_sensor` (`T_world_sensor`). The result is organized:
    /// `width() * height()` points, row-major with one row per channel, in the SENSOR frame (m).
    /// Misses (nothing hit, beyond `max_range`, dropped out, or a noisy range <= 0) are exact
    /// zeros `[0, 0, 0]`. Each call draws fresh noise from `rng`.
    pub fn scan(&self, scene: &Scene, t_world_sensor: &Pose, rng: &mut impl Rng) -> Cloud {
        let noise =
            (self.range_noise > 0.0).then(|| Normal::new(0.0, self.range_noise).ok()).flatten();
        let origin = (t_world_sensor * Point3::origin()).coords;
        let mut points = Vec::with_capacity(self.width() * self.height());
        for row in 0..self.height() {
            for col in 0..self.width() {
                let beam = self.beam(row, col);
                let hit = scene.intersect(origin, t_world_sensor.rotation * beam, self.max_range);
                let dropped = self.dropout > 0.0 && rng.random::<f64>() < self.dropout;
                let range = match (hit, dropped) {
                    (Some(t), false) => t + noise.map_or(0.0, |n| n.sample(rng)),
                    _ => 0.0,
                };
                let p = if range > 0.0 { beam * range } else { Vector3::zeros() };
                let p = [p.x as f32, p.y as f32, p.z as f32];
                points.push(if self.float16 { p.map(float16::round) } else { p });
            }
        }
        Cloud::from_points(points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;
    use crate::twin::scene::OrientedBox;
    use rand::SeedableRng;
    use rand_pcg::Pcg64;

    fn street() -> Scene {
        let boxes = vec![OrientedBox::new([8.0, 0.0, 1.0], 0.2, [1.0, 4.0, 2.0])];
        Scene { ground: true, boxes, ..Default::default() }
    }

    fn mount() -> Pose {
        pose_from_xyz_rpy([0.5, -0.2, 1.6], [0.1, 0.05, 0.3])
    }

    #[test]
    fn organized_shape_with_exact_zero_misses() {
        let lidar = Spinning::uniform(16, -0.3, 0.2, 360, 30.0, 0.01);
        let cloud = lidar.scan(&street(), &mount(), &mut Pcg64::seed_from_u64(3));
        assert_eq!(cloud.len(), 16 * 360);
        let zeros = cloud.points.iter().filter(|p| **p == [0.0; 3]).count();
        let hits = cloud.len() - zeros;
        // Upward beams miss, downward ones hit the ground or the wall.
        assert!(zeros > 500 && hits > 2000, "zeros {zeros}, hits {hits}");
        assert!(cloud.points.iter().all(|p| p.iter().all(|v| v.is_finite())));
        // Misses are +0.0 exactly (not -0.0), and hits are within range.
        for p in &cloud.points {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r == 0.0 && p.iter().all(|v| v.to_bits() == 0)) || (r > 0.5 && r < 30.1));
        }
    }

    #[test]
    fn full_dropout_is_all_zero() {
        let mut lidar = Spinning::uniform(8, -0.3, 0.0, 90, 30.0, 0.01);
        lidar.dropout = 1.0;
        let cloud = lidar.scan(&street(), &mount(), &mut Pcg64::seed_from_u64(1));
        assert_eq!(cloud.len(), 8 * 90);
        assert!(cloud.points.iter().all(|p| *p == [0.0; 3]));
        // Half dropout loses about half the returns.
        lidar.dropout = 0.5;
        let full = Spinning { dropout: 0.0, ..lidar.clone() };
        let count = |c: &Cloud| c.points.iter().filter(|p| **p != [0.0; 3]).count() as f64;
        let all = count(&full.scan(&street(), &mount(), &mut Pcg64::seed_from_u64(1)));
        let half = count(&lidar.scan(&street(), &mount(), &mut Pcg64::seed_from_u64(1)));
        assert!((half / all - 0.5).abs() < 0.08, "{half} of {all}");
    }

    #[test]
    fn seeded_scans_repeat_and_seeds_differ() {
        let mut lidar = Spinning::uniform(16, -0.3, 0.2, 180, 30.0, 0.01);
        lidar.dropout = 0.1;
        let scan = |seed| lidar.scan(&street(), &mount(), &mut Pcg64::seed_from_u64(seed));
        assert_eq!(scan(7), scan(7));
        assert_ne!(scan(7), scan(8));
    }

    #[test]
    fn points_lie_on_the_scene_in_the_sensor_frame() {
        let lidar = Spinning::uniform(16, -0.3, 0.2, 180, 30.0, 0.0);
        let scene = street();
        let cloud = lidar.scan(&scene, &mount(), &mut Pcg64::seed_from_u64(1));
        let mut checked = 0;
        for p in cloud.points.iter().filter(|p| **p != [0.0; 3]) {
            let w = mount() * Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let on_ground = w.z.abs() < 1e-5;
            let on_wall = scene.boxes[0].contains(w.coords, 1e-5)
                && !scene.boxes[0].contains(w.coords, -1e-5);
            assert!(on_ground || on_wall, "{w:?}");
            checked += 1;
        }
        assert!(checked > 1000);
    }

    #[test]
    fn range_noise_statistics() {
        // One beam straight ahead onto a wall 5 m away, scanned n times.
        let lidar = Spinning::uniform(1, 0.0, 0.0, 4, 30.0, 0.01);
        let scene = Scene {
            boxes: vec![OrientedBox::new([5.5, 0.0, 0.0], 0.0, [1.0; 3])],
            ..Default::default()
        };
        let mut rng = Pcg64::seed_from_u64(11);
        let n = 4000;
        let ranges: Vec<f64> = (0..n)
            .map(|_| {
                let p = lidar.scan(&scene, &Pose::identity(), &mut rng).points[0];
                assert_eq!((p[1], p[2]), (0.0, 0.0));
                p[0] as f64
            })
            .collect();
        let mean = ranges.iter().sum::<f64>() / n as f64;
        let std = (ranges.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        assert!((std / 0.01 - 1.0).abs() < 0.1, "std {std}");
        assert!((mean - 5.0).abs() < 3.0 * 0.01 / (n as f64).sqrt(), "mean {mean}");
    }
}
