//! `CalibrationSession`, `JrmpcShard`, `alignGlobal` and `alignPairs`: the library's [`Run`]
//! driven step by step from JS, so a pool of workers can share the global stage's sensors,
//! JRMPC's E-step and the frame pairs' ICP (docs/api.md). The session forwards to the run,
//! which owns the control flow (stages, methods, failures); the flat formats are
//! `jrmpc::wire`'s and `se3::to_quaternion_xyz`'s.
//! The M-step takes every view's statistics in view order, and the global alignments and the
//! frame pairs' outcomes are kept by sensor and pair, so the result is `calibrate`'s, bit for
//! bit, however the work is split.

use std::borrow::Cow;

use js_sys::{Array, Float32Array, Float64Array, Function, Uint32Array};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use super::calibrate::{ProgressShape, ProgressSink, outcomes, rig_and_settings};
use super::to_js;
use crate::calib::{
    self, CalibError, GlobalAlignment, GlobalJob, GlobalReference, GlobalSettings, PairIcp, Run,
    Stage,
};
use crate::cloud::Cloud;
use crate::jrmpc::{Shard, ViewStats, wire};
use crate::plane::Plane;
use crate::se3::{from_quaternion_xyz, to_quaternion_xyz};

#[wasm_bindgen]
pub struct CalibrationSession {
    /// `None` once the result was taken.
    run: Option<Run<'static>>,
    /// What JS sees of the run's progress.
    shape: ProgressShape,
    compared: bool,
    /// The vehicle frame's name, for the exports.
    parent: String,
}

#[wasm_bindgen]
impl CalibrationSession {
    /// Checks the rig `input` (as `calibrate` takes it, `method: 'all'` included) and plans
    /// its first method.
    #[wasm_bindgen(constructor)]
    pub fn new(input: JsValue) -> Result<CalibrationSession, JsError> {
        let (rig, settings, methods, parent) = rig_and_settings(input)?;
        let sensors = rig.sensors();
        let run = Run::new(Cow::Owned(rig), &settings, &methods);
        let shape = ProgressShape::new(sensors, &run);
        Ok(Self { run: Some(run), shape, compared: methods.len() > 1, parent })
    }

    /// `"global"`, `"views"`, `"jrmpc"`, `"framePairs"`, `"cad"`, `"finish"` (the names progress
    /// reports them by) or `"done"`: the stage the current method needs next. The run takes
    /// `"views"` and `"finish"` itself at `advance`.
    pub fn stage(&self) -> String {
        self.run.as_ref().and_then(Run::stage).map_or("done", |s| s.name()).into()
    }

    /// The current method's name (`undefined` when done).
    pub fn method(&self) -> Option<String> {
        let (_, method) = self.run.as_ref()?.method()?;
        Some(method.name().into())
    }

    /// The sensors (indices in result order) still to align in `"global"`. Align them here
    /// (`alignGlobally`) or elsewhere (`globalJob`, `alignGlobal` in another worker, then
    /// `recordGlobal`), in any order.
    #[wasm_bindgen(js_name = globalJobs)]
    pub fn global_jobs(&mut self) -> Result<Uint32Array, JsError> {
        let stage = self.run_mut()?.global_stage().ok_or_else(no_global)?;
        let pending: Vec<u32> = stage.pending().iter().map(|&s| s as u32).collect();
        Ok(Uint32Array::from(pending.as_slice()))
    }

    /// The current stage's progress as it stands (`calibrate`'s shape): what a driver reports
    /// as a stage begins, the run's own `"views"` and `"finish"` among them.
    pub fn progress(&self) -> Result<JsValue, JsError> {
        let run = self.run.as_ref().ok_or_else(finished)?;
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        run.progress(|p| self.shape.value(method, p)).ok_or_else(finished)?
    }

    /// The global stage's progress (`calibrate`'s shape): the sensors aligned so far.
    #[wasm_bindgen(js_name = globalProgress)]
    pub fn global_progress(&self) -> Result<JsValue, JsError> {
        let run = self.run.as_ref().ok_or_else(finished)?;
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        run.global_progress(|p| self.shape.value(method, p)).ok_or_else(no_global)?
    }

    /// Aligns the pending sensors `sensors` here; returns the progress (`calibrate`'s shape).
    #[wasm_bindgen(js_name = alignGlobally)]
    pub fn align_globally(&mut self, sensors: &[u32]) -> Result<JsValue, JsError> {
        let stage = self.run_mut()?.global_stage().ok_or_else(no_global)?;
        let which: Vec<usize> = sensors.iter().map(|&s| s as usize).collect();
        let pending = stage.pending();
        which.iter().try_for_each(|s| check_pending(&pending, *s))?;
        stage.align(&which, 1);
        self.global_progress()
    }

    /// Pending sensor `sensor`'s alignment as `alignGlobal` takes it.
    #[wasm_bindgen(js_name = globalJob)]
    pub fn global_job(&mut self, sensor: usize) -> Result<JsValue, JsError> {
        let stage = self.run_mut()?.global_stage().ok_or_else(no_global)?;
        let job = stage.job(sensor).ok_or_else(|| not_pending(sensor))?;
        let reference: Vec<f64> =
            job.reference.points.iter().flat_map(|p| p.iter().copied()).collect();
        let wire = GlobalJobWire {
            scan: Float32Array::from(job.scan.as_flattened()),
            nominal: to_quaternion_xyz(&job.nominal),
            reference: Float64Array::from(reference.as_slice()),
            ground: job.reference.ground,
            settings: job.settings.clone(),
            seed: job.seed,
        };
        wire.serialize(&bigints())
            .map_err(|e| JsError::new(&format!("internal: cannot convert a global job: {e}")))
    }

    /// Records pending sensor `sensor`'s alignment, found by `alignGlobal` elsewhere; returns
    /// the progress (`calibrate`'s shape).
    #[wasm_bindgen(js_name = recordGlobal)]
    pub fn record_global(&mut self, sensor: usize, alignment: JsValue) -> Result<JsValue, JsError> {
        let alignment: GlobalAlignment = serde_wasm_bindgen::from_value(alignment)
            .map_err(|e| JsError::new(&format!("recordGlobal: not a global alignment: {e}")))?;
        from_quaternion_xyz(&to_quaternion_xyz(&alignment.applied)).ok_or_else(bad_pose)?;
        let stage = self.run_mut()?.global_stage().ok_or_else(no_global)?;
        check_pending(&stage.pending(), sensor)?;
        stage.record(sensor, alignment);
        self.global_progress()
    }

    /// Points per view of EM's views, for splitting them among shards (empty outside EM).
    #[wasm_bindgen(js_name = viewSizes)]
    pub fn view_sizes(&self) -> Uint32Array {
        let points = self.run.as_ref().and_then(Run::em_points);
        let sizes: Vec<u32> =
            points.map_or_else(Vec::new, |p| p.iter().map(|v| v.len() as u32).collect());
        Uint32Array::from(sizes.as_slice())
    }

    /// The centred points of EM's views `first..first + count`, flat, for `new JrmpcShard`.
    #[wasm_bindgen(js_name = shardPoints)]
    pub fn shard_points(&self, first: usize, count: usize) -> Result<Float64Array, JsError> {
        let points = self.run.as_ref().and_then(Run::em_points).ok_or_else(no_em)?;
        let (flat, _) = wire::shard_points(points, first, count).ok_or_else(|| {
            JsError::new(&format!("views {first}..{first}+{count} of {}", points.len()))
        })?;
        Ok(Float64Array::from(flat.as_slice()))
    }

    /// EM has converged, been cancelled or run out of iterations (or is not running).
    pub fn finished(&mut self) -> bool {
        self.run.as_mut().and_then(Run::em).is_none_or(|em| em.finished())
    }

    /// The next E-step's input (`jrmpc::wire`).
    #[wasm_bindgen(js_name = eStepInput)]
    pub fn e_step_input(&mut self) -> Result<Float64Array, JsError> {
        let em = self.run_mut()?.em().ok_or_else(no_em)?;
        Ok(Float64Array::from(wire::e_step_input(em).as_slice()))
    }

    /// Ends an iteration with the shards' E-step outputs, in view order; returns the progress
    /// (`calibrate`'s shape).
    #[wasm_bindgen(js_name = mStep)]
    pub fn m_step(&mut self, outputs: Array) -> Result<JsValue, JsError> {
        let flats = outputs
            .iter()
            .map(|o| o.dyn_into::<Float64Array>().map(|a| a.to_vec()))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|_| JsError::new("mStep takes an array of Float64Array"))?;
        let run = self.run.as_mut().ok_or_else(finished)?;
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        let em = run.em().ok_or_else(no_em)?;
        let (k, views) = (em.mixture().len(), em.transforms().len());
        let (terms, stats) = wire::read_e_step_outputs(flats.iter().map(Vec::as_slice), k, views)
            .map_err(|e| JsError::new(&e.to_string()))?;
        em.m_step(&stats, terms);
        let shape = &self.shape;
        run.em_progress(|p| shape.value(method, p)).ok_or_else(no_em)?
    }

    /// Stops the current stage after its current step; no later method starts.
    pub fn cancel(&mut self) {
        if let Some(run) = &mut self.run {
            run.cancel();
        }
    }

    /// The frame pairs to register, in `"framePairs"`: `{icp, pairs, starts}`, where `pairs`
    /// holds `referenceView, view` per pair (the views of `viewPoints`) and `starts` a pose
    /// per pair (7 numbers). Register them here (`registerPairs`) or elsewhere (`alignPairs`
    /// in another worker, then `recordPair`), in any order.
    #[wasm_bindgen(js_name = framePairs)]
    pub fn frame_pairs(&mut self) -> Result<JsValue, JsError> {
        let pairs = self.run_mut()?.frame_pairs().ok_or_else(no_pairs)?;
        let value = js_sys::Object::new();
        let views: Vec<u32> =
            pairs.pairs().iter().flat_map(|p| [p.reference_view as u32, p.view as u32]).collect();
        let starts: Vec<f64> =
            pairs.pairs().iter().flat_map(|p| to_quaternion_xyz(&p.start)).collect();
        let fields = [
            ("icp", to_js(pairs.icp())?),
            ("pairs", Uint32Array::from(views.as_slice()).into()),
            ("starts", Float64Array::from(starts.as_slice()).into()),
        ];
        for (key, field) in fields {
            js_sys::Reflect::set(&value, &key.into(), &field)
                .map_err(|_| JsError::new("internal: cannot build the frame pairs"))?;
        }
        Ok(value.into())
    }

    /// View `view`'s cropped, pre-aligned points (flat `x, y, z`), as `alignPairs` takes them.
    #[wasm_bindgen(js_name = viewPoints)]
    pub fn view_points(&self, view: usize) -> Result<Float32Array, JsError> {
        let views = self.run.as_ref().and_then(Run::views).ok_or_else(finished)?;
        let clouds = views.clouds();
        let cloud = clouds
            .get(view)
            .ok_or_else(|| JsError::new(&format!("no view {view} of {}", clouds.len())))?;
        Ok(Float32Array::from(cloud.as_flattened()))
    }

    /// Registers the frame pairs `pairs` (indices into `framePairs().pairs`) here;
    /// `onProgress` sees each, as with `calibrate`.
    #[wasm_bindgen(js_name = registerPairs)]
    pub fn register_pairs(
        &mut self,
        pairs: &[u32],
        on_progress: Option<Function>,
    ) -> Result<(), JsError> {
        let run = self.run.as_mut().ok_or_else(finished)?;
        let count = run.frame_pairs().ok_or_else(no_pairs)?.pairs().len();
        pairs.iter().try_for_each(|&p| check_pair(count, p as usize))?;
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        let mut sink = ProgressSink::new(on_progress, self.shape.clone());
        run.register_pairs(pairs.iter().map(|&p| p as usize), 1, &mut |p| sink.send(method, p));
        sink.error()
    }

    /// Runs `cad`'s registration onto the target's model here (stage `"cad"`); `onProgress`
    /// sees each iteration, as with `calibrate`, and may stop it by returning `false`.
    #[wasm_bindgen(js_name = registerCad)]
    pub fn register_cad(&mut self, on_progress: Option<Function>) -> Result<(), JsError> {
        let run = self.run.as_mut().ok_or_else(finished)?;
        if run.stage() != Some(Stage::Cad) {
            return Err(JsError::new("the current method is not in its cad stage"));
        }
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        let mut sink = ProgressSink::new(on_progress, self.shape.clone());
        run.register_cad(&mut |p| sink.send(method, p));
        sink.error()
    }

    /// Records frame pair `pair`'s outcome, registered elsewhere: a pose (7 numbers) or the
    /// error's message. Returns the progress (`calibrate`'s shape).
    #[wasm_bindgen(js_name = recordPair)]
    pub fn record_pair(&mut self, pair: usize, outcome: JsValue) -> Result<JsValue, JsError> {
        let outcome = match (outcome.as_string(), outcome.dyn_ref::<Float64Array>()) {
            (Some(message), _) => Err(message),
            (None, Some(pose)) => Ok(from_quaternion_xyz(&pose.to_vec()).ok_or_else(bad_pose)?),
            (None, None) => return Err(JsError::new("recordPair: a pose or a message")),
        };
        let run = self.run.as_mut().ok_or_else(finished)?;
        let count = run.frame_pairs().ok_or_else(no_pairs)?.pairs().len();
        check_pair(count, pair)?;
        let method = run.method().map(|(_, m)| m).ok_or_else(finished)?;
        let shape = &self.shape;
        run.record_pair(pair, outcome, |p| shape.value(method, p)).ok_or_else(no_pairs)?
    }

    /// Ends the current stage (EM even if unfinished; the frame pairs as far as registered)
    /// and moves on: to the frame pairs, to the method's result, to the next method.
    pub fn advance(&mut self) -> Result<(), JsError> {
        self.run_mut()?.advance();
        Ok(())
    }

    /// Ends the current method with `message` as its error (its work failed in a worker) and
    /// moves on to the next.
    pub fn fail(&mut self, message: String) -> Result<(), JsError> {
        self.run_mut()?.fail(CalibError::StageFailed(message));
        Ok(())
    }

    /// Once `"done"`: `calibrate`'s result (one report, or with `method: 'all'` an array of
    /// every method's report or `{method, error}`).
    pub fn result(&mut self) -> Result<JsValue, JsError> {
        if self.run.as_ref().is_some_and(|r| r.stage().is_some()) {
            return Err(JsError::new("the session has not finished"));
        }
        let run = self.run.take().ok_or_else(finished)?;
        outcomes(run.into_outcomes(), self.compared, &self.parent)
    }
}

impl CalibrationSession {
    fn run_mut(&mut self) -> Result<&mut Run<'static>, JsError> {
        self.run.as_mut().ok_or_else(finished)
    }
}

/// An error unless `sensor` is waiting for its global alignment.
fn check_pending(pending: &[usize], sensor: usize) -> Result<(), JsError> {
    if pending.contains(&sensor) { Ok(()) } else { Err(not_pending(sensor)) }
}

fn not_pending(sensor: usize) -> JsError {
    JsError::new(&format!("sensor {sensor} is not waiting for its global alignment"))
}

/// An error unless `pair` is one of `count` frame pairs.
fn check_pair(count: usize, pair: usize) -> Result<(), JsError> {
    if pair < count {
        Ok(())
    } else {
        Err(JsError::new(&format!("no frame pair {pair} of {count}")))
    }
}

/// One sensor's global alignment as it crosses between workers: the flat formats of
/// `viewPoints` and `recordPair`; the seed a BigInt.
#[derive(Serialize, Deserialize)]
struct GlobalJobWire {
    #[serde(with = "serde_wasm_bindgen::preserve")]
    scan: Float32Array,
    nominal: [f64; 7],
    /// The reference's thinned points in the vehicle frame, flat.
    #[serde(with = "serde_wasm_bindgen::preserve")]
    reference: Float64Array,
    ground: Plane,
    settings: GlobalSettings,
    seed: u64,
}

/// A serializer that writes 64-bit integers (seeds) as BigInts, so none is rounded.
fn bigints() -> serde_wasm_bindgen::Serializer {
    serde_wasm_bindgen::Serializer::new().serialize_large_number_types_as_bigints(true)
}

/// Runs one sensor's global alignment, `job` as a session's `globalJob` gave it: the
/// alignment, for that session's `recordGlobal`.
#[wasm_bindgen(js_name = alignGlobal)]
pub fn align_global(job: JsValue) -> Result<JsValue, JsError> {
    let wire: GlobalJobWire = serde_wasm_bindgen::from_value(job)
        .map_err(|e| JsError::new(&format!("alignGlobal: invalid job: {e}")))?;
    wire.settings.check().map_err(|e| JsError::new(&format!("alignGlobal: {e}")))?;
    let scan = cloud_from(&wire.scan.to_vec(), "alignGlobal", "scan")?;
    let flat = wire.reference.to_vec();
    if flat.len() % 3 != 0 {
        let what = format!("alignGlobal: the reference's {} numbers are not points", flat.len());
        return Err(JsError::new(&what));
    }
    let points = flat.chunks_exact(3).map(|p| Vector3::new(p[0], p[1], p[2])).collect();
    let reference = GlobalReference { ground: wire.ground, points };
    let nominal = from_quaternion_xyz(&wire.nominal).ok_or_else(bad_pose)?;
    let job = GlobalJob {
        scan: &scan.points,
        nominal,
        reference: &reference,
        settings: &wire.settings,
        seed: wire.seed,
    };
    wire_alignment(&job.run())
}

/// A global alignment for `recordGlobal`: every number as it is, so the session records
/// what an alignment here would have found.
fn wire_alignment(alignment: &GlobalAlignment) -> Result<JsValue, JsError> {
    alignment
        .serialize(&bigints())
        .map_err(|e| JsError::new(&format!("internal: cannot convert a global alignment: {e}")))
}

/// Registers each of `sources` (flat points, like `viewPoints`) onto `target` from its pose in
/// `starts` (7 numbers each), by `icp` (`framePairs().icp`): per source, its pose or the
/// error's message. The target is built once, so pass every pair of one reference view
/// together.
#[wasm_bindgen(js_name = alignPairs)]
pub fn align_pairs(
    icp: JsValue,
    target: &[f32],
    sources: Array,
    starts: &[f64],
) -> Result<Array, JsError> {
    let icp: PairIcp = serde_wasm_bindgen::from_value(icp)
        .map_err(|e| JsError::new(&format!("alignPairs: invalid icp: {e}")))?;
    if starts.len() != 7 * sources.length() as usize {
        return Err(JsError::new(&format!(
            "alignPairs: {} numbers of starts for {} sources",
            starts.len(),
            sources.length()
        )));
    }
    let target = cloud_from(target, "alignPairs", "target")?;
    // A pool worker's target serves its pairs only: the verdict is the calibration worker's.
    let built = calib::fixed_cloud(&target.points, &icp, false);
    let outcomes = Array::new();
    for (i, (source, start)) in sources.iter().zip(starts.chunks_exact(7)).enumerate() {
        let source = cloud_of(&source, &format!("source {i}"))?;
        let start = from_quaternion_xyz(start).ok_or_else(bad_pose)?;
        let outcome: JsValue = match &built {
            Ok(target) => match calib::align(target, &source.points, &start, &icp) {
                Ok(pose) => Float64Array::from(to_quaternion_xyz(&pose).as_slice()).into(),
                Err(e) => e.to_string().into(),
            },
            Err(e) => e.to_string().into(),
        };
        outcomes.push(&outcome);
    }
    Ok(outcomes)
}

fn cloud_of(value: &JsValue, what: &str) -> Result<Cloud, JsError> {
    let flat = value
        .dyn_ref::<Float32Array>()
        .ok_or_else(|| JsError::new(&format!("alignPairs: the {what} is not a Float32Array")))?
        .to_vec();
    cloud_from(&flat, "alignPairs", what)
}

/// `flat` (`x, y, z, ...`) as a cloud, or an error naming the function `call` and `what`.
fn cloud_from(flat: &[f32], call: &str, what: &str) -> Result<Cloud, JsError> {
    Cloud::from_flat(flat).ok_or_else(|| {
        JsError::new(&format!("{call}: the {what}'s {} numbers are not points", flat.len()))
    })
}

/// Some views' points, and their E-step: one per worker.
#[wasm_bindgen]
pub struct JrmpcShard {
    shard: Shard,
    stats: Vec<ViewStats>,
}

#[wasm_bindgen]
impl JrmpcShard {
    /// `points`: a session's `shardPoints`; `sizes`: the points of each of those views.
    #[wasm_bindgen(constructor)]
    pub fn new(points: &[f64], sizes: &[u32]) -> Result<JrmpcShard, JsError> {
        let views =
            wire::read_shard_points(points, sizes).map_err(|e| JsError::new(&e.to_string()))?;
        Ok(Self { shard: Shard::new(views), stats: Vec::new() })
    }

    /// The E-step of this shard's views, which are views `first..` of the session: its
    /// output (`jrmpc::wire`).
    #[wasm_bindgen(js_name = eStep)]
    pub fn e_step(&mut self, input: &[f64], first: usize) -> Result<Float64Array, JsError> {
        let views = self.shard.len();
        let input = wire::read_e_step_input(input, first, views)
            .map_err(|e| JsError::new(&e.to_string()))?;
        let k = input.mixture.len();
        if self.stats.len() != views || self.stats.first().is_some_and(|s| s.lambda.len() != k) {
            self.stats = vec![ViewStats::zeros(k); views];
        }
        let terms = self.shard.e_step(&input.step(), &input.transforms, &mut self.stats);
        Ok(Float64Array::from(wire::e_step_output(terms, &self.stats).as_slice()))
    }
}

fn bad_pose() -> JsError {
    JsError::new("a pose is 7 finite numbers: a unit quaternion and a translation")
}

fn no_global() -> JsError {
    JsError::new("the current method is not in its global stage")
}

fn no_em() -> JsError {
    JsError::new("the current method is not in its jrmpc stage")
}

fn no_pairs() -> JsError {
    JsError::new("the current method is not registering frame pairs")
}

fn finished() -> JsError {
    JsError::new("the session has finished")
}
