//! Points on a target's surface: the initial means of JRMPC's mixture, placed by the caller at
//! the centroid of the ROI's points (GMMCalib hard-codes a position; the centroid follows the
//! data).

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// `k` points uniformly distributed over the surface of a cube of edge `edge` centred on the
/// origin (faces have equal area, so each point picks a face uniformly).
pub fn cube_surface(edge: f64, k: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let h = edge / 2.0;
    (0..k)
        .map(|_| {
            let face = rng.random_range(0..6usize);
            let u = rng.random_range(-h..=h);
            let v = rng.random_range(-h..=h);
            let w = if face % 2 == 0 { h } else { -h };
            match face / 2 {
                0 => [w, u, v],
                1 => [u, w, v],
                _ => [u, v, w],
            }
        })
        .collect()
}

/// `k` points uniformly distributed over the surface of a box of edges `size` (x, y, z)
/// centred on the origin: each point picks a face by its area.
pub fn box_surface(size: [f64; 3], k: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let h = size.map(|s| s / 2.0);
    // Face pairs normal to x, y, z, weighted by their area.
    let areas = [size[1] * size[2], size[0] * size[2], size[0] * size[1]];
    let total: f64 = areas.iter().sum();
    (0..k)
        .map(|_| {
            let pick = rng.random_range(0.0..total);
            let axis = if pick < areas[0] {
                0
            } else if pick < areas[0] + areas[1] {
                1
            } else {
                2
            };
            let mut p = [0, 1, 2].map(|i| rng.random_range(-h[i]..=h[i]));
            p[axis] = if rng.random_range(0..2u8) == 0 { h[axis] } else { -h[axis] };
            p
        })
        .collect()
}

/// `k` points on a sphere of radius `radius` centred on the origin, evenly spread by the
/// Fibonacci lattice (deterministic, no clustering at the poles).
pub fn sphere_surface(radius: f64, k: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..k)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / k as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            [radius * r * phi.cos(), radius * r * phi.sin(), radius * z]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_points_lie_on_the_surface() {
        let points = cube_surface(0.5, 400, 7);
        assert_eq!(points.len(), 400);
        for p in &points {
            let m = p.iter().fold(0.0f64, |m, c| m.max(c.abs()));
            assert!((m - 0.25).abs() < 1e-12, "{p:?}");
        }
        // Every face is used.
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                assert!(points.iter().any(|p| (p[axis] - sign * 0.25).abs() < 1e-12));
            }
        }
        assert_eq!(points, cube_surface(0.5, 400, 7), "seeded: same output every run");
    }

    #[test]
    fn sphere_points_lie_on_the_sphere_and_prior_is_centred() {
        let means = super::super::Target::Sphere { diameter: 4.0 }.surface(100, [1.0, 2.0, 3.0], 0);
        let n = means.len() as f64;
        let c = [0, 1, 2].map(|i| means.iter().map(|p| p[i]).sum::<f64>() / n);
        assert!(
            (c[0] - 1.0).abs() < 0.05 && (c[1] - 2.0).abs() < 0.05 && (c[2] - 3.0).abs() < 0.05
        );
        for p in means {
            let r = ((p[0] - 1.0).powi(2) + (p[1] - 2.0).powi(2) + (p[2] - 3.0).powi(2)).sqrt();
            assert!((r - 2.0).abs() < 1e-12);
        }
    }
}
