//! `CalibrationSession`, `JrmpcShard` and `alignFrames`: the calibration driven step by step
//! from JS, so a pool of workers can share JRMPC's E-step and then the frame pairs' ICP
//! (README, "Wasm API"). The session prepares the rig, owns EM's state and runs the M-step;
//! each shard holds a contiguous slice of the views and returns their statistics, O(views x K)
//! numbers, each iteration. The M-step takes every view's statistics in view order, and the
//! frame pairs' outcomes are kept in pair order, so the result is the same as `calibrate`'s,
//! bit for bit, however the work is split.
//!
//! Wire formats (flat `Float64Array`s, so they transfer between workers without copies):
//! - E-step input: `[beta, K, means (3K), variances (K), priors (K), then per view its rotation
//!   (9, row-major) and translation (3)]`;
//! - E-step output: `[terms, then per view lambda (K), s1 (3K), s2 (K)]`;
//! - a pose (a frame pair's start or outcome): `[qx, qy, qz, qw, x, y, z]`, the rotation's
//!   unit quaternion and the translation, exactly as the library holds them.

use js_sys::{Array, Float32Array, Float64Array, Function, Uint32Array};
use nalgebra::{Matrix3, Quaternion, Translation3, UnitQuaternion, Vector3, Vector4};
use wasm_bindgen::prelude::*;

use super::calibrate::{ProgressSink, output, rig_and_settings};
use super::to_js;
use crate::calib::refine::{self, Plan, Refinement};
use crate::calib::{self, Prepared};
use crate::cloud::Cloud;
use crate::jrmpc::{Em, Mixture, Registration, Shard, ViewStats};
use crate::se3::Pose;

/// Numbers per view in the E-step input: a rotation and a translation.
const TRANSFORM: usize = 12;
/// Numbers per component in a view's statistics: lambda, s1 (3), s2.
const STATS: usize = 5;
/// Numbers per pose: a unit quaternion and a translation.
const POSE: usize = 7;

#[wasm_bindgen]
pub struct CalibrationSession {
    prepared: Option<Prepared>,
    /// `None` for the ICP methods, which have no EM.
    em: Option<Em>,
    /// The views' centred points, handed out to the shards.
    points: Vec<Vec<Vector3<f64>>>,
    max_iterations: usize,
    /// Once EM is over: its result (none for the ICP methods) and the frame pairs to register.
    registered: Option<(Option<Registration>, Option<Refinement>)>,
}

#[wasm_bindgen]
impl CalibrationSession {
    /// Checks, levels and crops the rig `input` (as `calibrate` takes it) and starts EM.
    #[wasm_bindgen(constructor)]
    pub fn new(input: JsValue) -> Result<CalibrationSession, JsError> {
        let (rig, settings) = rig_and_settings(input)?;
        let prepared = calib::prepare(&rig, &settings).map_err(|e| JsError::new(&e.to_string()))?;
        let (em, points) = if settings.method.uses_jrmpc() {
            let (em, points) = prepared.start_jrmpc().map_err(|e| JsError::new(&e.to_string()))?;
            (Some(em), points)
        } else {
            (None, Vec::new())
        };
        let max_iterations = settings.jrmpc.max_iterations;
        Ok(Self { prepared: Some(prepared), em, points, max_iterations, registered: None })
    }

    /// Points per view (0 views for the ICP methods), for splitting the views among shards.
    #[wasm_bindgen(js_name = viewSizes)]
    pub fn view_sizes(&self) -> Uint32Array {
        let sizes: Vec<u32> = self.points.iter().map(|v| v.len() as u32).collect();
        Uint32Array::from(sizes.as_slice())
    }

    /// The centred points of views `first..first + count`, flat, for `new JrmpcShard`.
    #[wasm_bindgen(js_name = shardPoints)]
    pub fn shard_points(&self, first: usize, count: usize) -> Result<Float64Array, JsError> {
        let views = self.points.get(first..first.saturating_add(count)).ok_or_else(|| {
            JsError::new(&format!("views {first}..{first}+{count} of {}", self.points.len()))
        })?;
        let flat: Vec<f64> = views.iter().flatten().flat_map(|p| [p.x, p.y, p.z]).collect();
        Ok(Float64Array::from(flat.as_slice()))
    }

    /// EM has converged, been cancelled or run out of iterations (or there is none).
    pub fn finished(&self) -> bool {
        self.em.as_ref().is_none_or(Em::finished)
    }

    /// The next E-step's input (see the module's wire formats).
    #[wasm_bindgen(js_name = eStepInput)]
    pub fn e_step_input(&self) -> Result<Float64Array, JsError> {
        let em = self.em.as_ref().ok_or_else(no_em)?;
        let mixture = em.mixture();
        let k = mixture.len();
        let mut flat = Vec::with_capacity(2 + 5 * k + TRANSFORM * em.transforms().len());
        flat.extend([em.beta(), k as f64]);
        flat.extend(mixture.means.iter().flat_map(|m| [m.x, m.y, m.z]));
        flat.extend(&mixture.variances);
        flat.extend(&mixture.priors);
        for (r, t) in em.transforms() {
            flat.extend(r.transpose().iter()); // column-major storage: row-major out
            flat.extend(t.iter());
        }
        Ok(Float64Array::from(flat.as_slice()))
    }

    /// Ends an iteration with the shards' E-step outputs, in view order; returns the progress
    /// (`calibrate`'s shape).
    #[wasm_bindgen(js_name = mStep)]
    pub fn m_step(&mut self, outputs: Array) -> Result<JsValue, JsError> {
        let em = self.em.as_mut().ok_or_else(no_em)?;
        let k = em.mixture().len();
        let mut stats = Vec::with_capacity(em.transforms().len());
        let mut terms = 0.0;
        for output in outputs.iter() {
            let flat = output
                .dyn_into::<Float64Array>()
                .map_err(|_| JsError::new("mStep takes an array of Float64Array"))?
                .to_vec();
            let (head, rest) = flat.split_first().ok_or_else(|| bad_stats(0, k))?;
            if rest.len() % (STATS * k) != 0 {
                return Err(bad_stats(rest.len(), k));
            }
            terms += head;
            stats.extend(rest.chunks_exact(STATS * k).map(|view| read_stats(view, k)));
        }
        if stats.len() != em.transforms().len() {
            return Err(JsError::new(&format!(
                "mStep got statistics for {} views, expected {}",
                stats.len(),
                em.transforms().len()
            )));
        }
        em.m_step(&stats, terms as u64);
        let prepared = self.prepared.as_ref().ok_or_else(finished)?;
        let p = em.progress();
        ProgressSink::value(
            prepared.sensors(),
            &calib::Progress {
                stage: calib::Stage::Jrmpc,
                iteration: p.iteration,
                max_iterations: self.max_iterations,
                mean_sigma: p.mean_sigma,
                max_change: p.max_change,
                corrections: &prepared.jrmpc_corrections(&p.poses),
            },
        )
    }

    /// Stops EM after the current iteration, and the frame pairs after the current one.
    pub fn cancel(&mut self) {
        if let Some(em) = &mut self.em {
            em.cancel();
        }
        if let Some((_, Some(refinement))) = &mut self.registered {
            refinement.stop();
        }
    }

    /// Ends EM and returns the frame pairs to register (`gmm`'s refinement, the ICP methods),
    /// or `null` (`jrmpc`): `{plan, jobs, starts}`, where `jobs` holds `referenceView, view`
    /// per pair (the views of `viewPoints`) and `starts` a pose per pair. Register them here
    /// (`alignFrames`, `refineFrames`) or elsewhere (`alignFrames` in another worker, then
    /// `recordFrame`), in any order.
    #[wasm_bindgen(js_name = frameJobs)]
    pub fn frame_jobs(&mut self) -> Result<JsValue, JsError> {
        let Some(refinement) = self.refinement()? else { return Ok(JsValue::NULL) };
        let value = js_sys::Object::new();
        let jobs: Vec<u32> = refinement
            .jobs()
            .iter()
            .flat_map(|j| [j.reference_view as u32, j.view as u32])
            .collect();
        let starts: Vec<f64> =
            refinement.jobs().iter().flat_map(|j| pose_to_flat(&j.start)).collect();
        let fields = [
            ("plan", to_js(refinement.plan())?),
            ("jobs", Uint32Array::from(jobs.as_slice()).into()),
            ("starts", Float64Array::from(starts.as_slice()).into()),
        ];
        for (key, field) in fields {
            js_sys::Reflect::set(&value, &key.into(), &field).map_err(|_| internal())?;
        }
        Ok(value.into())
    }

    /// View `view`'s cropped, pre-aligned points (flat `x, y, z`), as `alignFrames` takes them.
    #[wasm_bindgen(js_name = viewPoints)]
    pub fn view_points(&self, view: usize) -> Result<Float32Array, JsError> {
        let prepared = self.prepared.as_ref().ok_or_else(finished)?;
        let clouds = prepared.clouds();
        let cloud = clouds
            .get(view)
            .ok_or_else(|| JsError::new(&format!("no view {view} of {}", clouds.len())))?;
        Ok(Float32Array::from(cloud.as_flattened()))
    }

    /// Registers the frame pairs `jobs` (indices into `frameJobs().jobs`) here; `onProgress`
    /// sees each, as with `calibrate`.
    #[wasm_bindgen(js_name = refineFrames)]
    pub fn refine_frames(
        &mut self,
        jobs: &[u32],
        on_progress: Option<Function>,
    ) -> Result<(), JsError> {
        self.refinement()?;
        let prepared = self.prepared.as_ref().ok_or_else(finished)?;
        let Some((_, Some(refinement))) = &mut self.registered else { return Ok(()) };
        jobs.iter().try_for_each(|&job| check_job(refinement, job as usize))?;
        let mut sink = ProgressSink::new(on_progress, prepared.sensors().to_vec());
        prepared.refine(refinement, jobs.iter().map(|&j| j as usize), 1, &mut |p| sink.send(p));
        sink.error()
    }

    /// Records frame pair `job`'s outcome, registered elsewhere: a pose (see the wire formats)
    /// or the error's message. Returns the progress (`calibrate`'s shape).
    #[wasm_bindgen(js_name = recordFrame)]
    pub fn record_frame(&mut self, job: usize, outcome: JsValue) -> Result<JsValue, JsError> {
        let outcome = match (outcome.as_string(), outcome.dyn_ref::<Float64Array>()) {
            (Some(message), _) => Err(message),
            (None, Some(pose)) => Ok(pose_from_flat(&pose.to_vec())?),
            (None, None) => return Err(JsError::new("recordFrame: a pose or a message")),
        };
        self.refinement()?;
        let prepared = self.prepared.as_ref().ok_or_else(finished)?;
        let Some((_, Some(refinement))) = &mut self.registered else {
            return Err(JsError::new("this method has no frame pairs"));
        };
        check_job(refinement, job)?;
        refinement.record(job, outcome);
        let corrections = prepared.levelled(&refinement.running());
        ProgressSink::value(prepared.sensors(), &refinement.progress(&corrections))
    }

    /// The rest of the calibration (the frame pairs not registered yet, averaging, target
    /// fit): `calibrate`'s result. `onProgress` sees those pairs, as with `calibrate`.
    pub fn finish(&mut self, on_progress: Option<Function>) -> Result<JsValue, JsError> {
        let all: Vec<u32> = match self.refinement()? {
            Some(refinement) => (0..refinement.jobs().len() as u32).collect(),
            None => Vec::new(),
        };
        self.refine_frames(&all, on_progress)?;
        let prepared = self.prepared.take().ok_or_else(finished)?;
        let (registration, refinement) = self.registered.take().ok_or_else(finished)?;
        output(
            &prepared
                .finish_with(registration, refinement)
                .map_err(|e| JsError::new(&e.to_string()))?,
        )
    }
}

/// An error unless `job` is one of `refinement`'s frame pairs.
fn check_job(refinement: &Refinement, job: usize) -> Result<(), JsError> {
    let count = refinement.jobs().len();
    if job < count { Ok(()) } else { Err(JsError::new(&format!("no frame pair {job} of {count}"))) }
}

impl CalibrationSession {
    /// The frame pairs, EM ended first if it has not been.
    fn refinement(&mut self) -> Result<Option<&Refinement>, JsError> {
        if self.registered.is_none() {
            let prepared = self.prepared.as_ref().ok_or_else(finished)?;
            let registration = self.em.take().map(Em::into_registration);
            let refinement = prepared.refinement(registration.as_ref());
            self.registered = Some((registration, refinement));
        }
        Ok(self.registered.as_ref().and_then(|(_, r)| r.as_ref()))
    }
}

/// Registers each of `sources` (flat points, like `viewPoints`) onto `target` from its pose in
/// `starts`, by `plan` (`frameJobs().plan`): per source, its pose or the error's message.
/// The target is built once, so pass every pair of one reference view together.
#[wasm_bindgen(js_name = alignFrames)]
pub fn align_frames(
    plan: JsValue,
    target: &[f32],
    sources: Array,
    starts: &[f64],
) -> Result<Array, JsError> {
    let plan: Plan = serde_wasm_bindgen::from_value(plan)
        .map_err(|e| JsError::new(&format!("alignFrames: invalid plan: {e}")))?;
    if starts.len() != POSE * sources.length() as usize {
        return Err(JsError::new(&format!(
            "alignFrames: {} numbers of starts for {} sources",
            starts.len(),
            sources.length()
        )));
    }
    let target = cloud_from(target, "target")?;
    let built = refine::target(&target.points, &plan);
    let outcomes = Array::new();
    for (i, (source, start)) in sources.iter().zip(starts.chunks_exact(POSE)).enumerate() {
        let source = cloud_of(&source, &format!("source {i}"))?;
        let start = pose_from_flat(start)?;
        let outcome: JsValue = match &built {
            Ok(target) => match refine::align(target, &source.points, &start, &plan) {
                Ok(pose) => Float64Array::from(pose_to_flat(&pose).as_slice()).into(),
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
        .ok_or_else(|| JsError::new(&format!("alignFrames: the {what} is not a Float32Array")))?
        .to_vec();
    cloud_from(&flat, what)
}

/// `flat` (`x, y, z, ...`) as a cloud, or an error naming `what`.
fn cloud_from(flat: &[f32], what: &str) -> Result<Cloud, JsError> {
    Cloud::from_flat(flat).ok_or_else(|| {
        JsError::new(&format!("alignFrames: the {what}'s {} numbers are not points", flat.len()))
    })
}

fn pose_to_flat(pose: &Pose) -> [f64; POSE] {
    let (q, t) = (pose.rotation.coords, pose.translation.vector);
    [q.x, q.y, q.z, q.w, t.x, t.y, t.z]
}

/// The pose `pose_to_flat` wrote; anything else (wrong length, not finite, not a unit
/// quaternion) is an error.
fn pose_from_flat(flat: &[f64]) -> Result<Pose, JsError> {
    let bad = || JsError::new("a pose is 7 finite numbers: a unit quaternion and a translation");
    let &[x, y, z, w, tx, ty, tz] = flat else { return Err(bad()) };
    let q = Quaternion::from(Vector4::new(x, y, z, w));
    if !flat.iter().all(|v| v.is_finite()) || (q.norm() - 1.0).abs() > 1e-9 {
        return Err(bad());
    }
    Ok(Pose::from_parts(Translation3::new(tx, ty, tz), UnitQuaternion::new_unchecked(q)))
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
        // u64: a sum of u32 sizes may not fit wasm32's usize.
        let total: u64 = sizes.iter().map(|&n| u64::from(n)).sum();
        if total * 3 != points.len() as u64 {
            return Err(JsError::new(&format!(
                "shard: {} coordinates for {total} points",
                points.len()
            )));
        }
        let mut rest = points;
        let views = sizes
            .iter()
            .map(|&n| {
                let (view, tail) = rest.split_at(3 * n as usize);
                rest = tail;
                view.chunks_exact(3).map(|p| Vector3::new(p[0], p[1], p[2])).collect()
            })
            .collect();
        Ok(Self { shard: Shard::new(views, false), stats: Vec::new() })
    }

    /// The E-step of this shard's views, which are views `first..` of the session: its
    /// output (see the module's wire formats).
    #[wasm_bindgen(js_name = eStep)]
    pub fn e_step(&mut self, input: &[f64], first: usize) -> Result<Float64Array, JsError> {
        let bad = || JsError::new("shard: malformed E-step input");
        let (&beta, rest) = input.split_first().ok_or_else(bad)?;
        let (&k, rest) = rest.split_first().ok_or_else(bad)?;
        let k = k as usize; // saturating; NaN -> 0
        if k == 0 || k > rest.len() / 5 || !(beta.is_finite() && beta > 0.0) {
            return Err(bad());
        }
        let (mixture, transforms) = rest.split_at(5 * k);
        let mixture = Mixture {
            means: mixture[..3 * k]
                .chunks_exact(3)
                .map(|m| Vector3::new(m[0], m[1], m[2]))
                .collect(),
            variances: mixture[3 * k..4 * k].to_vec(),
            priors: mixture[4 * k..].to_vec(),
        };
        let plausible = mixture.means.iter().all(|m| m.iter().all(|x| x.is_finite()))
            && mixture.variances.iter().all(|v| v.is_finite() && *v > 0.0)
            && mixture.priors.iter().all(|p| p.is_finite() && *p >= 0.0);
        if !plausible {
            return Err(JsError::new("shard: the mixture is not finite"));
        }
        let views = self.shard.len();
        let transforms = transforms
            .chunks_exact(TRANSFORM)
            .skip(first)
            .take(views)
            .map(|rt| (Matrix3::from_row_slice(&rt[..9]), Vector3::new(rt[9], rt[10], rt[11])))
            .collect::<Vec<_>>();
        if transforms.len() != views {
            return Err(JsError::new(&format!("shard: no transforms for views {first}..")));
        }
        if self.stats.len() != views || self.stats.first().is_some_and(|s| s.lambda.len() != k) {
            self.stats = vec![ViewStats::zeros(k); views];
        }
        let terms = self.shard.e_step(&mixture, beta, &transforms, &mut self.stats);
        let mut flat = Vec::with_capacity(1 + STATS * k * views);
        flat.push(terms as f64);
        for st in &self.stats {
            flat.extend(&st.lambda);
            flat.extend(st.s1.iter().flat_map(|s| [s.x, s.y, s.z]));
            flat.extend(&st.s2);
        }
        Ok(Float64Array::from(flat.as_slice()))
    }
}

fn read_stats(flat: &[f64], k: usize) -> ViewStats {
    ViewStats {
        lambda: flat[..k].to_vec(),
        s1: flat[k..4 * k].chunks_exact(3).map(|s| Vector3::new(s[0], s[1], s[2])).collect(),
        s2: flat[4 * k..5 * k].to_vec(),
    }
}

fn bad_stats(len: usize, k: usize) -> JsError {
    JsError::new(&format!("mStep: {len} numbers is not a whole number of views of {k} components"))
}

fn no_em() -> JsError {
    JsError::new("this method has no EM to drive")
}

fn finished() -> JsError {
    JsError::new("the session has finished")
}

fn internal() -> JsError {
    JsError::new("internal: cannot build the frame jobs")
}
