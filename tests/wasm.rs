//! The JS-facing API under Node (wasm-bindgen-test): what the worker calls, with JS values in
//! and out. Bad input must come back as a JS `Error` naming the problem, never as a panic.
#![cfg(target_arch = "wasm32")]

use gmmcalib::wasm::{calibrate, synthetic_rig};
use js_sys::{Array, Error, Function, Reflect};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::*;

/// Runs a JS function body with `rig` bound, for building inputs and reading results.
fn js(body: &str, rig: &JsValue) -> JsValue {
    Function::new_with_args("rig", body).call1(&JsValue::NULL, rig).expect("helper JS threw")
}

fn small_rig() -> JsValue {
    let options =
        js("return { sensors: 2, frames: 3, pointsPerView: 600, seed: 4 };", &JsValue::NULL);
    let rig = synthetic_rig(options).map_err(JsValue::from).expect("syntheticRig");
    js(
        "return { views: rig.views, nominal: rig.nominal, roi: rig.roi, truth: rig.truth, components: 150 };",
        &rig,
    )
}

fn error_message(result: Result<JsValue, JsError>) -> String {
    let value = JsValue::from(result.expect_err("expected an Error"));
    assert!(value.is_instance_of::<Error>(), "not an Error: {value:?}");
    value.unchecked_into::<Error>().message().into()
}

#[wasm_bindgen_test]
fn calibrate_recovers_the_synthetic_truth() {
    let rig = small_rig();
    let result = calibrate(rig.clone(), None).map_err(JsValue::from).expect("calibrate");
    // Compare the corrected extrinsic of sensor_2 with the truth, in JS, as the page does.
    let check = Function::new_with_args(
        "rig, result",
        "const s = result.sensors.find((s) => s.name === 'sensor_2');
         const t = rig.truth.sensor_2;
         const dx = Math.hypot(s.xyz[0] - t.xyz[0], s.xyz[1] - t.xyz[1], s.xyz[2] - t.xyz[2]);
         const dr = Math.max(...s.rpy.map((v, i) => Math.abs(v - t.rpy[i])));
         return [dx, dr, result.reference, result.target.means instanceof Float32Array,
                 result.target.means.length, result.sensors[0].correction.length];",
    );
    let out: Array = check.call2(&JsValue::NULL, &rig, &result).unwrap().into();
    let (dx, dr) = (out.get(0).as_f64().unwrap(), out.get(1).as_f64().unwrap());
    assert!(dx < 0.02 && dr < 0.5f64.to_radians(), "error {dx} m, {dr} rad");
    assert_eq!(out.get(2).as_string().unwrap(), "sensor_1");
    assert_eq!(out.get(3), JsValue::TRUE);
    assert_eq!(out.get(4).as_f64().unwrap(), 450.0);
    assert_eq!(out.get(5).as_f64().unwrap(), 16.0);
}

#[wasm_bindgen_test]
fn bad_input_throws_errors_that_name_the_problem() {
    let cases = [
        ("rig.views[0].sensor = 'lidar_x'; return rig;", "unknown sensor 'lidar_x'"),
        ("rig.roi = { min: [0, 0, 0], max: [-1, 1, 1] }; return rig;", "ROI is empty"),
        (
            "rig.roi = { min: [100, 100, 100], max: [101, 101, 101] }; return rig;",
            "no usable points in the ROI",
        ),
        (
            "rig.views = rig.views.filter((v) => v.sensor === 'sensor_1'); return rig;",
            "at least 2 sensors",
        ),
        ("rig.nominal.sensor_2.rpy[1] = NaN; return rig;", "not finite"),
        (
            "rig.views[1].points = rig.views[1].points.subarray(0, 301); return rig;",
            "not a multiple of 3",
        ),
        ("rig.views[1].points[5] = NaN; return rig;", "point 1 is not finite"),
        ("rig.views[0].points = [1, 2, 3]; return rig;", "invalid calibrate input"),
        ("rig.reference = 'nobody'; return rig;", "unknown reference sensor 'nobody'"),
        ("return 42;", "invalid calibrate input"),
    ];
    for (mutation, expected) in cases {
        let input = js(mutation, &small_rig());
        let message = error_message(calibrate(input, None));
        assert!(message.contains(expected), "{mutation}: got '{message}', want '{expected}'");
    }
}

#[wasm_bindgen_test]
fn progress_fires_every_iteration_and_can_cancel() {
    let rig = js("rig.iterations = 12; return rig;", &small_rig());
    let counter = js("const calls = []; return calls;", &JsValue::NULL);
    let on_progress = Function::new_with_args(
        "calls",
        "return (p) => { calls.push(p.iteration); return true; };",
    )
    .call1(&JsValue::NULL, &counter)
    .unwrap()
    .unchecked_into::<Function>();
    let result = calibrate(rig.clone(), Some(on_progress)).map_err(JsValue::from).unwrap();
    let iterations = Reflect::get(&result, &"iterations".into()).unwrap().as_f64().unwrap();
    let calls: Vec<f64> = Array::from(&counter).iter().map(|v| v.as_f64().unwrap()).collect();
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
