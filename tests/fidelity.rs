//! Issue 22's fidelity rule: an approximation inside `gmm`'s EM is allowed when the calibration
//! the user receives moves by at most 0.002 deg / 0.2 mm and no verdict changes. Here the
//! convergence test of `gmm`'s JRMPC stage (`Settings::gmm_em_tolerance`) against running all
//! 100 iterations, on a handful of rigs; the full studies are in docs/benchmarks.md.

#![cfg(not(target_arch = "wasm32"))]

use gmmcalib::calib::{self, Settings};
use gmmcalib::jrmpc::Control;
use gmmcalib::twin::{Miscalibration, Model, Preset, Twin};

#[test]
fn gmm_stopping_jrmpc_early_gives_the_same_calibration() {
    let rigs = [
        (Preset::paper(), 1, Miscalibration::within(3f64.to_radians(), 0.1)),
        (Preset::paper_roof(), 2, Miscalibration::within(3f64.to_radians(), 0.1)),
        (Preset::paper(), 3, Miscalibration::within(8f64.to_radians(), 0.3)),
    ];
    for (preset, seed, draw) in rigs {
        let twin = Twin::new(&Model::RayCast(preset), 2, seed, &draw);
        let run = |tolerance: f64| {
            let settings = Settings { gmm_em_tolerance: tolerance, ..Settings::default() };
            calib::calibrate(&twin.rig(), &settings, |_| Control::Continue).expect("calibration")
        };
        let (exact, early) = (run(0.0), run(1e-4));
        assert_eq!(exact.iterations, 100);
        assert!(early.iterations < 100, "the convergence test stopped EM: {}", early.iterations);
        assert_eq!(exact.verdict.level, early.verdict.level, "seed {seed}");
        for (a, b) in exact.sensors.iter().zip(&early.sensors) {
            let d = a.extrinsic.inverse() * b.extrinsic;
            let (deg, mm) = (d.rotation.angle().to_degrees(), d.translation.vector.norm() * 1e3);
            eprintln!(
                "seed {seed} {}: {} iterations, moved {deg:.2e} deg / {mm:.2e} mm",
                a.name, early.iterations
            );
            assert!(deg <= 0.002 && mm <= 0.2, "seed {seed} {}: {deg} deg / {mm} mm", a.name);
        }
    }
}
