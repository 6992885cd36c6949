//! `CalibrationSession` and `JrmpcShard`: the calibration driven step by step from JS, so a
//! pool of workers can share JRMPC's E-step (README, "Wasm API"). The session prepares the rig,
//! owns EM's state and runs the M-step; each shard holds a contiguous slice of the views and
//! returns their statistics, O(views x K) numbers, each iteration. The M-step takes every view's
//! statistics in view order, so the result is the same as `calibrate`'s, bit for bit, however
//! the views are split.
//!
//! Wire formats (flat `Float64Array`s, so they transfer between workers without copies):
//! - E-step input: `[beta, K, means (3K), variances (K), priors (K), then per view its rotation
//!   (9, row-major) and translation (3)]`;
//! - E-step output: `[terms, then per view lambda (K), s1 (3K), s2 (K)]`.

use js_sys::{Array, Float64Array, Function, Uint32Array};
use nalgebra::{Matrix3, Vector3};
use wasm_bindgen::prelude::*;

use super::calibrate::{ProgressSink, output, rig_and_settings};
use crate::calib::{self, Prepared};
use crate::jrmpc::{Em, Mixture, Shard, ViewStats};

/// Numbers per view in the E-step input: a rotation and a translation.
const TRANSFORM: usize = 12;
/// Numbers per component in a view's statistics: lambda, s1 (3), s2.
const STATS: usize = 5;

#[wasm_bindgen]
pub struct CalibrationSession {
    prepared: Option<Prepared>,
    /// `None` for the ICP methods, which have no EM.
    em: Option<Em>,
    /// The views' centred points, handed out to the shards.
    points: Vec<Vec<Vector3<f64>>>,
    max_iterations: usize,
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
        Ok(Self { prepared: Some(prepared), em, points, max_iterations })
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
                iteration: p.iteration,
                max_iterations: self.max_iterations,
                mean_sigma: p.mean_sigma,
                max_change: p.max_change,
                corrections: &prepared.jrmpc_corrections(&p.poses),
            },
        )
    }

    /// Stops EM after the current iteration.
    pub fn cancel(&mut self) {
        if let Some(em) = &mut self.em {
            em.cancel();
        }
    }

    /// The rest of the calibration (refinement, averaging, target fit): `calibrate`'s result.
    /// `onProgress` sees the refinement's progress, as with `calibrate`.
    pub fn finish(&mut self, on_progress: Option<Function>) -> Result<JsValue, JsError> {
        let prepared = self.prepared.take().ok_or_else(finished)?;
        let registration = self.em.take().map(Em::into_registration);
        let mut sink = ProgressSink::new(on_progress, prepared.sensors().to_vec());
        let result = prepared.finish(registration, |p| sink.send(p));
        sink.error()?;
        output(&result.map_err(|e| JsError::new(&e.to_string()))?)
    }
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
