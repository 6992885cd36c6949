//! A solid-state rosette scanner (Livox Mid-40-like): two wedge prisms turning in opposite
//! directions steer one beam over a circular field of view in a pattern that never repeats,
//! so a static sensor's points fill the disc the longer it integrates. The output is
//! unorganized: one row of `points` shots per frame, misses as exact zeros.

use nalgebra::{Point3, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::float16;
use super::scene::Scene;
use crate::cloud::Cloud;
use crate::se3::Pose;

/// Sensor model. Shot `n` (counted from the sensor's start, across frames) leaves at time
/// `n / rate`; each prism deflects the beam by half the field of view's half-angle in the
/// direction its phase points, so the two together reach from the centre to the edge.
#[derive(Clone, Debug, PartialEq)]
pub struct Rosette {
    /// Half-angle of the circular field of view about the sensor's +x (rad).
    pub half_fov: f64,
    /// The two prisms' rotation rates (Hz, opposite signs: they counter-rotate). Their ratio
    /// is irrational, so the pattern never closes.
    pub prism_hz: [f64; 2],
    /// Shots per second.
    pub rate: f64,
    /// Shots per frame: a frame integrates `points / rate` seconds, and the next frame goes on
    /// where it stopped.
    pub points: usize,
    /// Returns farther than this are misses (m).
    pub max_range: f64,
    /// Standard deviation of the Gaussian range noise (m), along the beam.
    pub range_noise: f64,
    /// Coordinates rounded to IEEE binary16 after the noise ([`float16`]).
    pub float16: bool,
}

impl Rosette {
    /// A Livox Mid-40-like unit integrating `points` shots a frame: 38.4 deg circular field of
    /// view, 100k shots/s, prisms at 7294 and -4664 rpm (the speeds usually quoted for it: in
    /// 0.1 s the pattern reaches a third of the disc's 0.5 deg cells, in 0.6 s 96 %), 90 m
    /// range (its figure at 10 % reflectivity), 2 cm range noise.
    pub fn mid40(points: usize) -> Self {
        Self {
            half_fov: 19.2f64.to_radians(),
            prism_hz: [7294.0 / 60.0, -4664.0 / 60.0],
            rate: 100_000.0,
            points,
            max_range: 90.0,
            range_noise: 0.02,
            float16: false,
        }
    }

    /// Unit direction of shot `n` in the sensor frame: polar angle from +x up to `half_fov`,
    /// turned about +x (from +y towards +z) by the deflection's direction.
    pub fn beam(&self, n: u64) -> Vector3<f64> {
        let t = n as f64 / self.rate;
        let half = self.half_fov / 2.0;
        let (s1, c1) = (std::f64::consts::TAU * self.prism_hz[0] * t).sin_cos();
        let (s2, c2) = (std::f64::consts::TAU * self.prism_hz[1] * t).sin_cos();
        let (dy, dz) = (half * (c1 + c2), half * (s1 + s2));
        let polar = dy.hypot(dz);
        let (sp, cp) = polar.sin_cos();
        // At the centre the direction is +x whatever the deflection's direction.
        let (cy, cz) = if polar > 0.0 { (dy / polar, dz / polar) } else { (0.0, 0.0) };
        Vector3::new(cp, sp * cy, sp * cz)
    }

    /// Frame `frame` (0-based) from pose `t_world_sensor`: shots `frame * points ..` onwards,
    /// in the SENSOR frame (m); misses (nothing within `max_range`, or a noisy range <= 0) are
    /// exact zeros. Fresh noise from `rng`.
    pub fn scan(
        &self,
        scene: &Scene,
        t_world_sensor: &Pose,
        frame: usize,
        rng: &mut impl Rng,
    ) -> Cloud {
        let noise =
            (self.range_noise > 0.0).then(|| Normal::new(0.0, self.range_noise).ok()).flatten();
        let origin = (t_world_sensor * Point3::origin()).coords;
        let first = frame as u64 * self.points as u64;
        let points = (first..first + self.points as u64)
            .map(|n| {
                let beam = self.beam(n);
                let hit = scene.intersect(origin, t_world_sensor.rotation * beam, self.max_range);
                let range = hit.map_or(0.0, |t| t + noise.map_or(0.0, |d| d.sample(rng)));
                let p = if range > 0.0 { beam * range } else { Vector3::zeros() };
                let p = [p.x as f32, p.y as f32, p.z as f32];
                if self.float16 { p.map(float16::round) } else { p }
            })
            .collect();
        Cloud::from_points(points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::scene::OrientedBox;
    use rand::SeedableRng;
    use rand_pcg::Pcg64;

    /// A wall 10 m ahead, wide and tall enough to fill the field of view.
    fn wall() -> Scene {
        Scene {
            boxes: vec![OrientedBox::new([10.5, 0.0, 0.0], 0.0, [1.0, 40.0, 40.0])],
            ..Default::default()
        }
    }

    /// Each hit's polar angle from +x and its direction (rad), from the points themselves.
    fn angles(cloud: &Cloud) -> Vec<(f64, f64)> {
        let hits = cloud.points.iter().filter(|p| **p != [0.0; 3]);
        hits.map(|p| {
            let v = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64).normalize();
            (v.x.acos(), v.z.atan2(v.y))
        })
        .collect()
    }

    /// Share of the disc's cells (0.5 deg square, those wholly inside the field of view) that
    /// hold a point.
    fn coverage(rosette: &Rosette, cloud: &Cloud) -> f64 {
        let cell = 0.5f64.to_radians();
        let n = (rosette.half_fov / cell).floor() as i64;
        let key = |(polar, turn): (f64, f64)| {
            let (y, z) = (polar * turn.cos(), polar * turn.sin());
            ((y / cell).floor() as i64, (z / cell).floor() as i64)
        };
        let seen: std::collections::HashSet<_> = angles(cloud).into_iter().map(key).collect();
        let inside = |i: i64, j: i64| {
            let far = |k: i64| (k.abs().max((k + 1).abs()) as f64) * cell;
            far(i).hypot(far(j)) <= rosette.half_fov
        };
        let cells: Vec<_> = (-n..n).flat_map(|i| (-n..n).map(move |j| (i, j))).collect();
        let disc: Vec<_> = cells.into_iter().filter(|&(i, j)| inside(i, j)).collect();
        disc.iter().filter(|c| seen.contains(c)).count() as f64 / disc.len() as f64
    }

    #[test]
    fn covers_its_circular_field_of_view_and_nothing_outside() {
        let rosette = Rosette { range_noise: 0.0, ..Rosette::mid40(60_000) };
        let cloud = rosette.scan(&wall(), &Pose::identity(), 0, &mut Pcg64::seed_from_u64(1));
        assert_eq!(cloud.len(), 60_000);
        let angles = angles(&cloud);
        assert_eq!(angles.len(), 60_000, "the wall fills the field of view");
        let widest = angles.iter().map(|a| a.0).fold(0.0, f64::max);
        assert!(widest <= rosette.half_fov + 1e-6, "{} deg", widest.to_degrees());
        assert!(widest > rosette.half_fov - 0.05f64.to_radians(), "reaches the edge");
        // Every direction about the axis, and the centre too.
        let mut turns = [0usize; 12];
        for (_, turn) in &angles {
            turns[((turn + std::f64::consts::PI) / std::f64::consts::TAU * 12.0) as usize % 12] +=
                1;
        }
        assert!(turns.iter().all(|&n| n > 3000), "{turns:?}");
        assert!(angles.iter().any(|a| a.0 < 0.5f64.to_radians()));
        // Non-repetitive: 0.1 s covers part of the disc, 0.6 s nearly all of it.
        let short = Rosette { points: 10_000, ..rosette.clone() };
        let brief = coverage(
            &short,
            &short.scan(&wall(), &Pose::identity(), 0, &mut Pcg64::seed_from_u64(1)),
        );
        let full = coverage(&rosette, &cloud);
        eprintln!("disc covered: {brief:.3} in 0.1 s, {full:.3} in 0.6 s");
        assert!((0.15..0.6).contains(&brief), "0.1 s: {brief}");
        assert!(full > 0.93, "0.6 s: {full}");
    }

    #[test]
    fn frames_continue_the_pattern() {
        let rosette = Rosette { range_noise: 0.0, ..Rosette::mid40(5_000) };
        let scan =
            |frame| rosette.scan(&wall(), &Pose::identity(), frame, &mut Pcg64::seed_from_u64(1));
        let (a, b) = (scan(0), scan(1));
        // No shot of frame 1 repeats one of frame 0 (to a micro-radian).
        let key = |(p, t): (f64, f64)| ((p * 1e6) as i64, (t * 1e6) as i64);
        let first: std::collections::HashSet<_> = angles(&a).into_iter().map(key).collect();
        let repeated = angles(&b).into_iter().filter(|x| first.contains(&key(*x))).count();
        assert_eq!(repeated, 0);
        // Frame 1's first shot is the one after frame 0's last.
        let next = Vector3::from(b.points[0].map(f64::from)).normalize();
        assert!((next - rosette.beam(5_000)).norm() < 1e-6, "{next:?}");
        assert_eq!(scan(1), b, "seeded");
    }
}
