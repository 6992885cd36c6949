//! docs/accuracy.md's table for OpenCalib's road rig: each scene calibrated from its own guess
//! (`target: none`), then again with every scan coordinate moved by 1, 16 and 256 f32 ulps
//! (`eval::jitter`, three seeds each), with the plane adjustment on and off; prints the worst
//! sensor's move from the unjittered result. `cargo run --release --example opencalib_jitter`.

use gmmcalib::calib::{self, Rig, Settings};
use gmmcalib::eval;
use gmmcalib::jrmpc::Control;
use gmmcalib::targets::Target;

// The integration tests' reader of a fixture scene, not a copy of it.
#[path = "../tests/common/mod.rs"]
mod common;
use common::opencalib_scene as scene;

fn main() {
    for planes in [true, false] {
        let mut settings = Settings { target: Target::None, ..Default::default() };
        if !planes {
            settings.planes = None;
        }
        for name in ["0001", "0002"] {
            let run = |rig: &Rig| {
                calib::calibrate(rig, calib::Method::Gmm, &settings, |_| Control::Continue)
                    .expect("calibration")
            };
            let base = run(&scene(name));
            let mut cells = Vec::new();
            for ulps in [1, 16, 256] {
                let (mut deg, mut mm, mut verdicts) = (0f64, 0f64, Vec::new());
                for seed in 1..=3 {
                    let mut rig = scene(name);
                    eval::jitter(&mut rig, ulps, seed);
                    let result = run(&rig);
                    for (a, b) in base.sensors.iter().zip(&result.sensors).skip(1) {
                        let d = a.extrinsic.inverse() * b.extrinsic;
                        deg = deg.max(d.rotation.angle().to_degrees());
                        mm = mm.max(d.translation.vector.norm() * 1e3);
                    }
                    verdicts.push(result.verdict.level.name());
                }
                cells.push(format!("{deg:.5} deg / {mm:.3} mm ({})", verdicts.join(", ")));
            }
            let planes = if planes { "" } else { ", plane adjustment off" };
            println!("| {name}{planes} | {} |", cells.join(" | "));
        }
    }
}
