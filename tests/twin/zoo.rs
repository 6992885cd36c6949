//! The rig zoo against its truth: every preset gives points on every sensor, the sensors meant
//! to overlap do (one sensor's points lie on the surfaces another sees, placed by the true
//! mounts), and what each preset stands for holds: an upside-down fan looks up, rosette units
//! overlap in a strip only, half-float coordinates, a moving car's frames from other poses.

use std::collections::HashMap;

use gmmcalib::twin::{MID100_POINTS, Model, OrganizedScan, PRESETS, Preset, float16};
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};

/// The zoo's presets, by name.
const ZOO: [&str; 5] = ["stacked", "sideways", "mid100", "surround", "moving"];

fn preset(name: &str) -> Preset {
    match Model::by_name(name) {
        Some(Model::RayCast(p)) => p,
        other => panic!("{name}: {other:?}"),
    }
}

/// Each view's hits in the world frame, placed by the true mount and the frame's vehicle pose.
fn world(preset: &Preset, views: &[OrganizedScan]) -> Vec<Vec<Vector3<f64>>> {
    let n = preset.sensors.len();
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (frame, s) = (i / n, &preset.sensors[i % n]);
            let pose = preset.vehicle_pose(frame).map_or(s.mount, |v| v * s.mount);
            let hits = v.cloud.points.iter().filter(|p| **p != [0.0; 3]);
            hits.map(|p| (pose * Point3::from(p.map(f64::from))).coords).collect()
        })
        .collect()
}

/// Points hashed into cubes of `cell` (m), to find neighbours.
struct Grid<'a> {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<&'a Vector3<f64>>>,
}

impl<'a> Grid<'a> {
    fn new(points: &'a [Vector3<f64>], cell: f64) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<_>> = HashMap::new();
        for p in points {
            cells.entry(Self::key(p, cell)).or_default().push(p);
        }
        Self { cell, cells }
    }

    fn key(p: &Vector3<f64>, cell: f64) -> [i64; 3] {
        [0, 1, 2].map(|i| (p[i] / cell).floor() as i64)
    }

    /// The points within `cell` of `p`.
    fn near(&self, p: &Vector3<f64>) -> Vec<&'a Vector3<f64>> {
        let k = Self::key(p, self.cell);
        let mut out = Vec::new();
        for d in 0..27i64 {
            let c = [k[0] + d % 3 - 1, k[1] + d / 3 % 3 - 1, k[2] + d / 9 - 1];
            let found = self.cells.get(&c).into_iter().flatten();
            out.extend(found.filter(|q| (**q - p).norm() < self.cell));
        }
        out
    }
}

/// How many of `points` lie within 5 cm of the surface `other` sees: a plane fitted to
/// `other`'s points within 0.5 m (at least 6 of them, spread along a surface).
fn on_surface_of(points: &[Vector3<f64>], other: &[Vector3<f64>]) -> usize {
    let grid = Grid::new(other, 0.5);
    let on = |p: &Vector3<f64>| {
        let near = grid.near(p);
        if near.len() < 6 {
            return false;
        }
        let mean = near.iter().copied().sum::<Vector3<f64>>() / near.len() as f64;
        let cov = near.iter().map(|q| (*q - mean) * (*q - mean).transpose()).sum::<Matrix3<f64>>();
        let eigen = SymmetricEigen::new(cov / near.len() as f64);
        let (mut order, values) = ([0, 1, 2], eigen.eigenvalues);
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        // A line of points (one ring) fixes no plane: the middle spread must be real.
        if values[order[1]] < 0.01 * 0.01 {
            return false;
        }
        let normal = eigen.eigenvectors.column(order[0]);
        normal.dot(&(p - mean)).abs() < 0.05
    };
    points.iter().filter(|p| on(p)).count()
}

/// Share of sensor `b`'s points (frame 1) on the surfaces sensor `a` sees.
fn overlap(hits: &[Vec<Vector3<f64>>], a: usize, b: usize) -> f64 {
    on_surface_of(&hits[b], &hits[a]) as f64 / hits[b].len() as f64
}

#[test]
fn every_preset_has_a_name_and_every_sensor_points() {
    for name in ZOO {
        assert!(PRESETS.contains(&name), "{name}");
        let p = preset(name);
        assert!(p.targetless && p.targets().count() == 0, "{name}: targetless");
        let views = p.simulate(2, 1);
        assert_eq!(views.len(), 2 * p.sensors.len());
        for (v, hits) in views.iter().zip(world(&p, &views)) {
            assert_eq!(v.cloud.len(), v.width * v.height, "{name} {}", v.sensor);
            let in_roi = hits.iter().filter(|w| p.roi.contains([w.x, w.y, w.z])).count();
            eprintln!(
                "{name} {} frame {}: {} hits, {in_roi} in the ROI",
                v.sensor,
                v.frame,
                hits.len()
            );
            assert!(in_roi > 3000, "{name} {} frame {}: {in_roi}", v.sensor, v.frame);
        }
    }
}

#[test]
fn the_sensors_meant_to_overlap_do() {
    // (preset, sensor, the reference's share of its points on the reference's surfaces).
    let wanted: [(&str, usize, f64); 9] = [
        ("stacked", 1, 0.2),
        ("sideways", 1, 0.1),
        ("sideways", 2, 0.1),
        ("surround", 1, 0.1),
        ("surround", 2, 0.1),
        ("surround", 3, 0.1),
        ("surround", 4, 0.1),
        ("moving", 1, 0.2),
        ("mid100", 1, 0.1),
    ];
    for (name, sensor, least) in wanted {
        let p = preset(name);
        let views = p.simulate(1, 2);
        let hits = world(&p, &views);
        let share = overlap(&hits, 0, sensor);
        eprintln!(
            "{name}: {:.3} of {}'s points on {}'s surfaces",
            share, p.sensors[sensor].name, p.sensors[0].name
        );
        assert!(share > least, "{name} {}: {share}", p.sensors[sensor].name);
    }
}

#[test]
fn mid100_units_overlap_in_a_strip_only() {
    let p = Preset::mid100(MID100_POINTS);
    assert_eq!(
        p.sensors.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
        ["middle", "left", "right"]
    );
    let hits = world(&p, &p.simulate(1, 3));
    for (a, b) in [(0, 1), (0, 2), (1, 0), (2, 0)] {
        let share = overlap(&hits, a, b);
        eprintln!(
            "mid100: {share:.3} of {}'s points on {}'s surfaces",
            p.sensors[b].name, p.sensors[a].name
        );
        // A strip a few degrees wide: real, but far from all of it (the real rig: a quarter).
        assert!((0.08..0.4).contains(&share), "{a} {b}: {share}");
    }
    // The outer units, 60 deg apart with 38.4 deg fields of view, share nothing.
    let apart = overlap(&hits, 1, 2);
    assert!(apart < 0.01, "left and right: {apart}");
}

#[test]
fn the_upside_down_sensor_looks_up_and_coordinates_are_half_floats() {
    let p = preset("stacked");
    let views = p.simulate(1, 4);
    let hits = world(&p, &views);
    // Highest elevation seen from each sensor's own origin (deg).
    let highest = |i: usize| {
        let o = p.sensors[i].mount.translation.vector;
        hits[i]
            .iter()
            .map(|w| ((w.z - o.z) / (w - o).norm()).asin().to_degrees())
            .fold(-90.0, f64::max)
    };
    let (upper, lower) = (highest(0), highest(1));
    // The upper fan stops at +10.67 deg; the flipped one reaches the walls' tops and the poles
    // (nothing in the street stands higher than 24 deg above it).
    assert!(upper < 10.8, "upper {upper}");
    assert!(lower > 20.0, "lower {lower}");
    // Every coordinate is a binary16; the f32 street's are not.
    let halves = |views: &[OrganizedScan]| {
        let all = views.iter().flat_map(|v| v.cloud.points.iter().flatten());
        let (n, exact) =
            all.fold((0, 0), |(n, e), x| (n + 1, e + usize::from(float16::round(*x) == *x)));
        exact as f64 / n as f64
    };
    assert_eq!(halves(&views), 1.0);
    let street = preset("street").simulate(1, 4);
    assert!(halves(&street) < 0.5, "{}", halves(&street));
}

#[test]
fn moving_frames_come_from_different_vehicle_poses() {
    let p = preset("moving");
    let poses: Vec<_> = (0..5).map(|f| p.vehicle_pose(f).expect("a drive")).collect();
    for pair in poses.windows(2) {
        let step = pair[0].inverse() * pair[1];
        let (metres, turn) = (step.translation.vector.norm(), step.rotation.angle().to_degrees());
        assert!((2.0..=5.0).contains(&metres) && turn < 6.0, "{metres} m, {turn} deg");
    }
    assert!(poses.windows(2).any(|w| (w[0].inverse() * w[1]).rotation.angle() > 1f64.to_radians()));
    // The reference's frames 1 and 3, off the ground (which is z = 0 from any pose): placed in
    // the world by their poses they land on the same surfaces; taken as they are (vehicle
    // frame) they do not, because the scene moved.
    let views = p.simulate(3, 5);
    let raised = |points: Vec<Vector3<f64>>| -> Vec<Vector3<f64>> {
        points.into_iter().filter(|w| w.z > 0.3).collect()
    };
    let in_world = world(&p, &views);
    let (first, third) = (raised(in_world[0].clone()), raised(in_world[4].clone()));
    let as_taken = |v: &OrganizedScan| {
        let hits = v.cloud.points.iter().filter(|q| **q != [0.0; 3]);
        raised(hits.map(|q| (p.sensors[0].mount * Point3::from(q.map(f64::from))).coords).collect())
    };
    let share =
        |a: &[Vector3<f64>], b: &[Vector3<f64>]| on_surface_of(b, a) as f64 / b.len() as f64;
    let placed = share(&first, &third);
    let unplaced = share(&as_taken(&views[0]), &as_taken(&views[4]));
    eprintln!("moving: frame 3 on frame 1's surfaces {placed:.3} placed, {unplaced:.3} as taken");
    assert!(placed > 0.6 && unplaced < placed - 0.2, "{placed} {unplaced}");
}

#[test]
fn zoo_scans_are_seeded() {
    for name in ZOO {
        let model = Model::by_name(name).expect("a preset");
        let a = model.simulate(2, 7);
        assert_eq!(a, model.simulate(2, 7), "{name}");
        assert_ne!(a, model.simulate(2, 8), "{name}");
        // Frames differ: fresh noise, and a rosette's pattern or a moving car's pose moves on.
        assert_ne!(a[0].cloud, a[a.len() / 2].cloud, "{name}");
    }
}
