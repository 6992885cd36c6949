//! The digital twin against its own ground truth: the ray-cast scans, the miscalibration and
//! its seed rule.

use gmmcalib::se3::{Pose, rpy};
use gmmcalib::twin::{
    MAX_MISCALIBRATION_ANGLE, MAX_MISCALIBRATION_TRANSLATION, Miscalibration, Model, Preset, Twin,
    expected_correction,
};
use nalgebra::{Point3, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

fn point(p: &[f32; 3]) -> Point3<f64> {
    Point3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

fn is_miss(p: &[f32; 3]) -> bool {
    *p == [0.0; 3]
}

/// The paper preset with fewer columns, to keep the tests fast.
fn paper(columns: usize, noise: f64) -> Preset {
    let mut preset = Preset::paper();
    for s in &mut preset.sensors {
        s.lidar.spinning_mut().expect("spinning").horizontal_steps = columns;
        *s.lidar.range_noise_mut() = noise;
    }
    preset
}

#[test]
fn simulate_is_organized_labelled_and_seeded() {
    let preset = paper(512, 0.01);
    let views = preset.simulate(2, 5);
    assert_eq!(views.len(), 4);
    let labels: Vec<_> = views.iter().map(|v| (v.sensor.as_str(), v.frame.as_str())).collect();
    assert_eq!(
        labels,
        [("front_left", "1"), ("front_right", "1"), ("front_left", "2"), ("front_right", "2")]
    );
    for v in &views {
        assert_eq!((v.width, v.height), (512, 50));
        assert_eq!(v.cloud.len(), 512 * 50);
    }
    // Frames re-sample the noise, the same seed repeats everything.
    assert_ne!(views[0].cloud, views[2].cloud);
    assert_eq!(views, preset.simulate(2, 5));
    assert_ne!(views, preset.simulate(2, 6));
}

#[test]
fn miscalibration_stays_in_bounds_and_is_seeded() {
    let truth = Preset::paper().sensors[0].mount;
    let mut rng = Pcg64::seed_from_u64(1);
    let (a, t) = (MAX_MISCALIBRATION_ANGLE, MAX_MISCALIBRATION_TRANSLATION);
    let mut largest = [0.0f64; 2];
    for _ in 0..200 {
        let nominal = Miscalibration::within(a, t).draw(&truth, &mut rng);
        // The sensor turned about itself and shifted: the turn is nominal's rotation over the
        // truth's, the shift the difference of their positions.
        let angles = rpy(&(nominal.rotation * truth.rotation.inverse()));
        let shift = nominal.translation.vector - truth.translation.vector;
        assert!(angles.iter().all(|x| x.abs() <= a + 1e-12), "{angles:?}");
        assert!(shift.iter().all(|x| x.abs() <= t + 1e-12));
        largest[0] = angles.iter().fold(largest[0], |m, x| m.max(x.abs()));
        largest[1] = shift.iter().fold(largest[1], |m, x| m.max(x.abs()));
    }
    // The samples use the whole range, not a sliver of it.
    assert!(largest[0] > 0.9 * a && largest[1] > 0.9 * t, "{largest:?}");
    let draw = |seed| Miscalibration::within(a, t).draw(&truth, &mut Pcg64::seed_from_u64(seed));
    assert_eq!(draw(3), draw(3));
    assert_ne!(draw(3), draw(4));
}

#[test]
fn corrected_nominal_points_land_on_the_truth() {
    let preset = paper(512, 0.0);
    let views = preset.simulate(1, 2);
    let mut rng = Pcg64::seed_from_u64(9);
    let mut worst = [0.0f64; 2];
    let mut hits = 0;
    for (s, view) in preset.sensors.iter().zip(&views) {
        let truth = s.mount;
        let nominal = Miscalibration::within(MAX_MISCALIBRATION_ANGLE, 0.1).draw(&truth, &mut rng);
        let correction = expected_correction(&truth, &nominal);
        // The nominal alone is visibly wrong at 10 m.
        let far = point(&[10.0, 0.0, 0.0]);
        assert!((nominal * far - truth * far).norm() > 0.01);
        for (i, p) in view.cloud.points.iter().enumerate() {
            if is_miss(p) {
                continue;
            }
            hits += 1;
            let pre_aligned = nominal * point(p);
            let corrected = correction * pre_aligned;
            worst[0] = worst[0].max((corrected - truth * point(p)).norm());
            // Independently: the world hit of the same beam cast from the true mount. The
            // scan is stored in f32, so allow a relative error of 1e-6.
            let (row, col) = (i / view.width, i % view.width);
            let dir = truth.rotation * s.lidar.spinning().expect("spinning").beam(row, col);
            let origin = truth.translation.vector;
            let t = preset.scene.intersect(origin, dir, s.lidar.max_range()).unwrap();
            let err = (corrected.coords - (origin + dir * t)).norm() / t.max(1.0);
            worst[1] = worst[1].max(err);
        }
    }
    eprintln!("corrected vs truth: {:.2e} m; vs ray cast: {:.2e} (relative)", worst[0], worst[1]);
    assert!(hits > 10_000);
    assert!(worst[0] < 1e-6 && worst[1] < 1e-6, "{worst:?}");
}

#[test]
fn paper_preset_sees_every_cube_with_both_sensors() {
    let preset = paper(2048, 0.01);
    let views = preset.simulate(1, 1);
    let targets: Vec<_> = preset.targets().collect();
    assert_eq!(targets.len(), 3);
    for (s, view) in preset.sensors.iter().zip(&views) {
        let roi: Vec<Vector3<f64>> = view
            .cloud
            .points
            .iter()
            .filter(|p| !is_miss(p))
            .map(|p| (s.mount * point(p)).coords)
            .filter(|w| preset.roi.contains([w.x, w.y, w.z]))
            .collect();
        let on_cube: Vec<usize> = targets
            .iter()
            .map(|b| roi.iter().filter(|w| w.z > 0.05 && b.contains(**w, 0.05)).count())
            .collect();
        let ground = roi.iter().filter(|w| w.z.abs() < 0.05).count();
        eprintln!("{}: {} ROI points, cubes {on_cube:?}, ground {ground}", s.name, roi.len());
        assert!(on_cube.iter().all(|&n| n > 50), "{}: {on_cube:?}", s.name);
        assert!(ground > 200, "{}: {ground}", s.name);
        // Every ROI point is on a cube or the ground.
        assert_eq!(ground + on_cube.iter().sum::<usize>(), roi.len());
        // The validation cube is seen too, outside the ROI.
        let validation = &preset.scene.boxes[preset.validation_box.unwrap()];
        let seen = view
            .cloud
            .points
            .iter()
            .filter(|p| !is_miss(p))
            .filter(|p| {
                let w = (s.mount * point(p)).coords;
                w.z > 0.05 && validation.contains(w, 0.05)
            })
            .count();
        assert!(seen > 10, "{}: validation cube {seen}", s.name);
    }
}

#[test]
fn sensors_lean_towards_the_centre_line() {
    // Each sensor's beam aimed across the car (towards the other sensor) points downwards.
    for s in &Preset::paper().sensors {
        let across = Vector3::new(0.0, -s.mount.translation.y.signum(), 0.0);
        let world = s.mount.rotation * across;
        assert!(world.z < -0.3, "{}: {world:?}", s.name);
    }
}

#[test]
fn os1_128_preset_shares_scene_and_mounts() {
    let (paper, os1) = (Preset::paper(), Preset::os1_128());
    assert_eq!(paper.scene, os1.scene);
    assert_eq!(paper.roi, os1.roi);
    for (a, b) in paper.sensors.iter().zip(&os1.sensors) {
        assert_eq!(a.mount, b.mount);
        assert_eq!(b.lidar.height(), 128);
        assert_eq!(b.lidar.max_range(), 120.0);
        let angles = &b.lidar.spinning().expect("spinning").vertical_angles;
        let fov = angles[0] - angles[127];
        assert!((fov - 45f64.to_radians()).abs() < 1e-12);
    }
    let angles = &paper.sensors[0].lidar.spinning().expect("spinning").vertical_angles;
    let fov = angles[0] - angles[49];
    assert!((fov - 25f64.to_radians()).abs() < 1e-12);
}

/// One seed rule: the same preset, frames and seed give the same rig (the page's demo and
/// `gmmcalib simulate` alike); the bounds move the nominals, never the scans; the reference
/// keeps its true mount.
#[test]
fn the_seed_rule_gives_the_same_twin_everywhere() {
    let model = Model::by_name("sampled").expect("a preset");
    let a = Twin::new(&model, 2, 9, &Miscalibration::default());
    let b = Twin::new(&model, 2, 9, &Miscalibration::default());
    assert_eq!(a.scans, b.scans);
    assert_eq!(a.nominal, b.nominal);
    let wider = Twin::new(&model, 2, 9, &Miscalibration::within(0.1, 0.3));
    assert_eq!(a.scans, wider.scans, "the bounds keep the scans");
    assert_ne!(a.nominal[1], wider.nominal[1]);
    assert_eq!(a.nominal[0].1, a.truth[0].1, "the reference keeps its true mount");
    let other = Twin::new(&model, 2, 10, &Miscalibration::default());
    assert_ne!(a.nominal[1], other.nominal[1]);
    // A draw's own seed (a study's start) moves the nominals, not the scans.
    let start = Twin::new(&model, 2, 9, &Miscalibration { seed: Some(9001), ..Default::default() });
    assert_eq!(a.scans, start.scans);
    assert_ne!(a.nominal[1], start.nominal[1]);
    let d: Pose = a.correction(1) * a.nominal[1].1;
    assert!((d.inverse() * a.truth[1].1).translation.vector.norm() < 1e-12);
    for name in gmmcalib::twin::PRESETS {
        assert!(Model::by_name(name).is_some(), "{name}");
    }
}
