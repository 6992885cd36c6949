//! Per-frame ICP of each sensor's view onto the reference sensor's view of the same frame:
//! the ICP baselines, and `gmm`'s refinement of the JRMPC corrections.
//!
//! Why refine: JRMPC's isotropic Gaussians blend the sensors' different samplings of the same
//! surfaces, and each view is pulled point-to-point toward that blend, which leaves a bias
//! along the surfaces (README, "Why refine"). Point-to-plane and GICP remove most of the in-plane force; JRMPC
//! supplies the basin of convergence. The match distance shrinks over stages, so the first
//! stage can still catch what JRMPC left and the last one ignores what does not overlap.

use crate::icp::{self, IcpSettings};
use crate::jrmpc::Control;
use crate::se3::Pose;

use super::Progress;
use super::average::average;
use super::level::Plane;
use nalgebra::Vector3;

/// The refinement's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RefineSettings {
    /// The ICP variant that refines.
    pub method: icp::Method,
    /// Maximum correspondence distance (m) of each stage, in order.
    pub match_distances: Vec<f64>,
    /// The ICP settings of every stage (the match distance is taken from the stages).
    pub icp: IcpSettings,
    /// A refinement that moves a frame's correction further than this from where it started
    /// (rad, m) has slid off (on sparse views, poor normals can drag ICP away); the
    /// frame keeps its starting correction and is reported. JRMPC's errors stay well inside.
    pub max_departure: (f64, f64),
}

impl Default for RefineSettings {
    fn default() -> Self {
        Self {
            // GICP measured better than point-to-plane on the full-view rigs (README).
            method: icp::Method::Gicp,
            match_distances: vec![0.5, 0.2, 0.1, 0.05],
            icp: IcpSettings {
                // Tight: the refinement is the last word on the calibration.
                translation_tolerance: 1e-5,
                rotation_tolerance: 1e-5,
                // About the range noise: matches across edges and onto the other side of a
                // cube stop pulling (twin, README: median 0.028 -> 0.019 deg).
                robust_scale: Some(0.01),
                ..IcpSettings::default()
            },
            max_departure: (2f64.to_radians(), 0.2),
        }
    }
}

/// A frame whose registration failed (left out of the average) or whose refinement was
/// rejected (the starting correction kept).
pub struct Failure {
    /// Index of the sensor's view.
    pub view: usize,
    pub reason: String,
    pub kept_start: bool,
}

/// How the frames are registered.
pub struct Plan<'a> {
    pub method: icp::Method,
    pub settings: &'a IcpSettings,
    /// One ICP stage per match distance (m), in order.
    pub match_distances: &'a [f64],
    /// Rotation (rad) and translation (m) beyond which a result is rejected, if any.
    pub max_departure: Option<(f64, f64)>,
    /// The reference's ground plane and the band (m) around it whose points take its normal.
    pub ground: Option<(Plane, f64)>,
}

/// For each sensor and frame pair `(reference view, sensor view)`, registers the sensor's view
/// onto the reference's from the current correction (identity when `corrections[s]` is empty,
/// i.e. the nominal pre-alignment) and replaces it. Frames that fail are dropped and returned.
///
/// With `threads` > 1 (native only) the pairs run on that many threads, a batch at a time; the
/// results are the same as on one, and `progress` still sees every pair in order (a stop takes
/// effect after the batch).
pub fn per_frame(
    clouds: &[&[[f32; 3]]],
    pairs: &[Vec<(usize, usize)>],
    reference: usize,
    corrections: &mut [Vec<((usize, usize), Pose)>],
    plan: &Plan,
    threads: usize,
    progress: &mut impl FnMut(&Progress) -> Control,
) -> Result<Vec<Failure>, super::CalibError> {
    let threads = if cfg!(target_arch = "wasm32") { 1 } else { threads.max(1) };
    // Every pair to register, in order: (sensor, reference view, view, start).
    let jobs: Vec<(usize, usize, usize, Pose)> = pairs
        .iter()
        .enumerate()
        .filter(|(s, _)| *s != reference)
        .flat_map(|(s, frames)| {
            let corrections = &corrections[s];
            frames.iter().map(move |&(r, v)| {
                let start = corrections
                    .iter()
                    .find(|(p, _)| *p == (r, v))
                    .map_or_else(Pose::identity, |(_, c)| *c);
                (s, r, v, start)
            })
        })
        .collect();
    // Targets are built once per reference view, when a batch first needs it, and shared by
    // every sensor.
    let mut targets: Vec<Option<Result<icp::Target, icp::IcpError>>> =
        (0..clouds.len()).map(|_| None).collect();
    let mut refined: Vec<Vec<((usize, usize), Pose)>> = vec![Vec::new(); pairs.len()];
    refined[reference] = pairs[reference].iter().map(|&pair| (pair, Pose::identity())).collect();
    let mut failures = Vec::new();
    let mut done = 0;
    'batches: for batch in jobs.chunks(4 * threads) {
        let mut needed: Vec<usize> =
            batch.iter().map(|j| j.1).filter(|&r| targets[r].is_none()).collect();
        needed.sort_unstable();
        needed.dedup();
        let built = on_threads(&needed, threads, |&r| target(clouds[r], plan));
        for (&r, built) in needed.iter().zip(built) {
            targets[r] = Some(built);
        }
        let aligned = on_threads(batch, threads, |&(_, r, v, start)| {
            let target =
                targets[r].as_ref().expect("built for the batch").as_ref().map_err(Clone::clone);
            target.and_then(|target| {
                plan.match_distances.iter().try_fold(start, |pose, &distance| {
                    let stage = IcpSettings {
                        max_correspondence_distance: distance,
                        ..plan.settings.clone()
                    };
                    target.align(clouds[v], &pose, &stage).map(|a| a.target_from_source)
                })
            })
        });
        for (&(s, r, v, start), result) in batch.iter().zip(aligned) {
            match result {
                Ok(pose) => match departure_beyond(&start, &pose, plan.max_departure) {
                    None => refined[s].push(((r, v), pose)),
                    Some(reason) => {
                        failures.push(Failure { view: v, reason, kept_start: true });
                        refined[s].push(((r, v), start));
                    }
                },
                Err(e) => failures.push(Failure {
                    view: v,
                    reason: format!("{} failed: {e}", plan.method.name()),
                    kept_start: false,
                }),
            }
            done += 1;
            let running: Vec<Pose> = refined
                .iter()
                .map(|c| {
                    average(&c.iter().map(|(_, p)| *p).collect::<Vec<_>>())
                        .map_or_else(Pose::identity, |(m, _)| m)
                })
                .collect();
            let answer = progress(&Progress {
                iteration: done,
                max_iterations: jobs.len(),
                mean_sigma: 0.0,
                max_change: 0.0,
                corrections: &running,
            });
            if answer == Control::Stop {
                break 'batches;
            }
        }
    }
    corrections.iter_mut().zip(refined).for_each(|(c, r)| *c = r);
    Ok(failures)
}

/// The ICP target of reference view `cloud`, with the plan's ground normals.
fn target(cloud: &[[f32; 3]], plan: &Plan) -> Result<icp::Target, icp::IcpError> {
    let mut target = icp::Target::new(cloud, plan.method, plan.settings)?;
    if let Some((plane, band)) = plan.ground {
        target.set_normals(|p| {
            let p = Vector3::from(p.map(f64::from));
            (plane.distance(&p).abs() <= band).then_some(plane.normal)
        });
    }
    Ok(target)
}

/// `f` of every item, in order, on up to `threads` threads (contiguous slices).
fn on_threads<T: Sync, R: Send>(items: &[T], threads: usize, f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    if threads <= 1 || items.len() <= 1 {
        return items.iter().map(f).collect();
    }
    let per = items.len().div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(per)
            .map(|chunk| scope.spawn(move || chunk.iter().map(f).collect::<Vec<R>>()))
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a refinement thread panicked")).collect()
    })
}

/// Why `end` is too far from `start` to be trusted, if it is.
fn departure_beyond(start: &Pose, end: &Pose, limit: Option<(f64, f64)>) -> Option<String> {
    let (angle, distance) = limit?;
    let d = start.inverse() * end;
    let (a, t) = (d.rotation.angle(), d.translation.vector.norm());
    (a > angle || t > distance).then(|| {
        format!(
            "refinement moved {:.2} deg / {:.3} m from the JRMPC correction; kept that instead",
            a.to_degrees(),
            t
        )
    })
}
