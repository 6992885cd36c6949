//! The plane adjustment on scenes of cubes with known motions.

use super::detect::{clusters, frame_observations};
use super::*;
use crate::se3::pose_from_xyz_rpy;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

/// Points on the visible faces of an axis-aligned cube (edge `a`, centre `c` at height
/// `a / 2`) standing on z = 0 and a ground patch around it, sampled on a grid with noise along `beam` from the
/// origin.
fn scene(c: Vector3<f64>, a: f64, step: f64, noise: f64, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise).unwrap();
    let mut pts = Vec::new();
    let n = (a / step) as i64;
    for i in 0..=n {
        for j in 0..=n {
            let (s, t) = (i as f64 * step - a / 2.0, j as f64 * step);
            // Front face (facing -x), side face (facing -y), top.
            pts.push(Vector3::new(c.x - a / 2.0, c.y + s, t));
            pts.push(Vector3::new(c.x + s, c.y - a / 2.0, t));
            pts.push(Vector3::new(c.x + s, c.y + t - a / 2.0, a));
        }
    }
    for i in -30..=30 {
        for j in -30..=30 {
            let p = Vector3::new(c.x + i as f64 * 0.05, c.y + j as f64 * 0.05, 0.0);
            if (p.x - c.x).abs() > a / 2.0 + 0.01 || (p.y - c.y).abs() > a / 2.0 + 0.01 {
                pts.push(p);
            }
        }
    }
    pts.iter().map(|p| p + p.normalize() * normal.sample(&mut rng)).collect()
}

/// Both sensors of these scenes sit at the origin.
const ORIGINS: [Vector3<f64>; 2] = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 0.0)];

fn as_f32(points: &[Vector3<f64>]) -> Vec<[f32; 3]> {
    points.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect()
}

/// Two sensors see the same scene of two cubes; the second one's points are moved by a
/// small wrong correction. The adjustment must find the inverse, from a start that is off.
#[test]
fn recovers_a_small_motion_between_two_sensors() {
    let cubes = [Vector3::new(10.0, -1.0, 0.25), Vector3::new(11.0, 1.0, 0.25)];
    let truth = pose_from_xyz_rpy([0.004, -0.006, 0.002], [0.001, -0.0008, 0.0015]);
    let mut clouds = Vec::new();
    for frame in 0..3u64 {
        for sensor in 0..2u64 {
            let mut pts: Vec<Vector3<f64>> = Vec::new();
            // The sensors sample the faces on different grids.
            let step = 0.04 - 0.005 * sensor as f64;
            for (i, c) in cubes.iter().enumerate() {
                pts.extend(scene(*c, 0.5, step, 0.003, frame * 10 + sensor + 100 * i as u64));
            }
            if sensor == 1 {
                pts = pts
                    .iter()
                    .map(|p| (truth.inverse() * nalgebra::Point3::from(*p)).coords)
                    .collect();
            }
            clouds.push(as_f32(&pts));
        }
    }
    let refs: Vec<&[[f32; 3]]> = clouds.iter().map(|c| c.as_slice()).collect();
    let pairs = vec![vec![(0, 0), (2, 2), (4, 4)], vec![(0, 1), (2, 3), (4, 5)]];
    let mut corrections = vec![
        pairs[0].iter().map(|&p| (p, Pose::identity())).collect::<Vec<_>>(),
        pairs[1].iter().map(|&p| (p, Pose::identity())).collect::<Vec<_>>(),
    ];
    let ground = Plane { normal: Vector3::z(), offset: 0.0 };
    let outcomes = adjust(
        &refs,
        &ORIGINS,
        &pairs,
        0,
        &mut corrections,
        Some((ground, 0.03)),
        &PlaneSettings::default(),
    );
    assert_eq!(outcomes.len(), 1);
    assert!(outcomes[0].accepted, "{outcomes:?}");
    for (_, c) in &corrections[1] {
        let error = c.inverse() * truth;
        let (deg, m) = (error.rotation.angle().to_degrees(), error.translation.vector.norm());
        assert!(deg < 0.005 && m < 0.001, "{deg} deg, {m} m");
    }
    assert!(corrections[0].iter().all(|(_, c)| *c == Pose::identity()));
}

#[test]
fn finds_the_faces_of_a_cube_and_drops_its_edges() {
    let points: Vec<(usize, Vector3<f64>)> =
        scene(Vector3::new(10.0, 0.0, 0.25), 0.5, 0.02, 0.0, 1)
            .into_iter()
            .enumerate()
            .map(|(i, p)| (i % 2, p))
            .collect();
    let ground = Plane { normal: Vector3::z(), offset: 0.0 };
    let (mut planes, mut observations) = (Vec::new(), Vec::new());
    let settings = PlaneSettings::default();
    frame_observations(&points, &ground, 0.03, &settings, 0, &mut planes, &mut observations);
    // Ground, front, side, top.
    assert_eq!(planes.len(), 4, "{planes:?}");
    for o in &observations {
        let d = planes[o.plane].distance(&o.point);
        assert!(d.abs() < 1e-6, "{d} {:?} {:?}", o.point, planes[o.plane]);
        // Near the cube, no point kept is near a second plane (the planes extend beyond).
        let near_cube = (o.point.x - 10.0).abs() < 0.3 && o.point.y.abs() < 0.3;
        let near = planes.iter().filter(|p| p.distance(&o.point).abs() <= settings.edge_distance);
        assert!(!near_cube || near.count() == 1, "{:?}", o.point);
    }
    // Edge points are out: the top's points keep 3 cm from the front and side faces.
    assert!(observations.len() < points.len());
}

#[test]
fn a_motion_beyond_the_limit_is_rejected() {
    let cube = Vector3::new(10.0, 0.0, 0.25);
    // 0.057 deg of yaw about the origin: 1 cm at the cube.
    let truth = pose_from_xyz_rpy([0.0, 0.0, 0.0], [0.0, 0.0, 0.001]);
    let a = scene(cube, 0.5, 0.03, 0.0, 1);
    let b: Vec<Vector3<f64>> = scene(cube, 0.5, 0.03, 0.0, 2)
        .iter()
        .map(|p| (truth.inverse() * nalgebra::Point3::from(*p)).coords)
        .collect();
    let clouds = [as_f32(&a), as_f32(&b)];
    let refs: Vec<&[[f32; 3]]> = clouds.iter().map(|c| c.as_slice()).collect();
    let pairs = vec![vec![(0, 0)], vec![(0, 1)]];
    let mut corrections = vec![vec![((0, 0), Pose::identity())], vec![((0, 1), Pose::identity())]];
    let settings =
        PlaneSettings { max_departure: (0.03f64.to_radians(), 0.02), ..Default::default() };
    let ground = Plane { normal: Vector3::z(), offset: 0.0 };
    let outcomes =
        adjust(&refs, &ORIGINS, &pairs, 0, &mut corrections, Some((ground, 0.03)), &settings);
    assert!(!outcomes[0].accepted, "{outcomes:?}");
    assert!((outcomes[0].motion.rotation.angle() - 0.001).abs() < 1e-4, "{outcomes:?}");
    assert_eq!(corrections[1][0].1, Pose::identity());
}

#[test]
fn clusters_are_the_connected_groups_of_occupied_cells() {
    use rand::RngExt;
    let mut rng = Pcg64::seed_from_u64(7);
    let gap = 0.15;
    // Sparse points, so groups of one cell, chains and blobs all occur, negative cells too.
    let points: Vec<(usize, Vector3<f64>)> =
        (0..600).map(|i| (i % 3, Vector3::from_fn(|_, _| rng.random_range(-1.5..1.5)))).collect();
    let indices: Vec<usize> = (0..points.len()).filter(|i| i % 5 != 0).collect();
    let groups = clusters(&points, &indices, gap);
    // Brute force: two points share a group when a chain of cells, each within one step of
    // the next on every axis, joins theirs.
    let cell = |i: usize| points[i].1.map(|c| (c / gap).floor() as i64);
    let mut label: Vec<Option<usize>> = vec![None; points.len()];
    let mut expected = 0;
    for &start in &indices {
        if label[start].is_some() {
            continue;
        }
        let mut stack = vec![start];
        label[start] = Some(expected);
        while let Some(i) = stack.pop() {
            for &j in &indices {
                if label[j].is_none() && (cell(i) - cell(j)).amax() <= 1 {
                    label[j] = Some(expected);
                    stack.push(j);
                }
            }
        }
        expected += 1;
    }
    assert_eq!(groups.len(), expected);
    assert!(expected > 20 && groups.iter().any(|g| g.len() > 10), "{expected} groups");
    let mut seen = vec![false; points.len()];
    for group in &groups {
        let first = label[group[0]];
        for &i in group {
            assert_eq!(label[i], first);
            assert!(!std::mem::replace(&mut seen[i], true), "point {i} twice");
        }
    }
    assert!(indices.iter().all(|&i| seen[i]));
}
