//! JRMPC on its own: exact recovery of known transforms, the convergence test, and degenerate
//! input.

use crate::common;
use gmmcalib::jrmpc::{self, Control, EmSettings, JrmpcError};
use gmmcalib::se3::{Pose, pose_from_xyz_rpy};
use gmmcalib::targets::cube_surface;
use nalgebra::Point3;

fn cube_points(n: usize, seed: u64, pose: &Pose) -> Vec<[f32; 3]> {
    cube_surface(0.5, n, seed)
        .iter()
        .map(|p| {
            let q = pose * Point3::new(p[0] + 4.0, p[1], p[2] + 0.25);
            [q.x as f32, q.y as f32, q.z as f32]
        })
        .collect()
}

fn prior_means(k: usize) -> Vec<[f64; 3]> {
    cube_surface(0.5, k, 99).iter().map(|p| [p[0] + 4.0, p[1], p[2] + 0.25]).collect()
}

/// Three views' offsets from the first: a few centimetres and degrees.
fn known_offsets() -> [Pose; 3] {
    [
        Pose::identity(),
        pose_from_xyz_rpy([0.05, -0.08, 0.03], [0.04, -0.03, 0.05]),
        pose_from_xyz_rpy([-0.1, 0.02, -0.06], [-0.05, 0.05, -0.02]),
    ]
}

/// Views holding the same sample positions under known offsets leave the method nothing to
/// blur: the relative transforms must come back exactly, forward and inverse.
#[test]
fn recovers_known_offsets_exactly_when_views_share_samples() {
    let offsets = known_offsets();
    let views: Vec<Vec<[f32; 3]>> = offsets.iter().map(|o| cube_points(1500, 1, o)).collect();
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    let settings =
        EmSettings { initial_sigma: Some(0.5), max_iterations: 300, ..EmSettings::default() };
    let result =
        jrmpc::register(&refs, &prior_means(300), &settings, |_| Control::Continue).unwrap();
    assert!(result.converged, "stopped after {} iterations without converging", result.iterations);
    for (j, offset) in offsets.iter().enumerate() {
        // T_model_view_j maps view j onto the model; view j = offset_j * view 0.
        let relative = result.poses[0].inverse() * result.poses[j];
        let error = relative * offset;
        assert!(error.rotation.angle() < 1e-6, "view {j}: {} rad", error.rotation.angle());
        assert!(
            error.translation.vector.norm() < 1e-6,
            "view {j}: {} m",
            error.translation.vector.norm()
        );
    }
    assert!(result.history.iter().all(|h| h.mean_sigma.is_finite() && h.max_change.is_finite()));
    assert!(result.unsupported.is_empty());
}

/// Stopping at the default tolerance gives the calibration 100 fixed iterations give, to 1e-5.
#[test]
fn convergence_test_matches_fixed_iterations() {
    let offset = pose_from_xyz_rpy([0.03, 0.02, -0.01], [0.02, 0.01, -0.03]);
    let views = [cube_points(1000, 2, &Pose::identity()), cube_points(1000, 2, &offset)];
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    let means = prior_means(200);
    let early = EmSettings { initial_sigma: Some(0.5), ..EmSettings::default() };
    let fixed = EmSettings { tolerance: 0.0, ..early.clone() };
    let a = jrmpc::register(&refs, &means, &early, |_| Control::Continue).unwrap();
    let b = jrmpc::register(&refs, &means, &fixed, |_| Control::Continue).unwrap();
    assert!(
        a.converged && a.iterations < 100,
        "converged: {}, iterations: {}",
        a.converged,
        a.iterations
    );
    assert_eq!(b.iterations, 100);
    // The calibration is what must match: each view relative to the first (the mixture floats,
    // so absolute poses may keep drifting together).
    let (ra, rb) = (a.poses[0].inverse() * a.poses[1], b.poses[0].inverse() * b.poses[1]);
    let d = ra.inverse() * rb;
    assert!(d.rotation.angle() < 1e-5 && d.translation.vector.norm() < 1e-5, "{d}");
}

#[test]
fn progress_runs_every_iteration_and_can_cancel() {
    let views = [cube_points(300, 3, &Pose::identity()), cube_points(300, 4, &Pose::identity())];
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    let settings = EmSettings { tolerance: 0.0, max_iterations: 20, ..EmSettings::default() };
    let mut seen = Vec::new();
    let result = jrmpc::register(&refs, &prior_means(50), &settings, |p| {
        seen.push(p.iteration);
        assert_eq!(p.poses.len(), 2);
        if p.iteration == 7 { Control::Stop } else { Control::Continue }
    })
    .unwrap();
    assert_eq!(seen, (1..=7).collect::<Vec<_>>());
    assert!(result.cancelled && !result.converged);
    assert_eq!(result.iterations, 7);
}

#[test]
fn degenerate_input_is_a_typed_error() {
    let good = cube_points(100, 5, &Pose::identity());
    let means = prior_means(20);
    let s = EmSettings::default();
    let run = |views: &[&[[f32; 3]]], means: &[[f64; 3]]| {
        jrmpc::register(views, means, &s, |_| Control::Continue).err()
    };
    assert_eq!(run(&[], &means), Some(JrmpcError::NoViews));
    assert_eq!(run(&[&good], &[]), Some(JrmpcError::NoComponents));
    assert_eq!(run(&[&good, &[]], &means), Some(JrmpcError::DegenerateView { view: 1, points: 0 }));
    assert_eq!(
        run(&[&good, &[[1.0, 2.0, 3.0]]], &means),
        Some(JrmpcError::DegenerateView { view: 1, points: 1 })
    );
    let same = vec![[1.0f32, 2.0, 3.0]; 50];
    assert_eq!(
        run(&[&good, &same], &means),
        Some(JrmpcError::DegenerateView { view: 1, points: 50 })
    );
    let mut nan = good.clone();
    nan[17][1] = f32::NAN;
    assert_eq!(
        run(&[&good, &nan], &means),
        Some(JrmpcError::NonFinitePoint { view: 1, index: 17 })
    );
    let mut bad_means = means.clone();
    bad_means[3][0] = f64::INFINITY;
    assert_eq!(run(&[&good], &bad_means), Some(JrmpcError::NonFiniteMean { index: 3 }));
    let no_gamma = EmSettings { gamma: 0.0, ..EmSettings::default() };
    assert!(jrmpc::register(&[&good], &means, &no_gamma, |_| Control::Continue).is_err());
}

/// Collinear points and far-away components must not produce NaN: the view keeps a rotation
/// and components that lose all support drop out.
#[test]
fn weak_data_never_produces_nan() {
    let line: Vec<[f32; 3]> = (0..100).map(|i| [4.0 + i as f32 * 0.005, 0.0, 0.25]).collect();
    let good = cube_points(500, 6, &Pose::identity());
    let mut means = prior_means(50);
    means.push([500.0, 500.0, 500.0]); // a component nothing can reach
    let settings =
        EmSettings { initial_sigma: Some(0.5), max_iterations: 30, ..EmSettings::default() };
    let result =
        jrmpc::register(&[&good, &line], &means, &settings, |_| Control::Continue).unwrap();
    for pose in &result.poses {
        assert!(pose.to_homogeneous().iter().all(|v| v.is_finite()));
    }
    let m = &result.mixture;
    assert!(m.means.iter().all(|x| x.iter().all(|v| v.is_finite())));
    assert!(m.variances.iter().all(|v| v.is_finite() && *v > 0.0));
    assert_eq!(m.priors[50], 0.0, "the unreachable component drops out");
}

/// The fast E-step (grid with a bound on the neglected mass, SIMD lanes, polynomial exp)
/// against the exact dense one, through the calibration on synthetic rigs: every sensor's
/// correction within 1e-4 rad and 0.1 mm, iteration counts within 1. Plain JRMPC on these rigs
/// is still moving after 100 iterations, so errors in the terms show: f32 exps of f64 exponents
/// (the kernel) move the results by at most 8e-6 rad and 3e-5 m; f32 distances as well, by up
/// to 5e-4 rad, which is why the exponents stay f64.
#[test]
fn fast_estep_calibrates_as_the_dense_one() {
    use crate::common::{RigSpec, generate};
    use gmmcalib::calib::{self, InitialSigma, Method};

    // (rig, K, mixture started at the prior's size (else the bounding box), max iterations,
    // convergence test on)
    let rigs = [
        // Partial views; converges within 600 iterations (seed 6 since the miscalibration turns
        // the sensor about itself: seed 3 no longer converges by then).
        (
            RigSpec { frames: 3, partial: true, seed: 6, ..RigSpec::default() },
            300,
            false,
            600,
            true,
        ),
        // Full views, three sensors.
        (RigSpec { frames: 2, sensors: 3, seed: 5, ..RigSpec::default() }, 200, true, 100, true),
        // As the bench: fixed 100 iterations, K = 444.
        (
            RigSpec { frames: 2, partial: true, seed: 7, ..RigSpec::default() },
            444,
            false,
            100,
            false,
        ),
    ];
    for (n, (spec, components, prior_size, iterations, converge)) in rigs.into_iter().enumerate() {
        let synthetic = generate(&spec);
        let rig = common::rig_of(&synthetic);
        let mut settings = calib::Settings {
            components,
            initial_sigma: if prior_size {
                InitialSigma::TargetSize
            } else {
                InitialSigma::BoundingBox
            },
            ..Default::default()
        };
        settings.jrmpc.max_iterations = iterations;
        if !converge {
            settings.jrmpc.tolerance = 0.0;
        }
        let fast = calib::calibrate(&rig, Method::Jrmpc, &settings, |_| Control::Continue).unwrap();
        settings.jrmpc.exact = true;
        let dense =
            calib::calibrate(&rig, Method::Jrmpc, &settings, |_| Control::Continue).unwrap();
        assert!(
            fast.iterations.abs_diff(dense.iterations) <= 1,
            "rig {n}: {} iterations fast, {} dense",
            fast.iterations,
            dense.iterations
        );
        if n == 0 {
            assert!(
                dense.converged && dense.iterations < iterations,
                "rig 0 converges: {} iterations",
                dense.iterations
            );
        }
        let evaluated: u64 = fast.history.iter().map(|h| h.terms).sum();
        let all: u64 = dense.history.iter().map(|h| h.terms).sum();
        assert!(evaluated < all, "rig {n}: the fast path skips terms");
        for (f, d) in fast.sensors.iter().zip(&dense.sensors) {
            let e = f.correction.inverse() * d.correction;
            let (angle, shift) = (e.rotation.angle(), e.translation.vector.norm());
            println!(
                "rig {n} {}: {angle:.1e} rad, {shift:.1e} m; iterations {} / {}; terms {:.1} %",
                f.name,
                fast.iterations,
                dense.iterations,
                100.0 * evaluated as f64 / all as f64
            );
            assert!(angle < 1e-4 && shift < 1e-4, "rig {n} {}: {angle} rad, {shift} m", f.name);
        }
    }
}

/// Sharding the views over threads changes nothing: each view's sums come from one thread.
#[test]
fn threads_give_identical_results() {
    let identity = Pose::identity();
    let offset = pose_from_xyz_rpy([0.03, 0.02, -0.01], [0.02, 0.01, -0.03]);
    let views: Vec<Vec<[f32; 3]>> = (0..5)
        .map(|j| cube_points(800, 10 + j, if j % 2 == 0 { &offset } else { &identity }))
        .collect();
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    for multiresolution in [false, true] {
        let one = EmSettings {
            initial_sigma: Some(0.5),
            max_iterations: 40,
            multiresolution,
            ..EmSettings::default()
        };
        let a = jrmpc::register(&refs, &prior_means(150), &one, |_| Control::Continue).unwrap();
        for threads in [2, 3, 8] {
            let s = EmSettings { threads, ..one.clone() };
            let b = jrmpc::register(&refs, &prior_means(150), &s, |_| Control::Continue).unwrap();
            assert_eq!(a.poses, b.poses, "{threads} threads");
            assert_eq!(a.mixture, b.mixture);
            assert_eq!(a.history, b.history);
        }
    }
}

/// Multi-resolution EM (each view's points merged in cubes while sigma is large) lands where
/// every point does, for a fraction of the terms; off, nothing is merged.
#[test]
fn multiresolution_registers_as_every_point_does() {
    let offsets = known_offsets();
    let views: Vec<Vec<[f32; 3]>> =
        offsets.iter().enumerate().map(|(j, o)| cube_points(4000, 20 + j as u64, o)).collect();
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    let every =
        EmSettings { initial_sigma: Some(0.5), max_iterations: 100, ..EmSettings::default() };
    let merged = EmSettings { multiresolution: true, ..every.clone() };
    let run = |s: &EmSettings| {
        jrmpc::register(&refs, &prior_means(300), s, |_| Control::Continue).unwrap()
    };
    let (a, b) = (run(&every), run(&merged));
    let terms = |r: &jrmpc::Registration| r.history.iter().map(|h| h.terms).sum::<u64>();
    let first = |r: &jrmpc::Registration| r.history[0].terms;
    assert_eq!(first(&a), 3 * 4000 * 300, "sigma 0.5 reaches every component: dense");
    assert!(first(&b) * 10 < first(&a), "merged: {} terms of {}", first(&b), first(&a));
    // Both against the truth: the views' own offsets (T_model_view maps view j onto view 0's
    // frame as offsets[j]^-1 does).
    for (j, offset) in offsets.iter().enumerate().skip(1) {
        let error = |r: &jrmpc::Registration| {
            let e = r.poses[0].inverse() * r.poses[j] * offset;
            (e.rotation.angle(), e.translation.vector.norm())
        };
        let ((ra, ta), (rb, tb)) = (error(&a), error(&b));
        println!(
            "view {j}: every point {ra:.1e} rad / {ta:.1e} m off, merged {rb:.1e} rad / {tb:.1e} \
             m; terms {:.1} % of every point's",
            100.0 * terms(&b) as f64 / terms(&a) as f64
        );
        assert!(rb < ra.max(1e-3) * 1.5 && tb < ta.max(1e-3) * 1.5, "view {j}");
    }
}

/// Driving EM by hand, as the browser's worker pool does, with uneven shards that each compute
/// their own views' statistics, gives `register`'s result bit for bit.
#[test]
fn em_driven_over_uneven_shards_matches_register() {
    let identity = Pose::identity();
    let offset = pose_from_xyz_rpy([0.03, 0.02, -0.01], [0.02, 0.01, -0.03]);
    let views: Vec<Vec<[f32; 3]>> = (0..5)
        .map(|j| {
            cube_points(
                600 + 100 * j as usize,
                20 + j,
                if j % 2 == 0 { &offset } else { &identity },
            )
        })
        .collect();
    let refs: Vec<&[[f32; 3]]> = views.iter().map(|v| v.as_slice()).collect();
    let settings =
        EmSettings { initial_sigma: Some(0.5), max_iterations: 40, ..EmSettings::default() };
    let expected =
        jrmpc::register(&refs, &prior_means(150), &settings, |_| Control::Continue).unwrap();

    let (mut em, points) = jrmpc::Em::start(&refs, &prior_means(150), &settings).unwrap();
    let split = [1, 3, 1];
    let mut points = points.into_iter();
    let mut shards: Vec<jrmpc::Shard> =
        split.iter().map(|&n| jrmpc::Shard::new(points.by_ref().take(n).collect())).collect();
    let mut stats = em.empty_stats();
    let mut iterations = 0;
    while !em.finished() {
        let mut first = 0;
        let mut terms = 0;
        // Last shard first: the order the shards finish in must not matter.
        let ranges: Vec<_> = split
            .iter()
            .map(|&n| {
                first += n;
                first - n..first
            })
            .collect();
        for (shard, range) in shards.iter_mut().zip(&ranges).rev() {
            let transforms = &em.transforms()[range.clone()];
            terms += shard.e_step(&em.step(), transforms, &mut stats[range.clone()]);
        }
        em.m_step(&stats, terms);
        iterations += 1;
        assert_eq!(em.latest().iteration, iterations);
    }
    let driven = em.into_registration();
    assert_eq!(driven.poses, expected.poses);
    assert_eq!(driven.mixture, expected.mixture);
    assert_eq!(driven.history, expected.history);
    assert_eq!(driven.iterations, expected.iterations);
}
