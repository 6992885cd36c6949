//! Issue 22's fidelity rule: an approximation inside `gmm`'s EM is allowed when the calibration
//! the user receives moves by at most 0.002 deg / 0.2 mm and no verdict changes. Here each
//! approximation against the exact path on a handful of rigs: the convergence test of `gmm`'s
//! JRMPC stage (`Settings::gmm_em_tolerance`) against all 100 iterations, and multi-resolution
//! EM (`Settings::gmm_multiresolution`) against every point every iteration. The full studies
//! are in docs/benchmarks.md.

#![cfg(not(target_arch = "wasm32"))]

use gmmcalib::calib::{self, Calibration, Settings};
use gmmcalib::jrmpc::Control;
use gmmcalib::twin::{Miscalibration, Model, Preset, Twin};

/// The rigs: the paper's, its three-sensor roof variant, and a start beyond the spec.
fn rigs() -> [(Preset, u64, Miscalibration); 3] {
    [
        (Preset::paper(), 1, Miscalibration::within(3f64.to_radians(), 0.1)),
        (Preset::paper_roof(), 2, Miscalibration::within(3f64.to_radians(), 0.1)),
        (Preset::paper(), 3, Miscalibration::within(8f64.to_radians(), 0.3)),
    ]
}

/// Calibrates every rig with `exact` and `approximate` settings and holds the rule; returns
/// the pairs of results.
fn holds_the_rule(
    what: &str,
    exact: &Settings,
    approximate: &Settings,
) -> Vec<(Calibration, Calibration)> {
    let mut pairs = Vec::new();
    for (preset, seed, draw) in rigs() {
        let twin = Twin::new(&Model::RayCast(preset), 2, seed, &draw);
        let run = |settings: &Settings| {
            calib::calibrate(&twin.rig(), settings, |_| Control::Continue).expect("calibration")
        };
        let (a, b) = (run(exact), run(approximate));
        assert_eq!(a.verdict.level, b.verdict.level, "{what}, seed {seed}");
        for (x, y) in a.sensors.iter().zip(&b.sensors) {
            let d = x.extrinsic.inverse() * y.extrinsic;
            let (deg, mm) = (d.rotation.angle().to_degrees(), d.translation.vector.norm() * 1e3);
            eprintln!("{what}, seed {seed} {}: moved {deg:.2e} deg / {mm:.2e} mm", x.name);
            assert!(
                deg <= 0.002 && mm <= 0.2,
                "{what}, seed {seed} {}: {deg} deg / {mm} mm",
                x.name
            );
        }
        pairs.push((a, b));
    }
    pairs
}

#[test]
fn gmm_stopping_jrmpc_early_gives_the_same_calibration() {
    let exact = Settings { gmm_em_tolerance: 0.0, ..Settings::default() };
    let early = Settings { gmm_em_tolerance: 1e-4, ..exact.clone() };
    for (exact, early) in holds_the_rule("early stop", &exact, &early) {
        assert_eq!(exact.iterations, 100);
        assert!(early.iterations < 100, "the convergence test stopped EM: {}", early.iterations);
    }
}

#[test]
fn gmm_on_merged_points_gives_the_same_calibration() {
    let every = Settings { gmm_multiresolution: false, ..Settings::default() };
    let merged = Settings { gmm_multiresolution: true, ..Settings::default() };
    for (every, merged) in holds_the_rule("multi-resolution", &every, &merged) {
        let terms = |c: &Calibration| c.history.iter().map(|h| h.terms).sum::<u64>();
        assert!(
            terms(&merged) < terms(&every) * 9 / 10,
            "merging saves terms: {} of {}",
            terms(&merged),
            terms(&every)
        );
    }
}
