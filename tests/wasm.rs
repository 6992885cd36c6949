//! The JS-facing API under Node (wasm-bindgen-test): what the worker calls, with JS values in
//! and out. Bad input must come back as a JS `Error` naming the problem, never as a panic.
#![cfg(target_arch = "wasm32")]

use gmmcalib::calib;
use gmmcalib::jrmpc::Control;
use gmmcalib::se3::{Pose, pose_from_xyz_rpy, to_row_major, xyz_rpy};
use gmmcalib::twin::{Miscalibration, Model, Preset, Sampling, Twin};
use gmmcalib::wasm::{calibrate, exports_of, methods, parse_cloud, parse_config, simulate_rig};
use js_sys::{Array, Error, Function, Reflect};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::*;

/// Runs a JS function body with `rig` bound, for building inputs and reading results.
fn js(body: &str, rig: &JsValue) -> JsValue {
    Function::new_with_args("rig", body).call1(&JsValue::NULL, rig).expect("helper JS threw")
}

fn small_rig() -> JsValue {
    let options = js(
        "return { preset: 'sampled', sensors: 2, frames: 3, pointsPerView: 1000, seed: 4 };",
        &JsValue::NULL,
    );
    let rig = simulate_rig(options).map_err(JsValue::from).expect("simulateRig");
    js(
        "return { scans: rig.scans, nominal: rig.nominal, roi: rig.roi, truth: rig.truth, components: 200, initialSigma: 'prior' };",
        &rig,
    )
}

fn error_message(result: Result<JsValue, JsError>) -> String {
    let value = JsValue::from(result.expect_err("expected an Error"));
    assert!(value.is_instance_of::<Error>(), "not an Error: {value:?}");
    value.unchecked_into::<Error>().message().into()
}

/// The JS API returns exactly what the library computes for the same rig, in the documented
/// layout (row-major 4x4, rad, m), and that is close to the simulated truth.
#[wasm_bindgen_test]
fn calibrate_returns_the_library_result_for_the_synthetic_truth() {
    let rig = small_rig();
    let result = calibrate(rig.clone(), None).map_err(JsValue::from).expect("calibrate");

    let sampling = Sampling { points_per_view: 1000, ..Sampling::default() };
    let truth = Twin::new(&Model::Sampled(sampling), 3, 4, &Miscalibration::default());
    let lib_rig = truth.rig();
    let settings = calib::Settings {
        components: 200,
        initial_sigma: calib::InitialSigma::TargetSize,
        ..calib::Settings::default()
    };
    let expected =
        calib::calibrate(&lib_rig, calib::Method::Gmm, &settings, |_| Control::Continue).unwrap();

    let read = Function::new_with_args(
        "result",
        "const s = result.sensors[1];
         return [...s.extrinsic, ...s.xyz, ...s.rpy, result.reference, result.iterations,
                 result.reconstruction.means instanceof Float32Array, result.reconstruction.means.length];",
    );
    let out: Array = read.call1(&JsValue::NULL, &result).unwrap().into();
    let number = |i: u32| out.get(i).as_f64().unwrap();
    let extrinsic = to_row_major(&expected.sensors[1].extrinsic);
    let (xyz, rpy) = xyz_rpy(&expected.sensors[1].extrinsic);
    let want: Vec<f64> = extrinsic.iter().chain(&xyz).chain(&rpy).copied().collect();
    for (i, w) in want.iter().enumerate() {
        assert!((number(i as u32) - w).abs() < 1e-12, "element {i}: {} vs {w}", number(i as u32));
    }
    assert_eq!(out.get(22).as_string().unwrap(), "sensor_1");
    assert_eq!(number(23), expected.iterations as f64);
    assert_eq!(out.get(24), JsValue::TRUE);
    assert_eq!(number(25), 600.0);

    // A small rig (3 frames of 600 points, K = 150) under plain JRMPC: near the truth.
    let d = expected.sensors[1].extrinsic.inverse() * truth.truth[1].1;
    assert!(d.rotation.angle() < 3f64.to_radians() && d.translation.vector.norm() < 0.2, "{d}");
}

/// A result carries its exports, made by the library's writers for the input's vehicle frame;
/// `exportsOf` makes them again from the result's own fields for a renamed frame: the same
/// texts but for the frame's name, and no JSON (it names no frame).
#[wasm_bindgen_test]
fn a_result_carries_its_exports_and_a_renamed_frame_gets_them_again() {
    let input = js("return { ...rig, parent: 'base_link', method: 'jrmpc' };", &small_rig());
    let result = calibrate(input, None).map_err(JsValue::from).expect("calibrate");
    let exports = Reflect::get(&result, &"exports".into()).unwrap();
    let text = |v: &JsValue, key: &str| Reflect::get(v, &key.into()).unwrap().as_string();
    assert!(text(&exports, "urdf").unwrap().contains(r#"<parent link="base_link"/>"#));
    let json: serde_json::Value = serde_json::from_str(&text(&exports, "json").unwrap()).unwrap();
    assert_eq!(json["reference"], "sensor_1");
    assert!(json.get("exports").is_none(), "the JSON is the CLI's, without the exports");

    let again = exports_of(js(
        "return { parent: 'vehicle', sensors: rig.sensors, roi: rig.roi, reconstruction: rig.reconstruction };",
        &result,
    ))
    .map_err(JsValue::from)
    .expect("exportsOf");
    assert_eq!(text(&again, "json"), None);
    let keys = ["urdf", "ros1", "ros2", "tfYaml", "autoware", "kitti", "gmmcalibYaml", "targetPly"];
    for key in keys {
        let (before, after) = (text(&exports, key).unwrap(), text(&again, key).unwrap());
        assert_eq!(before.replace("base_link", "vehicle"), after, "{key}");
    }
    let bad = js(
        "return { parent: 'v', sensors: [{ name: 'a', extrinsic: [1, 2] }], roi: { min: [0, 0, 0], max: [1, 1, 1] } };",
        &JsValue::NULL,
    );
    assert_eq!(error_message(exports_of(bad)), "exportsOf: a: extrinsic is not 16 finite numbers");
}

#[wasm_bindgen_test]
fn bad_input_throws_errors_that_name_the_problem() {
    let cases = [
        ("rig.scans[0].sensor = 'lidar_x'; return rig;", "unknown sensor 'lidar_x'"),
        ("rig.roi = { min: [0, 0, 0], max: [-1, 1, 1] }; return rig;", "ROI is empty"),
        (
            "rig.roi = { min: [100, 100, 100], max: [101, 101, 101] }; return rig;",
            "no usable points in the ROI",
        ),
        (
            "rig.scans = rig.scans.filter((v) => v.sensor === 'sensor_1'); return rig;",
            "at least 2 sensors",
        ),
        ("rig.nominal.sensor_2.rpy[1] = NaN; return rig;", "not finite"),
        (
            "rig.scans[1].points = rig.scans[1].points.subarray(0, 301); return rig;",
            "not a multiple of 3",
        ),
        ("rig.scans[1].points[5] = NaN; return rig;", "point 1 is not finite"),
        ("rig.scans[0].points = [1, 2, 3]; return rig;", "invalid calibrate input"),
        ("rig.reference = 'nobody'; return rig;", "unknown reference sensor 'nobody'"),
        ("return 42;", "invalid calibrate input"),
        ("rig.initialSigma = -1; return rig;", "initialSigma: expected a positive number"),
    ];
    for (mutation, expected) in cases {
        let input = js(mutation, &small_rig());
        let message = error_message(calibrate(input, None));
        assert!(message.contains(expected), "{mutation}: got '{message}', want '{expected}'");
    }
}

#[wasm_bindgen_test]
fn progress_fires_every_iteration_and_can_cancel() {
    let rig = js("rig.iterations = 12; rig.method = 'jrmpc'; return rig;", &small_rig());
    // EM's iterations, and the stages as they begin: the run's own steps first and last.
    let seen = js("return { calls: [], stages: [] };", &JsValue::NULL);
    let on_progress = Function::new_with_args(
        "seen",
        "return (p) => { if (p.stage === 'jrmpc') seen.calls.push(p.iteration); \
         if (seen.stages.at(-1) !== p.stage) seen.stages.push(p.stage); return true; };",
    )
    .call1(&JsValue::NULL, &seen)
    .unwrap()
    .unchecked_into::<Function>();
    let result = calibrate(rig.clone(), Some(on_progress)).map_err(JsValue::from).unwrap();
    let iterations = Reflect::get(&result, &"iterations".into()).unwrap().as_f64().unwrap();
    let field = |name: &str| Array::from(&Reflect::get(&seen, &name.into()).unwrap());
    let stages: Vec<String> = field("stages").iter().map(|v| v.as_string().unwrap()).collect();
    assert_eq!(stages, ["views", "jrmpc", "finish"], "plain jrmpc on the small rig");
    let calls: Vec<f64> = field("calls").iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(calls.len() as f64, iterations);
    assert_eq!(calls, (1..=calls.len()).map(|i| i as f64).collect::<Vec<_>>());

    let stop_at_three =
        js("return (p) => p.iteration < 3;", &JsValue::NULL).unchecked_into::<Function>();
    let result = calibrate(rig.clone(), Some(stop_at_three)).map_err(JsValue::from).unwrap();
    assert_eq!(Reflect::get(&result, &"iterations".into()).unwrap().as_f64(), Some(3.0));
    assert_eq!(Reflect::get(&result, &"cancelled".into()).unwrap(), JsValue::TRUE);

    let throws = js("return () => { throw new Error('boom'); };", &JsValue::NULL)
        .unchecked_into::<Function>();
    let message = error_message(calibrate(rig, Some(throws)));
    assert!(message.contains("onProgress threw: boom"), "{message}");
}

/// The ICP baselines go through the same entry point.
#[wasm_bindgen_test]
fn calibrate_with_gicp() {
    let rig = js("rig.method = 'gicp'; return rig;", &small_rig());
    let result = calibrate(rig.clone(), None).map_err(JsValue::from).expect("calibrate gicp");
    let read = Function::new_with_args(
        "rig, result",
        "const s = result.sensors[1]; const t = rig.truth.sensor_2;
         return [result.method, Math.hypot(s.xyz[0] - t.xyz[0], s.xyz[1] - t.xyz[1], s.xyz[2] - t.xyz[2]),
                 result.reconstruction.means.length, s.spread.frames];",
    );
    let out: Array = read.call2(&JsValue::NULL, &rig, &result).unwrap().into();
    assert_eq!(out.get(0).as_string().unwrap(), "gicp");
    assert!(out.get(1).as_f64().unwrap() < 0.05, "translation error {:?}", out.get(1));
    assert_eq!(out.get(2).as_f64(), Some(0.0), "ICP reconstructs no target");
    assert_eq!(out.get(3).as_f64(), Some(3.0));
    let bad = js("rig.method = 'ndt'; return rig;", &small_rig());
    assert!(error_message(calibrate(bad, None)).contains("unknown method 'ndt'"));
}

#[wasm_bindgen_test]
fn parse_cloud_reads_files_and_names_bad_ones() {
    let cloud = gmmcalib::Cloud {
        points: vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [0.0, 0.0, 0.0]],
        intensity: Some(vec![7.0, 8.0, 9.0]),
    };
    let bytes = gmmcalib::export::write_pcd_binary(&cloud);
    let parsed = parse_cloud(&bytes, "scan.pcd").map_err(JsValue::from).unwrap();
    let read = Function::new_with_args(
        "p",
        "return [p.points instanceof Float32Array, Array.from(p.points).join(','), p.count, p.dropped,
                 p.format, Array.from(p.intensity).join(',')];",
    );
    let out: Array = read.call1(&JsValue::NULL, &parsed).unwrap().into();
    assert_eq!(out.get(0), JsValue::TRUE);
    assert_eq!(out.get(1).as_string().unwrap(), "1,2,3,4,5,6");
    assert_eq!(out.get(2).as_f64(), Some(2.0));
    assert_eq!(out.get(3).as_f64(), Some(1.0), "the zero return is dropped");
    assert_eq!(out.get(4).as_string().unwrap(), "PCD binary");
    assert_eq!(out.get(5).as_string().unwrap(), "7,8");

    let message = error_message(parse_cloud(&bytes[..bytes.len() - 5], "cut.pcd"));
    assert!(message.contains("cut.pcd"), "{message}");
    let message =
        error_message(parse_cloud(b"ply\nformat ascii 1.0\nelement vertex 10\n", "bad.ply"));
    assert!(message.contains("bad.ply"), "{message}");
    let message = error_message(parse_cloud(b"1234", "scan.xyz"));
    assert!(message.contains("scan.xyz"), "{message}");
}

/// The twin for the demo: scans in the sensor frame that the true mount puts where the preset's
/// scene is, the reference sensor's nominal right and every other one wrong within the bounds;
/// seeded; bad options named.
#[wasm_bindgen_test]
fn simulate_rig_returns_a_miscalibrated_twin_with_its_truth() {
    let options = js(
        "return { preset: 'paper', frames: 1, seed: 7, maxAngleDeg: 2, maxTranslation: 0.05 };",
        &JsValue::NULL,
    );
    let rig = simulate_rig(options.clone()).map_err(JsValue::from).expect("simulateRig");
    let read = Function::new_with_args(
        "rig",
        "const v = rig.scans.find((v) => v.sensor === 'front_right');
         const n = rig.nominal, t = rig.truth;
         return [rig.scans.length, rig.reference, v.points instanceof Float32Array, v.points.length % 3,
                 v.points.length / 3 + v.dropped, JSON.stringify(n.front_left) === JSON.stringify(t.front_left),
                 ...n.front_right.xyz, ...n.front_right.rpy,
                 Array.from(v.points.subarray(0, 30)).join(','), rig.roi.min.join(',') + ';' + rig.roi.max.join(','),
                 ...t.front_right.xyz, ...t.front_right.rpy];",
    );
    let out: Array = read.call1(&JsValue::NULL, &rig).unwrap().into();
    let preset = Preset::paper();
    let lidar = &preset.sensors[1].lidar;
    assert_eq!(out.get(0).as_f64(), Some(2.0), "one frame, two sensors");
    assert_eq!(out.get(1).as_string().unwrap(), "front_left");
    assert_eq!(out.get(2), JsValue::TRUE);
    assert_eq!(out.get(3).as_f64(), Some(0.0));
    assert_eq!(
        out.get(4).as_f64(),
        Some((lidar.width() * lidar.height()) as f64),
        "points + misses"
    );
    assert_eq!(out.get(5), JsValue::TRUE, "the reference keeps its true mount");
    // The nominal is the truth turned about the sensor and shifted, each within its bound per
    // axis, and not the truth.
    let nominal = pose_from_xyz_rpy(
        [6, 7, 8].map(|i| out.get(i).as_f64().unwrap()),
        [9, 10, 11].map(|i| out.get(i).as_f64().unwrap()),
    );
    let mount = preset.sensors[1].mount;
    let dxyz: [f64; 3] = (nominal.translation.vector - mount.translation.vector).into();
    let (_, drpy) = xyz_rpy(&Pose::from_parts(
        nalgebra::Translation3::identity(),
        nominal.rotation * mount.rotation.inverse(),
    ));
    assert!(dxyz.iter().all(|v| v.abs() <= 0.05 + 1e-9), "translation off by {dxyz:?}");
    assert!(drpy.iter().all(|v| v.abs() <= 2f64.to_radians() + 1e-9), "rotation off by {drpy:?}");
    assert!(drpy.iter().any(|v| v.abs() > 1e-3) && dxyz.iter().any(|v| v.abs() > 1e-3));
    let roi = &preset.roi;
    assert_eq!(
        out.get(13).as_string().unwrap(),
        format!(
            "{};{}",
            roi.min.map(|v| v.to_string()).join(","),
            roi.max.map(|v| v.to_string()).join(",")
        )
    );
    let (xyz, rpy) = xyz_rpy(&preset.sensors[1].mount);
    for k in 0..3 {
        assert!((out.get(14 + k).as_f64().unwrap() - xyz[k as usize]).abs() < 1e-12);
        assert!((out.get(17 + k).as_f64().unwrap() - rpy[k as usize]).abs() < 1e-12);
    }
    // Seeded: the same options give the same scans.
    let again = simulate_rig(options).map_err(JsValue::from).unwrap();
    let again: Array = read.call1(&JsValue::NULL, &again).unwrap().into();
    assert_eq!(out.get(12), again.get(12));

    for (options, expected) in [
        ("return { preset: 'vlp16' };", "unknown preset 'vlp16'"),
        ("return { frames: 0 };", "frames must be 1 to"),
        ("return { maxAngleDeg: -1 };", "maxAngleDeg must be"),
        ("return { frames: 'two' };", "invalid simulateRig options"),
    ] {
        let message = error_message(simulate_rig(js(options, &JsValue::NULL)));
        assert!(message.contains(expected), "{options}: got '{message}', want '{expected}'");
    }
}

/// The page asks the library what it offers and reads configs with the library's one reader.
#[wasm_bindgen_test]
fn methods_and_the_config_reader_come_from_the_library() {
    let list = methods().map_err(JsValue::from).unwrap();
    let names = js("return rig.map((m) => `${m.name}:${m.jrmpc}:${m.pairs}`).join(' ');", &list);
    assert_eq!(
        names.as_string().unwrap(),
        "gmm:true:true jrmpc:true:false cad:false:false p2p:false:true p2l:false:true gicp:false:true"
    );
    let config = parse_config(
        "transform_a: [0.1, 0.2, 0.3, 1, 2, 3]\nmin_bound: [-1, -2, -3]\nmax_bound: [1, 2, 3]\n\
         initial_sigma: prior\ntarget_edge: 0.4\nmethod: all\n",
        "config.yaml",
    )
    .map_err(JsValue::from)
    .unwrap();
    let read = js(
        "return [rig.nominal.a.xyz.join(','), rig.nominal.a.rpy.join(','), rig.roi.max.join(','),
                 rig.initialSigma, rig.target, rig.method].join(';');",
        &config,
    );
    assert_eq!(read.as_string().unwrap(), "1,2,3;0.1,0.2,0.3;1,2,3;prior;cube:0.4;all");
    let message = error_message(parse_config("min_bound: [1, 2, 3]\n", "c.yaml"));
    assert!(message.contains("c.yaml: missing key max_bound"), "{message}");
}

/// `method: 'all'` runs every method through the same entry point: one result per method, in
/// order, a failed method as `{method, error}`.
#[wasm_bindgen_test]
fn calibrate_compares_every_method() {
    let rig = js("rig.method = 'all'; rig.iterations = 10; return rig;", &small_rig());
    let result = calibrate(rig, None).map_err(JsValue::from).expect("compare all");
    let names =
        js("return rig.map((r) => r.error ? `${r.method}!` : r.method).join(' ');", &result);
    assert_eq!(names.as_string().unwrap(), "gmm jrmpc cad p2p p2l gicp");
}
