//! The verdict on a labelled suite: good rigs (the twin within and beyond the spec,
//! 2 and 3 sensors, a nominal 40 deg / 2 m off, targets carried about between frames, each
//! judged by its truth) must be `good`; OpenCalib's real road scenes from their own guess must
//! not be `failed`; known-bad rigs (sensors swapped, another scene for one sensor, a region of interest holding only ground, a nominal
//! beyond the local search's reach with the global stage off, frames shifted in time, one sensor
//! given twice, one sensor's frames given as sensors, OpenCalib's raw guess taken as it is)
//! must be `check` or `failed`. The confusion table and what caught each bad case print with
//! `--nocapture` (docs/accuracy.md, "The verdict").

use gmmcalib::calib::{self, Calibration, Level, Rig, Scan, Settings};
use gmmcalib::cloud::Aabb;
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::pose_from_xyz_rpy;
use gmmcalib::targets::Target;
use gmmcalib::twin::{Miscalibration, Model, OrientedBox, Preset, Twin};

use crate::common::{for_seeds, opencalib_scene};

/// A case: its name, whether it is good, and the rig with its truth (when it has one).
/// What a case's verdict must be: `good`, not `good`, or (real scans whose reference cannot
/// tell right from wrong) anything but `failed`. A twin case labelled `Good` whose result
/// misses the truth by more than `good` promises must not read `good` either.
#[derive(Clone, Copy, PartialEq)]
enum Label {
    Good,
    Bad,
    Usable,
}

struct Case {
    name: String,
    label: Label,
    rig: Rig,
    twin: Option<Twin>,
    settings: Settings,
}

fn twin(preset: Preset, frames: usize, seed: u64, draw: Miscalibration) -> Twin {
    Twin::new(&Model::RayCast(preset), frames, seed, &draw)
}

fn case(name: &str, good: bool, twin: Twin) -> Case {
    Case {
        name: name.into(),
        label: if good { Label::Good } else { Label::Bad },
        rig: twin.rig(),
        twin: Some(twin),
        settings: Settings::default(),
    }
}

/// The paper preset whose targets move between frames, as a cube carried around.
fn moving() -> Preset {
    Preset { target_motion: Some(0.4), ..Preset::paper() }
}

fn cases() -> Vec<Case> {
    let spec = Miscalibration::default();
    let beyond = Miscalibration {
        angle: [3f64.to_radians(), 3f64.to_radians(), 8f64.to_radians()],
        translation: [0.3; 3],
        seed: None,
    };
    let mut cases = Vec::new();
    for seed in 1..=4 {
        cases.push(case(
            &format!("paper, seed {seed}"),
            true,
            twin(Preset::paper(), 5, seed, spec),
        ));
    }
    for seed in 1..=2 {
        let t = twin(Preset::paper(), 5, seed, beyond);
        cases.push(case(&format!("beyond the spec, seed {seed}"), true, t));
        let t = twin(Preset::paper_roof(), 5, seed, spec);
        cases.push(case(&format!("3 sensors, seed {seed}"), true, t));
        cases.push(case(
            &format!("moving targets, seed {seed}"),
            // Every frame is registered to one mixture: a cube carried 0.4 m about between
            // frames breaks that, yet the ground and the other cubes hold the result (seeds 1
            // and 2: 0.011 deg / 2.3 mm, 0.006 deg / 1.4 mm). Judged by the truth: no evidence
            // tells these frames from a still twin's (their spread, 21 mm in y, against 12 mm
            // on the still 3-sensor twin, both far beyond one frame's precision of 1 mm).
            true,
            twin(moving(), 5, seed, spec),
        ));
    }

    // Sensors on their flank and pitched down (the zoo's `sideways`), no target: the two
    // non-reference sensors overlap mostly on the ground, where a pair alone slides 14 deg /
    // 1.8 m and once read as an open loop.
    cases.push(Case {
        settings: Settings { target: Target::None, ..Settings::default() },
        ..case("sideways mounts, seed 1", true, twin(Preset::sideways(), 3, 1, spec))
    });

    // Sensors swapped: each sensor's nominal is the other's.
    let mut swapped = twin(Preset::paper(), 5, 1, spec);
    let (a, b) = (swapped.nominal[0].1, swapped.nominal[1].1);
    (swapped.nominal[0].1, swapped.nominal[1].1) = (b, a);
    cases.push(case("sensors swapped", false, swapped));

    // Another scene for one sensor: its cubes elsewhere.
    let mut other = Preset::paper();
    other.scene.boxes = vec![
        OrientedBox::cube_on_ground(11.6, -2.0, 0.5, 0.6),
        OrientedBox::cube_on_ground(13.0, 0.8, 0.5, 0.1),
        OrientedBox::cube_on_ground(12.0, 2.0, 0.5, 1.0),
    ];
    other.validation_box = None;
    let seen = twin(Preset::paper(), 5, 2, spec);
    let elsewhere = twin(other, 5, 2, spec);
    let mut rig = seen.rig();
    let theirs = elsewhere.rig();
    for (scan, from) in rig.scans.iter_mut().zip(&theirs.scans) {
        if scan.sensor == "front_right" {
            scan.points = from.points.clone();
        }
    }
    cases.push(Case {
        name: "another scene for one sensor".into(),
        label: Label::Bad,
        rig,
        twin: None,
        settings: Settings::default(),
    });

    // A region of interest holding only ground, in front of the cubes.
    let mut ground = twin(Preset::paper(), 5, 3, spec);
    ground.roi = Aabb::new([7.0, -2.5, -0.5], [10.5, 2.5, 1.0]);
    cases.push(case("ground-only ROI", false, ground));

    // A nominal 40 deg and 2 m off: beyond the bird's-eye search's reach, so bad without the
    // global stage; with it (gmm's default) the truth decides, and it is good.
    let far = Miscalibration { angle: [40f64.to_radians(); 3], translation: [2.0; 3], seed: None };
    cases.push(case("nominal 40 deg / 2 m off", true, twin(Preset::paper(), 5, 3, far)));
    let mut local =
        case("nominal 40 deg / 2 m off, global off", false, twin(Preset::paper(), 5, 3, far));
    local.settings.align_globally = Some(false);
    cases.push(local);

    // One sensor's frames shifted in time against the others', with targets that move.
    let mut shifted = twin(moving(), 5, 4, spec);
    let mut rig = shifted.rig();
    for scan in rig.scans.iter_mut().filter(|s| s.sensor == "front_right") {
        let f: usize = scan.frame.parse().expect("numbered frames");
        scan.frame = (f % 5 + 1).to_string();
    }
    shifted.scans.clear();
    cases.push(Case {
        name: "frames shifted in time".into(),
        label: Label::Bad,
        rig,
        twin: None,
        settings: Settings::default(),
    });

    // One sensor given twice.
    let mut rig = twin(Preset::paper(), 5, 4, spec).rig();
    let copies: Vec<Scan> = rig
        .scans
        .iter()
        .filter(|s| s.sensor == "front_left")
        .map(|s| Scan { sensor: "front_left_again".into(), ..s.clone() })
        .collect();
    rig.scans.extend(copies);
    let nominal = rig.nominal[0].1;
    rig.nominal.push(("front_left_again".into(), nominal));
    cases.push(Case {
        name: "one sensor given twice".into(),
        label: Label::Bad,
        rig,
        twin: None,
        settings: Settings::default(),
    });

    // One sensor's frames as three sensors (loose files 1.pcd 2.pcd 3.pcd), nominals identity.
    let loose = twin(Preset::paper(), 3, 5, spec);
    let scans: Vec<Scan> = loose
        .rig()
        .scans
        .into_iter()
        .filter(|s| s.sensor == "front_left")
        .map(|s| Scan { sensor: format!("scan_{}", s.frame), frame: "1".into(), ..s })
        .collect();
    let nominal = scans.iter().map(|s| (s.sensor.clone(), pose_from_xyz_rpy([0.0; 3], [0.0; 3])));
    let rig = Rig {
        nominal: nominal.collect(),
        scans,
        roi: Some(Aabb::new([8.0, -4.0, -3.0], [13.0, 4.0, 1.0])),
        reference: Some("scan_1".into()),
    };
    cases.push(Case {
        name: "frames of one sensor as sensors".into(),
        label: Label::Bad,
        rig,
        twin: None,
        settings: Settings::default(),
    });

    // Real scans without truth: OpenCalib's road rig from its own guess, each scene on its own
    // (usable: the two scenes agree to 0.2 deg / 2 cm, tests/calib/global.rs, while OpenCalib's own
    // answers for them differ by 0.21 deg / 5.5 cm, so no reference says `good` or `check`;
    // 0002's side LiDARs read `check` as their grounds lie 5-14 mm / 0.16-0.18 deg from the reference's); and the same guess taken as it is, the
    // global stage off (bad: the side LiDARs' grounds are 45 deg off, nothing overlaps).
    let targetless = Settings { target: Target::None, ..Settings::default() };
    for scene in ["0001", "0002"] {
        cases.push(Case {
            name: format!("OpenCalib {scene}, its guess"),
            label: Label::Usable,
            rig: opencalib_scene(scene),
            twin: None,
            settings: targetless.clone(),
        });
    }
    cases.push(Case {
        name: "OpenCalib 0001, its guess as it is (global off)".into(),
        label: Label::Bad,
        rig: opencalib_scene("0001"),
        twin: None,
        settings: Settings { align_globally: Some(false), ..targetless },
    });
    cases
}

/// The worst error against the truth (deg, mm), when there is one.
fn error(c: &Case, result: &Calibration) -> Option<(f64, f64)> {
    let twin = c.twin.as_ref()?;
    let errors = gmmcalib::eval::sensor_errors(twin, result);
    let worst = errors
        .iter()
        .flatten()
        .map(|e| e.deg_m())
        .fold((0.0, 0.0), |(a, m), (b, n)| (f64::max(a, b), f64::max(m, n * 1e3)));
    Some(worst)
}

/// A case is good when labelled so and, where it has a truth, its result is within 0.1 deg and
/// 1 cm of it.
fn good_truth(c: &Case, result: &Result<Calibration, calib::CalibError>) -> bool {
    let good = c.label != Label::Bad;
    match result.as_ref().ok().and_then(|r| error(c, r)) {
        Some((deg, mm)) => good && deg <= 0.1 && mm <= 10.0,
        None => good,
    }
}

#[test]
fn the_verdict_separates_good_rigs_from_known_bad_ones() {
    let cases = cases();
    let outcomes = for_seeds(0..=(cases.len() as u64 - 1), |i| {
        let c = &cases[i as usize];
        let clock = std::time::Instant::now();
        let result =
            calib::calibrate(&c.rig, calib::Method::Gmm, &c.settings, |_| Control::Continue);
        (result, clock.elapsed().as_secs_f64())
    });
    let mut wrong = Vec::new();
    println!("| case | label | verdict | what set it | error vs truth |");
    println!("|---|---|---|---|---|");
    for (c, (result, _)) in cases.iter().zip(&outcomes) {
        let (level, why, truth) = match result {
            Ok(r) => {
                let v = &r.verdict;
                let why: Vec<String> = v
                    .sensors
                    .iter()
                    .flat_map(|s| {
                        s.reasons
                            .iter()
                            .filter(|r| r.level == v.level && v.level > Level::Good)
                            .map(move |r| format!("{}: {}", s.sensor, r.kind.name()))
                    })
                    .collect();
                let truth =
                    error(c, r).map_or("".into(), |(d, m)| format!("{d:.3} deg / {m:.1} mm"));
                (v.level.name(), why.join(", "), truth)
            }
            Err(e) => ("error", e.to_string(), String::new()),
        };
        let label = match c.label {
            Label::Usable => "usable",
            _ if good_truth(c, result) => "good",
            _ => "bad",
        };
        println!("| {} | {label} | {level} | {why} | {truth} |", c.name);
        if let Ok(r) = result {
            for line in detail(r) {
                println!("    {line}");
            }
        }
        let ok = match c.label {
            Label::Usable => level != "failed" && level != "error",
            _ if good_truth(c, result) => level == "good",
            _ => level != "good",
        };
        if !ok {
            wrong.push(c.name.clone());
        }
    }
    assert!(wrong.is_empty(), "misjudged: {wrong:?}");
}

/// The evidence behind a verdict, one line per non-reference sensor (deg, mm).
fn detail(r: &Calibration) -> Vec<String> {
    let deg = |v: [f64; 3]| v.map(|x| format!("{:.4}", x.to_degrees())).join(" ");
    let mm = |v: [f64; 3]| v.map(|x| format!("{:.1}", x * 1e3)).join(" ");
    r.verdict
        .sensors
        .iter()
        .zip(&r.sensors)
        .filter_map(|(s, result)| {
            let e = s.evidence.as_ref()?;
            let (a, b) = (&e.after, &e.before);
            Some(format!(
                "{}: overlap {:.2}, share {:.2}, structure {:.2} of {} (before {:.2} / {:.2}); \
                 tolerance {:.1} mm, noise {:.1} mm; spread deg {} mm {}; one frame deg {} mm {}; \
                 frames deg {} mm {}",
                s.sensor,
                a.overlap(),
                a.share(),
                a.structure_share(),
                a.structure[1],
                b.share(),
                b.structure_share(),
                a.tolerance * 1e3,
                e.noise * 1e3,
                deg(e.observability.rotation),
                mm(e.observability.translation),
                deg(e.frame_observability.rotation),
                mm(e.frame_observability.translation),
                deg(result.spread.rpy),
                mm(result.spread.xyz),
            ))
        })
        .collect()
}
