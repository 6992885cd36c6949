use std::time::Instant;

use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

use super::*;

/// A rectangle: a corner and two edge vectors.
struct Face {
    corner: Vector3<f64>,
    u: Vector3<f64>,
    v: Vector3<f64>,
}

impl Face {
    fn area(&self) -> f64 {
        self.u.cross(&self.v).norm()
    }

    fn normal(&self) -> Vector3<f64> {
        self.u.cross(&self.v).normalize()
    }
}

/// The cube's centre and half edge (m).
const CUBE_CENTRE: [f64; 3] = [2.0, 0.0, 0.5];
const CUBE_HALF: f64 = 0.25;

/// A 0.5 m cube centred at (2, 0, 0.5) and a 1 m x 0.6 m board (normal along x) behind it.
fn scene() -> Vec<Face> {
    let c = Vector3::from(CUBE_CENTRE);
    let mut faces = Vec::new();
    for axis in 0..3 {
        let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut u = Vector3::zeros();
        u[i] = 2.0 * CUBE_HALF;
        let mut v = Vector3::zeros();
        v[j] = 2.0 * CUBE_HALF;
        for sign in [-1.0, 1.0] {
            let mut corner = c - Vector3::repeat(CUBE_HALF);
            corner[axis] = c[axis] + sign * CUBE_HALF;
            faces.push(Face { corner, u, v });
        }
    }
    faces.push(Face {
        corner: Vector3::new(2.6, -0.2, 0.2),
        u: Vector3::new(0.0, 1.0, 0.0),
        v: Vector3::new(0.0, 0.0, 0.6),
    });
    faces
}

/// `n` points uniformly over the faces (picked by area), with their face normals.
fn sample(faces: &[Face], n: usize, rng: &mut Pcg64) -> Vec<([f64; 3], [f64; 3])> {
    let total: f64 = faces.iter().map(Face::area).sum();
    (0..n)
        .map(|_| {
            let mut pick = rng.random_range(0.0..total);
            let face = faces
                .iter()
                .find(|f| {
                    pick -= f.area();
                    pick < 0.0
                })
                .unwrap_or(&faces[faces.len() - 1]);
            let p = face.corner
                + face.u * rng.random_range(0.0..1.0)
                + face.v * rng.random_range(0.0..1.0);
            (p.into(), face.normal().into())
        })
        .collect()
}

/// 1200 centres (about 4 cm apart) on the scene, a_max 30.
fn model() -> CadModel {
    let mut rng = Pcg64::seed_from_u64(7);
    CadModel::from_samples(&sample(&scene(), 1200, &mut rng), 30.0)
}

/// The per-sensor errors: 3 deg about differing axes (through the vehicle origin, 2 m from
/// the scene) and 5 cm along differing directions.
fn errors(sensors: usize) -> Vec<Pose> {
    let axes =
        [Vector3::new(1.0, 0.3, 0.2), Vector3::new(-0.2, 1.0, 0.4), Vector3::new(0.3, -0.5, 1.0)];
    let shifts = [
        Vector3::new(0.03, -0.04, 0.0),
        Vector3::new(-0.02, 0.0, 0.046),
        Vector3::new(0.0, 0.035, -0.036),
    ];
    (0..sensors)
        .map(|s| {
            let rotation =
                UnitQuaternion::from_scaled_axis(axes[s % 3].normalize() * 3f64.to_radians());
            Pose::from_parts(Translation3::from(shifts[s % 3].normalize() * 0.05), rotation)
        })
        .collect()
}

/// Two views per sensor of `per_view` fresh surface samples each with 5 mm gaussian noise per
/// axis (and, with `outliers`, a quarter as many more points uniform in the scene's box grown
/// by 0.3 m: 20 % of the view), moved by the sensor's error.
fn views(
    errors: &[Pose],
    per_view: usize,
    outliers: bool,
    seed: u64,
) -> (Vec<Vec<[f32; 3]>>, Vec<usize>) {
    let faces = scene();
    let mut rng = Pcg64::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.005).expect("sigma");
    let (lo, hi) = (Vector3::new(1.45, -0.55, -0.05), Vector3::new(2.9, 1.1, 1.05));
    let mut all = Vec::new();
    let mut sensor_of_view = Vec::new();
    for (s, error) in errors.iter().enumerate() {
        for _ in 0..2 {
            let mut points: Vec<Vector3<f64>> = sample(&faces, per_view, &mut rng)
                .into_iter()
                .map(|(p, _)| Vector3::from(p) + Vector3::from_fn(|_, _| noise.sample(&mut rng)))
                .collect();
            if outliers {
                for _ in 0..per_view / 4 {
                    points.push(Vector3::from_fn(|i, _| rng.random_range(lo[i]..hi[i])));
                }
            }
            let view = points
                .iter()
                .map(|p| {
                    let q = error.transform_point(&Point3::from(*p));
                    [q.x as f32, q.y as f32, q.z as f32]
                })
                .collect();
            all.push(view);
            sensor_of_view.push(s);
        }
    }
    (all, sensor_of_view)
}

fn refs(views: &[Vec<[f32; 3]>]) -> Vec<&[[f32; 3]]> {
    views.iter().map(|v| v.as_slice()).collect()
}

/// Rotation (deg) and translation (m, at the vehicle origin) of `pose * error`: the identity
/// when `pose` undoes `error`.
fn residual(pose: &Pose, error: &Pose) -> (f64, f64) {
    let r = pose * error;
    (r.rotation.angle().to_degrees(), r.translation.vector.norm())
}

/// Registers `sensors` sensors of 2 x 20000 points each (the estimate's spread is set by the
/// 5 mm noise: with 4000 points per sensor the weakest rotation's Cramer-Rao bound alone is
/// 0.046 deg) and checks every sensor's pose undoes its error within 0.05 deg and 2 mm.
fn recovers(sensors: usize, outliers: bool, seed: u64) {
    let model = model();
    let errors = errors(sensors);
    let (views, sensor_of_view) = views(&errors, 20_000, outliers, seed);
    let settings = CadSettings::default();
    let start = Instant::now();
    let result = register(
        &CadViews { points: &refs(&views), sensor_of: &sensor_of_view, sensors },
        &model,
        None,
        None,
        &settings,
        |_| Control::Continue,
    )
    .expect("registers");
    eprintln!(
        "{sensors} sensors, {} points, outliers {outliers}: {} iterations in {:.2} s, sigma {:.1} mm",
        views.iter().map(Vec::len).sum::<usize>(),
        result.iterations,
        start.elapsed().as_secs_f64(),
        result.sigma * 1e3
    );
    assert!(result.converged && !result.cancelled);
    for (s, (pose, error)) in result.poses.iter().zip(&errors).enumerate() {
        let (deg, m) = residual(pose, error);
        let (deg0, m0) = residual(&Pose::identity(), error);
        eprintln!(
            "  sensor {s}: {deg:.4} deg, {:.2} mm (from {deg0:.1} deg, {:.0} mm), support {}, rms {:.1} mm",
            m * 1e3,
            m0 * 1e3,
            result.support[s],
            result.rms[s] * 1e3
        );
        assert!(deg < 0.05, "sensor {s}: rotation error {deg} deg");
        assert!(m < 0.002, "sensor {s}: translation error {m} m");
    }
}

#[test]
fn recovers_each_sensors_inverse_error() {
    recovers(3, false, 11);
}

#[test]
fn recovers_with_uniform_outliers() {
    recovers(2, true, 12);
}

#[test]
fn flat_faces_are_anisotropic_and_edges_are_not() {
    let model = model();
    let a_max = 30.0;
    // A cube centre's distance (m) to the nearest cube edge; `None` off the cube (the board
    // is flat everywhere, its rim included).
    let edge_distance = |c: &Vector3<f64>| {
        let d = (c - Vector3::from(CUBE_CENTRE)).abs();
        if d.max() > CUBE_HALF + 1e-9 {
            return None;
        }
        // One coordinate is at the face (gap 0); the edge distance is the smaller other gap.
        let mut gaps: Vec<f64> = d.iter().map(|v| CUBE_HALF - v).collect();
        gaps.sort_by(f64::total_cmp);
        Some(gaps[1])
    };
    let (mut flat, mut edge) = (Vec::new(), Vec::new());
    for (c, a) in model.centres.iter().zip(&model.anisotropy) {
        match edge_distance(c) {
            Some(d) if d > 0.12 => flat.push(*a),
            Some(d) if d < 0.01 => edge.push(*a),
            _ => {}
        }
    }
    assert!(flat.len() > 50 && edge.len() > 20, "{} flat, {} edge", flat.len(), edge.len());
    edge.sort_by(f64::total_cmp);
    let mean = edge.iter().sum::<f64>() / edge.len() as f64;
    // Face middles: a_max. Within 1 cm of an edge: mostly 0 (their 12 nearest samples span
    // two faces), a few higher where the samples of the other face happen to be sparse.
    assert!(flat.iter().all(|a| *a > 0.95 * a_max), "flat centres: {flat:?}");
    assert!(edge[edge.len() / 2] < 0.05 * a_max, "edge centres: {edge:?}");
    assert!(mean < 0.2 * a_max, "edge centres' mean {mean}");
    assert!(model.anisotropy.iter().all(|a| (0.0..=a_max).contains(a)));
    assert!(model.normals.iter().all(|n| (n.norm() - 1.0).abs() < 1e-9));
}

#[test]
fn errors_are_named() {
    let model = model();
    let settings = CadSettings::default();
    let points = [[2.0f32, 0.0, 0.75], [2.1, 0.1, 0.75], [2.0, 0.2, 0.75]];
    let go = |views: &[&[[f32; 3]]], of: &[usize], sensors: usize, model: &CadModel| {
        register(
            &CadViews { points: views, sensor_of: of, sensors },
            model,
            None,
            None,
            &settings,
            |_| Control::Continue,
        )
        .map(|_| ())
    };
    let empty = CadModel { centres: Vec::new(), normals: Vec::new(), anisotropy: Vec::new() };
    assert_eq!(go(&[&points], &[0], 1, &empty), Err(CadError::NoCentres));
    assert_eq!(go(&[&points, &[]], &[0, 1], 2, &model), Err(CadError::NoPoints { sensor: 1 }));
    assert_eq!(go(&[&points], &[0], 2, &model), Err(CadError::NoPoints { sensor: 1 }));
    let mut bad = points;
    bad[2][1] = f32::NAN;
    assert_eq!(
        go(&[&points, &bad], &[0, 0], 1, &model),
        Err(CadError::NonFinitePoint { view: 1, index: 2 })
    );
    assert_eq!(go(&[&points], &[1], 1, &model), Err(CadError::InvalidSetting("sensor_of_view")));
    assert_eq!(go(&[&points], &[0, 0], 1, &model), Err(CadError::InvalidSetting("sensor_of_view")));
    let mut broken = model.clone();
    broken.anisotropy.pop();
    assert_eq!(go(&[&points], &[0], 1, &broken), Err(CadError::InvalidSetting("model")));
    let zero = CadSettings { max_iterations: 0, ..CadSettings::default() };
    assert_eq!(
        register(
            &CadViews { points: &[&points], sensor_of: &[0], sensors: 1 },
            &model,
            None,
            None,
            &zero,
            |_| Control::Continue
        )
        .map(|_| ()),
        Err(CadError::InvalidSetting("max_iterations"))
    );
    assert_eq!(CadError::NoPoints { sensor: 3 }.to_string(), "sensor 3 has no points");
}

#[test]
fn stops_on_convergence_and_on_request() {
    let model = model();
    let errors = errors(2);
    let (views, sensor_of_view) = views(&errors, 2000, false, 5);
    let views = refs(&views);
    let settings = CadSettings::default();
    let mut calls = 0;
    let done = register(
        &CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 2 },
        &model,
        None,
        None,
        &settings,
        |it| {
            calls += 1;
            assert_eq!(it.iteration, calls);
            Control::Continue
        },
    )
    .expect("registers");
    assert!(done.converged && !done.cancelled);
    assert!(done.iterations < settings.max_iterations, "{} iterations", done.iterations);
    assert_eq!((calls, done.history.len()), (done.iterations, done.iterations));
    let (last, before) = done.history.split_last().expect("iterations");
    assert!(last.max_change < settings.tolerance);
    assert!(before.iter().all(|h| h.max_change >= settings.tolerance));
    assert_eq!(done.sigma, last.sigma);

    let stopped = register(
        &CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 2 },
        &model,
        None,
        None,
        &settings,
        |it| {
            if it.iteration == 3 { Control::Stop } else { Control::Continue }
        },
    )
    .expect("registers");
    assert!(stopped.cancelled && !stopped.converged);
    assert_eq!(stopped.iterations, 3);

    // A cap below what convergence needs: neither converged nor cancelled.
    let capped = CadSettings { max_iterations: 4, ..CadSettings::default() };
    let short = register(
        &CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 2 },
        &model,
        None,
        None,
        &capped,
        |_| Control::Continue,
    )
    .expect("registers");
    assert!(!short.converged && !short.cancelled && short.iterations == 4);
}

/// Timing at the size the module is meant for: 6 views x 5000 points, 1000 centres; with the
/// reference's initial sigma (the scene's diagonal) and with 0.2 m.
#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn timing_six_views_of_5000_points() {
    let mut rng = Pcg64::seed_from_u64(3);
    let model = CadModel::from_samples(&sample(&scene(), 1000, &mut rng), 30.0);
    let errors = errors(3);
    let (views, sensor_of_view) = views(&errors, 5000, false, 4);
    let views = refs(&views);
    for (initial_sigma, tolerance) in
        [(None, 1e-7), (None, 0.0), (Some(0.2), 1e-7), (Some(0.2), 0.0)]
    {
        let settings = CadSettings { initial_sigma, tolerance, ..CadSettings::default() };
        let start = Instant::now();
        let r = register(
            &CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 3 },
            &model,
            None,
            None,
            &settings,
            |_| Control::Continue,
        )
        .expect("registers");
        let worst = r.poses.iter().zip(&errors).map(|(p, e)| residual(p, e).0).fold(0.0, f64::max);
        eprintln!(
            "initial sigma {initial_sigma:?}, tolerance {tolerance}: {} iterations in {:.3} s, worst {worst:.3} deg",
            r.iterations,
            start.elapsed().as_secs_f64(),
        );
    }
}

/// The model placed 1 deg and 2 cm off (as a placement from one sensor's few points can be):
/// with its copy free and sensor 0 fixed, sensor 1 lands on sensor 0 and the copy on the
/// truth; with the copy fixed, sensor 1 is pulled onto the misplaced model.
#[test]
fn a_misplaced_copy_moves_with_the_data() {
    let misplaced = Pose::from_parts(
        Translation3::new(0.02, -0.01, 0.01),
        UnitQuaternion::from_scaled_axis(
            Vector3::new(0.2, 1.0, 0.3).normalize() * 1f64.to_radians(),
        ),
    );
    let true_model = model();
    let model = CadModel {
        centres: true_model
            .centres
            .iter()
            .map(|c| misplaced.transform_point(&(*c).into()).coords)
            .collect(),
        normals: true_model.normals.iter().map(|n| misplaced.rotation * n).collect(),
        anisotropy: true_model.anisotropy.clone(),
    };
    let errors = vec![Pose::identity(), errors(2)[1]];
    let (views, sensor_of_view) = views(&errors, 20_000, false, 21);
    let views = refs(&views);
    let input = CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 2 };
    let of_centre = vec![0; model.len()];
    let of_view = vec![0; views.len()];
    let copies =
        Copies { of_centre: &of_centre, of_view: &of_view, fixed_sensor: 0, below_sigma: 0.1 };
    let settings = CadSettings::default();
    let free = register(&input, &model, Some(&copies), None, &settings, |_| Control::Continue)
        .expect("registers");
    let fixed =
        register(&input, &model, None, None, &settings, |_| Control::Continue).expect("registers");
    assert_eq!(free.poses[0], Pose::identity());
    let (deg, m) = residual(&free.poses[1], &errors[1]);
    let (copy_deg, copy_m) = residual(&free.copies[0], &misplaced);
    let (fixed_deg, fixed_m) = residual(&fixed.poses[1], &errors[1]);
    eprintln!(
        "copy free: sensor 1 {deg:.4} deg {:.2} mm, copy {copy_deg:.4} deg {:.2} mm; copy fixed: sensor 1 {fixed_deg:.3} deg {:.1} mm",
        m * 1e3,
        copy_m * 1e3,
        fixed_m * 1e3
    );
    assert!(deg < 0.05 && m < 0.002, "sensor 1: {deg} deg, {m} m");
    assert!(copy_deg < 0.05 && copy_m < 0.002, "copy: {copy_deg} deg, {copy_m} m");
    assert!(
        fixed_deg > 0.5,
        "with the copy fixed sensor 1 follows the misplaced model: {fixed_deg}"
    );
}

/// A few noisy points on the cube leave the tilt about it loose; the ground (20 x 20 m around
/// the vehicle, both sensors seeing it) holds it.
#[test]
fn the_ground_holds_the_tilt_about_the_target() {
    let model = model();
    let tilt = Pose::from_parts(
        Translation3::new(0.0, 0.0, 0.0),
        UnitQuaternion::from_scaled_axis(
            Vector3::new(1.0, 1.0, 0.0).normalize() * 1f64.to_radians(),
        ),
    );
    let errors = vec![Pose::identity(), tilt];
    let (mut views, sensor_of_view) = views(&errors, 300, false, 31);
    let mut rng = Pcg64::seed_from_u64(32);
    let noise = Normal::new(0.0, 0.02).expect("sigma");
    let ground: Vec<Vec<[f32; 3]>> = errors
        .iter()
        .map(|e| {
            (0..4000)
                .map(|_| {
                    let p = Vector3::new(
                        rng.random_range(-10.0..10.0),
                        rng.random_range(-10.0..10.0),
                        noise.sample(&mut rng),
                    );
                    let q = e.transform_point(&Point3::from(p));
                    [q.x as f32, q.y as f32, q.z as f32]
                })
                .collect()
        })
        .collect();
    // Noisier target points: 2 cm.
    let mut rng = Pcg64::seed_from_u64(33);
    for view in &mut views {
        for p in view.iter_mut() {
            for c in p.iter_mut() {
                *c += noise.sample(&mut rng) as f32;
            }
        }
    }
    let views = refs(&views);
    let input = CadViews { points: &views, sensor_of: &sensor_of_view, sensors: 2 };
    let lists: Vec<&[[f32; 3]]> = ground.iter().map(Vec::as_slice).collect();
    let on_ground =
        Ground { normal: [0.0, 0.0, 1.0], offset: 0.0, points: &lists, sensor_of: &[0, 1] };
    let settings = CadSettings::default();
    let tilt_error = |pose: &Pose| {
        let r = (pose * tilt).rotation * Vector3::z();
        r.angle(&Vector3::z()).to_degrees()
    };
    let with = register(&input, &model, None, Some(&on_ground), &settings, |_| Control::Continue)
        .expect("registers");
    let without =
        register(&input, &model, None, None, &settings, |_| Control::Continue).expect("registers");
    let (with_tilt, without_tilt) = (tilt_error(&with.poses[1]), tilt_error(&without.poses[1]));
    eprintln!("tilt error with the ground {with_tilt:.4} deg, without {without_tilt:.4} deg");
    assert!(with_tilt < 0.01, "with the ground: {with_tilt} deg");
    assert!(without_tilt > 2.0 * with_tilt, "without: {without_tilt}, with: {with_tilt}");
    let bad = Ground { normal: [0.0, 0.0, 2.0], ..on_ground };
    assert_eq!(
        register(&input, &model, None, Some(&bad), &settings, |_| Control::Continue).map(|_| ()),
        Err(CadError::InvalidSetting("ground"))
    );
}
