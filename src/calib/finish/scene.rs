//! The chosen placements refined on the whole scans. Where the registrations saw a region (a
//! target's, or the user's), the rest of what both sensors see is evidence too, and the
//! selection already judges by it: GMMCalib's chair example, started 0.48 deg off, kept that
//! start (nothing registered on the chair beat it) while the room around the chair pins the
//! pair to a thousandth of a degree.

use super::super::pairs::{self, PairCorrections, PairIcp};
use super::super::region::RoiSource;
use super::super::select::Source;
use super::super::views::Views;
use super::hypotheses::Hypotheses;
use crate::cloud::transformed;
use crate::icp::{FixedCloud, IcpError};
use crate::se3::Pose;

/// Adds, per non-reference sensor, the frame pairs' ICP on the selection's scans (every frame
/// both sensors have there, whole, thinned) from its chosen hypothesis; whether any was added.
/// Nothing where the region was the scans' overlap itself, nor for a paper method (it keeps
/// its own result).
pub(super) fn refine_on_scene(views: &Views, hypotheses: &mut Hypotheses) -> bool {
    if views.roi_source == RoiSource::Overlap || !views.stages.select {
        return false;
    }
    // `gmm`'s refinement, `cad`'s too: it has none of its own.
    let ground = views.reference_ground().filter(|_| views.stages.ground_normals);
    let icp = PairIcp { settings: views.settings.refine.clone(), ground };
    let r = views.reference;
    // The reference's scans where the views are: at its pre-alignment.
    let frames: Vec<(&str, Vec<[f32; 3]>)> = (views.scenes.frames_of(r))
        .map(|(f, surface)| (f, transformed(&surface.points, &views.pre_aligned[r])))
        .collect();
    let threads = crate::threads_here(views.settings.jrmpc.threads);
    let fixed: Vec<Result<FixedCloud, IcpError>> =
        crate::on_threads(&frames, threads, |(_, points)| pairs::fixed_cloud(points, &icp, false));
    // Every frame pair of every sensor whose frame both have scored, from its chosen start.
    let frames = &frames;
    let jobs: Vec<Job> = (0..views.sensors.len())
        .filter(|&s| s != r)
        .flat_map(|sensor| {
            let parent = &hypotheses.list[sensor][hypotheses.chosen[sensor]];
            // Its correction of the pre-aligned views: `correction = c * levelled`.
            let start = parent.correction * views.levelled[sensor].inverse();
            views.pairs[sensor].iter().filter_map(move |&(rv, sv)| {
                let name = views.views[sv].frame.as_str();
                let frame = frames.iter().position(|(f, _)| *f == name)?;
                let (_, surface) = views.scenes.frames_of(sensor).find(|(f, _)| *f == name)?;
                let points = transformed(&surface.points, &views.pre_aligned[sensor]);
                Some(Job { sensor, pair: (rv, sv), frame, points, start })
            })
        })
        .collect();
    let aligned = crate::on_threads(&jobs, threads, |job| {
        let target = fixed[job.frame].as_ref().ok()?;
        pairs::align(target, &job.points, &job.start, &icp).ok()
    });
    let mut added = false;
    for s in (0..views.sensors.len()).filter(|&s| s != r) {
        let per_frame: PairCorrections = (jobs.iter().zip(&aligned))
            .filter(|(job, _)| job.sensor == s)
            .filter_map(|(job, c)| c.map(|c| (job.pair, c)))
            .collect();
        if per_frame.is_empty() {
            continue;
        }
        let parent = hypotheses.chosen[s];
        added |= hypotheses.add(views, s, Source::RefinedOnScene, parent, per_frame).is_some();
    }
    added
}

/// One frame pair's ICP on the whole scans: sensor `sensor`'s scan (`points`, pre-aligned) of
/// the `frame`-th reference scan's frame, from `start`, for its views' `pair`.
struct Job {
    sensor: usize,
    pair: (usize, usize),
    frame: usize,
    points: Vec<[f32; 3]>,
    start: Pose,
}
