//! ICP baseline timings: one registration per pair (target preparation included) for a ~2k-point
//! view and a ~65k-point full scan, per metric, best of a few runs.
//!
//! A module, not a bench target: the main bench binary includes it with `#[path]` and calls
//! [`run`]. Build it in release mode; timings use `std::time::Instant`.

use std::time::{Duration, Instant};

use gmmcalib::Pose;
use gmmcalib::icp::{FixedCloud, IcpSettings, Metric};
use gmmcalib::se3::{angle_between, pose_from_xyz_rpy};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

/// Boxes on the ground: footprint centre as a fraction of the half extent, size (m), yaw (rad).
const BOXES: [([f64; 2], [f64; 3], f64); 4] = [
    ([0.4, 0.2], [1.0, 0.8, 1.2], 0.3),
    ([-0.3, 0.5], [2.0, 1.5, 0.5], -0.7),
    ([0.6, -0.4], [0.5, 0.5, 2.0], 1.1),
    ([-0.5, -0.3], [1.5, 1.0, 1.0], 0.0),
];

/// A scene of `n` points: about 70 % on a ground square of half extent `half` (m), the rest on
/// the tops and sides of the boxes, all with 1 cm Gaussian noise, mapped by `frame_from_world`.
fn scene(rng: &mut Pcg64, n: usize, half: f64, frame_from_world: &Pose) -> Vec<[f32; 3]> {
    let noise = Normal::new(0.0, 0.01).unwrap();
    let mut world = Vec::with_capacity(n);
    let ground = n * 7 / 10;
    for _ in 0..ground {
        world.push(Vector3::new(rng.random_range(-half..half), rng.random_range(-half..half), 0.0));
    }
    for i in 0..n - ground {
        let (centre, size, yaw) = BOXES[i % BOXES.len()];
        let (u, v) = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
        let local = match rng.random_range(0..3) {
            0 => Vector3::new(u * size[0], v * size[1], size[2]),
            1 => Vector3::new(size[0] / 2.0, u * size[1], (v + 0.5) * size[2]),
            _ => Vector3::new(u * size[0], -size[1] / 2.0, (v + 0.5) * size[2]),
        };
        let offset = Vector3::new(centre[0] * half, centre[1] * half, 0.0);
        world.push(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw) * local + offset);
    }
    world
        .iter()
        .map(|p| {
            let q = frame_from_world * Point3::from(*p);
            [q.x, q.y, q.z].map(|c| (c + noise.sample(rng)) as f32)
        })
        .collect()
}

/// Best wall time of `runs` calls of `f`, and its last result.
fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        let out = f();
        best = best.min(start.elapsed());
        last = Some(out);
    }
    (best, last.expect("at least one run"))
}

/// Prints, per cloud size and metric: target preparation, alignment, total per pair,
/// iterations and the error against the known 2 deg / 5 cm offset.
pub fn run() {
    let truth = pose_from_xyz_rpy([0.03, -0.03, 0.02], [0.02, -0.015, 0.025]);
    let settings = IcpSettings::default();
    println!("icp: per-pair registration, best of runs (1 cm noise, 2 deg / 5 cm offset)");
    for (label, n, half, runs) in [("view ~2k", 2_000, 4.0, 20), ("scan ~65k", 65_000, 20.0, 3)] {
        let mut rng = Pcg64::seed_from_u64(42);
        let target = scene(&mut rng, n, half, &Pose::identity());
        let source = scene(&mut rng, n, half, &truth.inverse());
        for metric in Metric::ALL {
            let (prepare, prepared) = best_of(runs, || FixedCloud::new(&target, metric, &settings));
            let Ok(prepared) = prepared else {
                println!("  {label:<10} {metric:<5} failed: {}", prepared.unwrap_err());
                continue;
            };
            let (register, result) =
                best_of(runs, || prepared.align(&source, &Pose::identity(), &settings));
            match result {
                Ok(a) => {
                    let deg =
                        angle_between(&a.target_from_source.rotation, &truth.rotation).to_degrees();
                    let mm = (a.target_from_source.translation.vector - truth.translation.vector)
                        .norm()
                        * 1e3;
                    println!(
                        "  {label:<10} {metric:<5} total {:>9.2} ms  (target {:>8.2} ms, align {:>8.2} ms)  \
                         {:>2} it  err {deg:.3} deg {mm:.1} mm",
                        (prepare + register).as_secs_f64() * 1e3,
                        prepare.as_secs_f64() * 1e3,
                        register.as_secs_f64() * 1e3,
                        a.iterations,
                    );
                }
                Err(e) => println!("  {label:<10} {metric:<5} failed: {e}"),
            }
        }
    }
}
