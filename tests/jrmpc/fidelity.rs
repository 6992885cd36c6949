//! The fidelity rule (docs/method.md): an approximation inside `gmm`'s EM is allowed when the
//! calibration the user receives moves by at most 0.002 deg / 0.2 mm and no verdict changes. Here
//! on a handful of rigs: the default (the fast E-step and the convergence test of `gmm`'s JRMPC
//! stage) against the exact path (the exact E-step for all 100 iterations); the convergence test
//! (`Settings::gmm_em`) against all 100 iterations; and multi-resolution EM (`Settings::gmm_em`,
//! off by default) against every point every iteration. The full studies are in
//! docs/lab/benchmarks-log.md.

#![cfg(not(target_arch = "wasm32"))]

use gmmcalib::calib::{self, Calibration, Rig, Settings};
use gmmcalib::io::recording::{Recording, RigRequest};
use gmmcalib::jrmpc::Control;
use gmmcalib::twin::{Miscalibration, Model, Preset, Twin};

/// The rigs: the paper's, its three-sensor roof variant, a start beyond the spec, and the
/// page's recording test rig (three instants of the paper twin from an MCAP, nominals from its
/// /tf_static, no ROI: as the page calibrates it).
fn rigs() -> Vec<(String, Rig)> {
    let twins = [
        ("paper", Preset::paper(), 1, Miscalibration::within(3f64.to_radians(), 0.1)),
        ("paper-roof", Preset::paper_roof(), 2, Miscalibration::within(3f64.to_radians(), 0.1)),
        ("paper", Preset::paper(), 3, Miscalibration::within(8f64.to_radians(), 0.3)),
    ];
    let mut rigs: Vec<(String, Rig)> = twins
        .into_iter()
        .map(|(name, preset, seed, draw)| {
            let twin = Twin::new(&Model::RayCast(preset), 2, seed, &draw);
            (format!("{name}, seed {seed}"), twin.rig())
        })
        .collect();
    rigs.push(("calib_zstd.mcap".into(), recording_rig("calib_zstd.mcap")));
    rigs
}

/// A recording fixture's two front LiDARs, as the CLI's `calibrate --bag` and the page build
/// the rig (`Recording::rig`): every instant they share, nominals from /tf_static, no ROI.
fn recording_rig(file: &str) -> Rig {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/recording/").to_owned() + file;
    let mut rec = Recording::open_path(std::path::Path::new(&path), &mut |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let topics = ["/front_left/points", "/front_right/points"].map(String::from);
    let request = RigRequest { topics: Some(topics.to_vec()), ..RigRequest::default() };
    let made = rec.rig(&request).unwrap_or_else(|e| panic!("{file}: {e}"));
    Rig { scans: made.scans, nominal: made.nominal, roi: None, reference: Some(made.reference) }
}

/// Calibrates every rig with `exact` and `approximate` settings and holds the rule; returns
/// the pairs of results.
fn holds_the_rule(
    what: &str,
    exact: &Settings,
    approximate: &Settings,
) -> Vec<(Calibration, Calibration)> {
    let mut pairs = Vec::new();
    for (rig_name, rig) in rigs() {
        let run = |settings: &Settings| {
            calib::calibrate(&rig, calib::Method::Gmm, settings, |_| Control::Continue)
                .expect("calibration")
        };
        let (a, b) = (run(exact), run(approximate));
        assert_eq!(
            a.verdict.level, b.verdict.level,
            "{what}, {rig_name}: {:#?} against {:#?}",
            a.verdict, b.verdict
        );
        for (x, y) in a.sensors.iter().zip(&b.sensors) {
            let d = x.extrinsic.inverse() * y.extrinsic;
            let (deg, mm) = (d.rotation.angle().to_degrees(), d.translation.vector.norm() * 1e3);
            eprintln!("{what}, {rig_name} {}: moved {deg:.2e} deg / {mm:.2e} mm", x.name);
            assert!(
                deg <= 0.002 && mm <= 0.2,
                "{what}, {rig_name} {}: {deg} deg / {mm} mm",
                x.name
            );
        }
        pairs.push((a, b));
    }
    pairs
}

#[test]
fn gmm_by_default_gives_the_exact_paths_calibration() {
    let mut exact = Settings::default();
    exact.gmm_em.tolerance = 0.0;
    exact.jrmpc.exact = true;
    for (exact, default) in holds_the_rule("default", &exact, &Settings::default()) {
        let terms = |c: &Calibration| c.history.iter().map(|h| h.terms).sum::<u64>();
        assert!(exact.exact && !default.exact);
        assert_eq!(exact.iterations, 100);
        let (fast, dense) = (terms(&default), terms(&exact));
        assert!(2 * fast < dense, "the default skips terms and iterations: {fast} of {dense}");
    }
}

#[test]
fn gmm_stopping_jrmpc_early_gives_the_same_calibration() {
    let mut exact = Settings::default();
    exact.gmm_em.tolerance = 0.0;
    let mut early = exact.clone();
    early.gmm_em.tolerance = 1e-4;
    for (exact, early) in holds_the_rule("early stop", &exact, &early) {
        assert_eq!(exact.iterations, 100);
        assert!(early.iterations < 100, "the convergence test stopped EM: {}", early.iterations);
    }
}

#[test]
fn gmm_on_merged_points_gives_the_same_calibration() {
    let mut every = Settings::default();
    every.gmm_em.multiresolution = false;
    let mut merged = Settings::default();
    merged.gmm_em.multiresolution = true;
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
