//! The first stage of every calibration: a [`Rig`]'s scans become views — each sensor levelled
//! onto the reference's ground and searched from above (when its stages say so), pre-aligned
//! with its nominal, cropped to the ROI, and paired with the reference's view of the same
//! frame. [`Views`] owns what the later stages need.

use super::global::{GlobalAlignment, GlobalStage};
use super::grounds::{level_sensor, reference_levelling, sensor_ground};
use super::notes::{LevellingSkipped, Note, NoteKind};
use super::pairs::{FramePairs, PairCorrections, PairIcp, PairStart};
use super::placed::{place_targets, roi_around_targets};
use super::region::{self, RoiSource};
use super::result::Levelling;
use super::rig::sensor_seed;
use super::select::{self, FrameScans, Hypothesis, Scenes, Source};
use super::settings::{InitialSigma, Method, Settings, Stages};
use super::{CalibError, Rig};
use crate::cloud::{Aabb, Cloud, is_valid_point};
use crate::jrmpc::{self, Em, Registration};
use crate::plane::Plane;
use crate::se3::Pose;
use crate::targets::{Placement, Target};

/// One cropped, pre-aligned view and whose it is.
pub(super) struct View {
    pub sensor: usize,
    pub frame: String,
    pub cloud: Cloud,
}

/// A rig's scans as views, ready for registration.
pub struct Views {
    pub(super) settings: Settings,
    pub(super) stages: Stages,
    pub(super) sensors: Vec<String>,
    /// Index of the reference in `sensors`.
    pub(super) reference: usize,
    /// Nominal `T_vehicle_sensor`, per sensor.
    pub(super) nominals: Vec<Pose>,
    pub(super) levelling: Vec<Levelling>,
    /// Per sensor, the global alignment (empty when off); its motion is part of `levelled`.
    pub(super) global: Vec<GlobalAlignment>,
    /// The motion the global alignment and the levelling applied on top of each sensor's
    /// nominal (identity without either).
    pub(super) levelled: Vec<Pose>,
    /// Each sensor's levelled nominal, `levelled * nominal`: what its points are pre-aligned by.
    pub(super) pre_aligned: Vec<Pose>,
    /// The views left after cropping.
    pub(super) views: Vec<View>,
    /// Scans left out, and why.
    pub(super) skipped: Vec<Note>,
    /// Per sensor, its frame pairs: (reference view, sensor view) of the frames both have.
    pub(super) pairs: Vec<Vec<(usize, usize)>>,
    /// The reference's ground, for the reconstruction's fit and the verdict.
    pub(super) ground: Option<Plane>,
    /// Where a CAD-model target stands (`T_vehicle_model` per copy found in the reference's
    /// views); empty for the other targets.
    pub(super) placements: Vec<Placement>,
    /// Per sensor, another sensor one of whose scans is one of its own, if any.
    pub(super) same_scans: Vec<(String, String)>,
    /// The region of interest the scans were cropped to, and where it came from.
    pub(super) roi: Aabb,
    pub(super) roi_source: RoiSource,
    /// Every sensor's whole scans, prepared for the selection score.
    pub(super) scenes: Scenes,
    /// Per sensor, its hypotheses so far: the nominal (first), the global stage's candidates,
    /// the levelled start; the reference has only its nominal.
    pub(super) hypotheses: Vec<Vec<Hypothesis>>,
    /// Per sensor, the hypothesis its views are pre-aligned by (`levelled` is its correction).
    pub(super) start: Vec<usize>,
}

/// What JRMPC registers: the views, the target's surface at their centroid, and EM's
/// settings.
pub struct JrmpcInput<'a> {
    pub clouds: Vec<&'a [[f32; 3]]>,
    pub means: Vec<[f64; 3]>,
    pub settings: jrmpc::EmSettings,
}

impl Views {
    /// Levels, searches, crops and pairs `rig`'s scans as `method` under `settings` asks.
    pub fn new(rig: &Rig, method: Method, settings: &Settings) -> Result<Self, CalibError> {
        let global = Self::global_stage(rig, method, settings)?
            .map_or_else(Vec::new, |g| g.into_alignments());
        Self::with_global(rig, method, settings, global)
    }

    /// The global stage `method` under `settings` asks for on `rig`, its reference's ground
    /// found; `None` when it asks for none.
    pub fn global_stage(
        rig: &Rig,
        method: Method,
        settings: &Settings,
    ) -> Result<Option<GlobalStage>, CalibError> {
        let (sensors, r) = rig.checked()?;
        settings.check()?;
        let Some(global_settings) = Stages::of(method, settings).global else { return Ok(None) };
        let nominals: Vec<Pose> = sensors.iter().map(|s| rig.nominal_of(s)).collect();
        let seeds: Vec<u64> = (0..sensors.len())
            .map(|s| if s == r { settings.seed } else { sensor_seed(settings.seed, &sensors, s) })
            .collect();
        let scans = sensor_scans(rig, &sensors);
        Ok(Some(GlobalStage::new(scans, &nominals, r, &global_settings, &seeds)))
    }

    /// [`Views::new`] with the global stage's alignments, per sensor, already found (empty
    /// when it is off): from then on each sensor starts from `global * nominal` as if that
    /// were its nominal.
    pub fn with_global(
        rig: &Rig,
        method: Method,
        settings: &Settings,
        global: Vec<GlobalAlignment>,
    ) -> Result<Self, CalibError> {
        let (sensors, r) = rig.checked()?;
        settings.check()?;
        let stages = Stages::of(method, settings);
        let nominals: Vec<Pose> = sensors.iter().map(|s| rig.nominal_of(s)).collect();
        let threads = settings.jrmpc.threads;

        // The start: the nominal or one of the global stage's candidates, by the selection;
        // not by the grounds yet: a right candidate may be tilted until it is levelled.
        let scenes = Scenes::new(&frame_scans(rig, &sensors), r, &settings.select, threads);
        let mut hypotheses: Vec<Vec<Hypothesis>> =
            (0..sensors.len()).map(|s| roots(global.get(s).filter(|_| s != r))).collect();
        let mut start: Vec<usize> = hypotheses.iter().map(|h| usize::from(h.len() > 1)).collect();
        let on =
            select::Scoring { scenes: &scenes, nominals: &nominals, reference: r, ground: None };
        select::choose_all(&on, &mut hypotheses, &mut start, &settings.select, threads);
        let starts = select::placed(&hypotheses, &start, &nominals);
        let roi = match rig.roi {
            Some(roi) => roi,
            None => region::overlap_region(&sensor_scans(rig, &sensors), &starts, r)
                .ok_or(CalibError::NoOverlap)?,
        };

        // Level, then search from above, when the stages say so: a hypothesis like any other.
        // The best-scored global candidates are levelled, not only the start: one in the right
        // basin may score below the nominal until levelled (the global stage's ground, one
        // RANSAC draw on the whole scan, may lie degrees off the one found near the region). The
        // nominal is
        // levelled only as the start: where it is not, a candidate beat it, and a levelling far
        // from it is no longer the user's guess, which the selection favours on a tie. The
        // bird's-eye search, which costs fifty levellings, runs from the start, and from another
        // candidate only once its levelling is chosen.
        // The reference's ground: what the others are levelled onto, and, levelled or not,
        // the reconstruction's fit and the verdict's structure.
        let reference = sensor_ground(rig, &roi, &sensors, &starts[r], r, settings);
        let mut levelling: Vec<Levelling> = match stages.level {
            true => sensors.iter().map(|name| reference_levelling(name, &reference)).collect(),
            false => Vec::new(),
        };
        let level = |s: usize, parent: usize, hypotheses: &[Vec<Hypothesis>], search: bool| {
            let from = hypotheses[s][parent].correction * nominals[s];
            level_sensor(rig, &roi, &sensors, &from, s, r, &reference, settings, &stages, search)
        };
        // Per sensor, its `Levelled` hypotheses and the levelling behind each.
        let mut levelled_from: Vec<Vec<(usize, Levelling)>> = vec![Vec::new(); sensors.len()];
        let jobs: Vec<(usize, usize)> = (0..sensors.len())
            .filter(|&s| s != r && stages.level)
            .flat_map(|s| {
                // The nominal, where it is not the start, was beaten by a candidate already.
                let start = start[s];
                let best = best_scored(&hypotheses[s], LEVELLED_CANDIDATES);
                let levelled = move |k: &usize| *k == start || best.contains(k);
                (0..hypotheses[s].len()).filter(levelled).map(move |k| (s, k))
            })
            .collect();
        let found = crate::on_threads(&jobs, crate::threads_here(threads), |&(s, k)| {
            level(s, k, &hypotheses, k == start[s])
        });
        for (&(s, parent), l) in jobs.iter().zip(found) {
            if parent == start[s] {
                // Reported unless another root's levelling is chosen.
                levelling[s] = l.clone();
            }
            add_levelled(&mut hypotheses[s], &mut levelled_from[s], parent, l);
        }
        let before = start.clone();
        if jobs.iter().any(|&(s, _)| !levelled_from[s].is_empty()) {
            select::choose_all(&on, &mut hypotheses, &mut start, &settings.select, threads);
        }
        // Another root's levelling chosen: the bird's-eye search from that root too.
        let searched: Vec<(usize, usize)> = (0..sensors.len())
            .filter(|&s| stages.bev.is_some() && s != r)
            .filter_map(|s| {
                let parent = hypotheses[s][start[s]].parent?;
                let other =
                    hypotheses[s][start[s]].source == Source::Levelled && parent != before[s];
                other.then_some((s, parent))
            })
            .collect();
        let found = crate::on_threads(&searched, crate::threads_here(threads), |&(s, k)| {
            level(s, k, &hypotheses, true)
        });
        for (&(s, parent), l) in searched.iter().zip(found) {
            add_levelled(&mut hypotheses[s], &mut levelled_from[s], parent, l);
        }
        if !searched.is_empty() {
            select::choose_all(&on, &mut hypotheses, &mut start, &settings.select, threads);
        }
        for (s, level) in levelling.iter_mut().enumerate().filter(|(s, _)| *s != r) {
            match levelled_from[s].iter().find(|(k, _)| *k == start[s]) {
                Some((_, chosen)) => *level = chosen.clone(),
                None if level.skipped.is_none() && level.motion != Pose::identity() => {
                    level.motion = Pose::identity();
                    level.skipped = Some(LevellingSkipped::ScoredWorse);
                }
                None => {}
            }
        }
        let levelled: Vec<Pose> =
            (0..sensors.len()).map(|s| hypotheses[s][start[s]].correction).collect();

        let ground = reference.1.map(|(g, _)| g);

        // Pre-align and crop: to the user's ROI, else around the targets found in the
        // reference's points, else to where the clouds overlap.
        let pre_aligned: Vec<Pose> = levelled.iter().zip(&nominals).map(|(l, n)| l * n).collect();
        let (mut views, mut skipped) = crop(rig, &roi, &sensors, &pre_aligned, settings);
        let mut roi = roi;
        let mut roi_source = if rig.roi.is_some() { RoiSource::Given } else { RoiSource::Overlap };
        if rig.roi.is_none() {
            let reference = reference_points(&views, r);
            if let Some((around, found)) =
                roi_around_targets(&settings.target, &reference, ground.as_ref(), &roi)
            {
                roi = around;
                roi_source = RoiSource::Targets { found };
                (views, skipped) = crop(rig, &roi, &sensors, &pre_aligned, settings);
            }
        }
        for (s, name) in sensors.iter().enumerate() {
            if !views.iter().any(|v| v.sensor == s) {
                // Points it has, but none in the region its start gave: say where to look.
                let own = rig.scans.iter().filter(|v| v.sensor == *name);
                let seen = own.flat_map(|v| &v.points).any(is_valid_point);
                return Err(if roi_source == RoiSource::Overlap && seen {
                    CalibError::OutsideOverlap(name.clone())
                } else {
                    CalibError::NoPointsInRoi(name.clone())
                });
            }
        }
        let pairs = frame_pairs(&views, sensors.len(), r);
        for (s, name) in sensors.iter().enumerate() {
            if pairs[s].is_empty() {
                return Err(CalibError::NoCommonFrames(name.clone()));
            }
        }
        let reference = reference_points(&views, r);
        let placements =
            place_targets(&settings.target, &stages, &reference, ground.as_ref(), &roi)?;
        let same_scans = same_scans(rig);
        Ok(Self {
            settings: settings.clone(),
            stages,
            sensors,
            reference: r,
            nominals,
            levelling,
            global,
            levelled,
            pre_aligned,
            views,
            skipped,
            pairs,
            ground,
            placements,
            same_scans,
            roi,
            roi_source,
            scenes,
            hypotheses,
            start,
        })
    }

    /// The region of interest the views were cropped to (the rig's, or where the clouds
    /// overlap).
    pub fn roi(&self) -> &Aabb {
        &self.roi
    }

    /// Sensor names, in result order.
    pub fn sensors(&self) -> &[String] {
        &self.sensors
    }

    /// The stages this calibration runs.
    pub fn stages(&self) -> &Stages {
        &self.stages
    }

    /// The cropped, pre-aligned views' points, numbered as JRMPC's views and the frame pairs'
    /// view indices number them.
    pub fn clouds(&self) -> Vec<&[[f32; 3]]> {
        self.views.iter().map(|v| v.cloud.points.as_slice()).collect()
    }

    /// JRMPC's input: every view, the target's surface at their centroid, EM's settings.
    pub fn jrmpc_input(&self) -> JrmpcInput<'_> {
        let settings = &self.settings;
        let clouds = self.clouds();
        let centre =
            crate::cloud::centroid(clouds.iter().flat_map(|c| c.iter())).unwrap_or([0.0; 3]);
        let means = match settings.target {
            // No target: the mixture starts on the scene itself, an even sample of its points.
            Target::None => {
                let all: Vec<&[f32; 3]> = clouds.iter().flat_map(|c| c.iter()).collect();
                let stride = all.len().div_ceil(settings.components.max(1)).max(1);
                all.iter().step_by(stride).map(|p| p.map(f64::from)).collect()
            }
            // A CAD model: samples on every copy placed, the components shared among them.
            Target::Mesh(ref m) if !self.placements.is_empty() => {
                let copies = self.placements.len();
                (0..copies)
                    .flat_map(|c| {
                        let k = settings.components / copies
                            + usize::from(c < settings.components % copies);
                        let pose = self.placements[c].pose;
                        m.mesh.sample(k, settings.seed.wrapping_add(c as u64)).into_iter().map(
                            move |p| {
                                let q = pose * nalgebra::Point3::from(p);
                                [q.x, q.y, q.z]
                            },
                        )
                    })
                    .collect()
            }
            _ => settings.target.surface(settings.components, centre, settings.seed),
        };
        let jrmpc_settings = jrmpc::EmSettings {
            initial_sigma: match settings.initial_sigma {
                InitialSigma::TargetSize => settings.target.size(),
                InitialSigma::BoundingBox => None,
                InitialSigma::Fixed(sigma) => Some(sigma),
            },
            tolerance: self.stages.em.tolerance,
            multiresolution: self.stages.em.multiresolution,
            ..settings.jrmpc.clone()
        };
        JrmpcInput { clouds, means, settings: jrmpc_settings }
    }

    /// EM started on [`Views::jrmpc_input`], and the views' centred points for its shards.
    pub fn start_jrmpc(&self) -> Result<(Em, jrmpc::CentredViews), CalibError> {
        let input = self.jrmpc_input();
        Ok(Em::start(&input.clouds, &input.means, &input.settings)?)
    }

    /// The running correction per sensor from JRMPC's views' poses: the mean over frames of
    /// `T_ref,f^-1 T_s,f`, levelling included.
    pub fn jrmpc_corrections(&self, poses: &[Pose]) -> Vec<Pose> {
        self.pairs
            .iter()
            .zip(&self.levelled)
            .map(|(frames, levelled)| {
                let per_frame: Vec<Pose> =
                    frames.iter().map(|&(r, s)| poses[r].inverse() * poses[s]).collect();
                super::average::average(&per_frame).map_or_else(Pose::identity, |(c, _)| c)
                    * levelled
            })
            .collect()
    }

    /// Corrections of the pre-aligned clouds, one per sensor, as the caller sees them: of the
    /// nominal pre-alignment, levelling included.
    pub fn levelled(&self, corrections: &[Pose]) -> Vec<Pose> {
        corrections.iter().zip(&self.levelled).map(|(c, l)| c * l).collect()
    }

    /// The frame pairs to register, when the stages register them: from each start the
    /// stages name — `registration`'s corrections (`gmm`, `cad`), the chosen start, the
    /// nominal.
    pub fn frame_pairs(&self, registration: Option<&Registration>) -> Option<FramePairs> {
        let settings = self.stages.pairs.clone()?;
        let ground = self.reference_ground().filter(|_| self.stages.ground_normals);
        let starts: Vec<(PairStart, Vec<PairCorrections>)> = (self.stages.pair_starts.iter())
            .filter_map(|&origin| match origin {
                PairStart::Registration => {
                    registration.map(|reg| (origin, jrmpc_per_pair(&self.pairs, reg)))
                }
                PairStart::Start => Some((origin, Vec::new())),
                // The pre-alignment undone: the nominal as given.
                PairStart::Nominal => Some((origin, self.per_pair(|s| self.levelled[s].inverse()))),
            })
            .collect();
        let icp = PairIcp { settings, ground };
        Some(FramePairs::new(icp, &self.pairs, self.reference, &starts))
    }

    /// Every frame pair's correction `of` its sensor.
    pub(super) fn per_pair(&self, of: impl Fn(usize) -> Pose) -> Vec<PairCorrections> {
        (self.pairs.iter().enumerate())
            .map(|(s, frames)| frames.iter().map(|&pair| (pair, of(s))).collect())
            .collect()
    }

    /// The reference's levelled ground plane and the band whose points take its normal.
    pub(super) fn reference_ground(&self) -> Option<(Plane, f64)> {
        let ground = self.levelling.get(self.reference).and_then(|l| l.ground)?;
        Some((ground, self.settings.ground.normal_band))
    }
}

/// Per sensor, JRMPC's correction of each of its frame pairs: `T_ref,f^-1 T_s,f`.
pub(super) fn jrmpc_per_pair(
    pairs: &[Vec<(usize, usize)>],
    registration: &Registration,
) -> Vec<PairCorrections> {
    let poses = &registration.poses;
    pairs
        .iter()
        .map(|p| p.iter().map(|&(r, s)| ((r, s), poses[r].inverse() * poses[s])).collect())
        .collect()
}

/// Each scan pre-aligned by its sensor's pose and cropped to the ROI; scans left with too few
/// points are noted instead.
fn crop(
    rig: &Rig,
    roi: &Aabb,
    sensors: &[String],
    poses: &[Pose],
    settings: &Settings,
) -> (Vec<View>, Vec<Note>) {
    let mut views = Vec::new();
    let mut skipped = Vec::new();
    for scan in &rig.scans {
        let s = sensors.iter().position(|n| n == &scan.sensor).unwrap_or(0);
        let cloud = thinned_to(
            Cloud::from_points(scan.points.clone()).transformed(&poses[s]).cropped(roi),
            settings.max_view_points,
        );
        let distinct = cloud.points.iter().any(|p| p != &cloud.points[0]);
        let needed = settings.min_view_points.max(3);
        if cloud.len() < needed || !distinct {
            let kind = if scan.points.is_empty() {
                NoteKind::NoValidPoints
            } else if distinct || cloud.is_empty() {
                NoteKind::TooFewPoints { points: cloud.len(), needed }
            } else {
                NoteKind::PointsCoincide
            };
            let frame = Some(scan.frame.clone());
            skipped.push(Note { sensor: scan.sensor.clone(), frame, kind });
            continue;
        }
        views.push(View { sensor: s, frame: scan.frame.clone(), cloud });
    }
    (views, skipped)
}

/// `cloud` thinned to voxel centroids, the voxel growing from 1 cm, until it holds at most
/// `most` points; unchanged when it already does.
fn thinned_to(cloud: Cloud, most: usize) -> Cloud {
    let mut voxel = 0.01;
    let mut thinned = cloud;
    while thinned.len() > most.max(1) {
        thinned = thinned.voxel_downsampled(voxel);
        voxel *= 1.5;
    }
    thinned
}

/// A sensor's root hypotheses: its nominal, then the global stage's candidates (its best
/// overlay, then the runners-up) when it aligned the sensor.
fn roots(global: Option<&GlobalAlignment>) -> Vec<Hypothesis> {
    let root = |source, correction| Hypothesis::new(source, correction, None);
    let mut roots = vec![root(Source::Nominal, Pose::identity())];
    let Some(g) = global.filter(|g| g.skipped.is_none()) else { return roots };
    roots.push(root(Source::Global { rank: 0 }, g.applied));
    if let Some(overlay) = &g.overlay {
        // The runners-up were searched after the same levelling as the best.
        let level = overlay.best.applied.inverse() * g.applied;
        for (k, runner) in overlay.runners_up.iter().enumerate() {
            roots.push(root(Source::Global { rank: k + 1 }, runner.applied * level));
        }
    }
    roots
}

/// Global candidates levelled besides the start: a levelling costs about as much as scoring
/// every candidate, so the candidates are scored first and the best few levelled.
const LEVELLED_CANDIDATES: usize = 5;

/// The indices of the `count` best-scored global candidates among `hypotheses` (ties to the
/// earlier).
fn best_scored(hypotheses: &[Hypothesis], count: usize) -> Vec<usize> {
    let mut global: Vec<usize> = (0..hypotheses.len())
        .filter(|&k| matches!(hypotheses[k].source, Source::Global { .. }))
        .collect();
    let value = |k: usize| hypotheses[k].score.value();
    global.sort_by(|&a, &b| value(b).total_cmp(&value(a)).then(a.cmp(&b)));
    global.truncate(count);
    global
}

/// A sensor's hypothesis levelled from its hypothesis `parent` by `l`, when `l` moved it;
/// `levelled` keeps which levelling each such hypothesis came from.
fn add_levelled(
    hypotheses: &mut Vec<Hypothesis>,
    levelled: &mut Vec<(usize, Levelling)>,
    parent: usize,
    l: Levelling,
) {
    if l.skipped.is_none() && l.motion != Pose::identity() {
        let correction = l.motion * hypotheses[parent].correction;
        levelled.push((hypotheses.len(), l));
        hypotheses.push(Hypothesis::new(Source::Levelled, correction, Some(parent)));
    }
}

/// Each sensor's scans, frame by frame, in its own frame: (frame name, points).
fn frame_scans<'a>(rig: &'a Rig, sensors: &[String]) -> Vec<FrameScans<'a>> {
    sensors
        .iter()
        .map(|name| {
            let own = rig.scans.iter().filter(|v| &v.sensor == name);
            own.map(|v| (v.frame.as_str(), v.points.as_slice())).collect()
        })
        .collect()
}

/// Each sensor's points over all its scans, in its own frame.
fn sensor_scans(rig: &Rig, sensors: &[String]) -> Vec<Vec<[f32; 3]>> {
    sensors
        .iter()
        .map(|name| {
            let own = rig.scans.iter().filter(|v| &v.sensor == name);
            own.flat_map(|v| v.points.iter().copied()).collect()
        })
        .collect()
}

/// Sensor `r`'s views' points (vehicle frame, cropped), borrowed: copied together only where a
/// target model is placed in them.
fn reference_points(views: &[View], r: usize) -> Vec<&[[f32; 3]]> {
    views.iter().filter(|v| v.sensor == r).map(|v| v.cloud.points.as_slice()).collect()
}

/// For each sensor, the (reference view, sensor view) index pairs of the frames both have.
fn frame_pairs(views: &[View], sensors: usize, r: usize) -> Vec<Vec<(usize, usize)>> {
    let mut pairs = vec![Vec::new(); sensors];
    for (i, view) in views.iter().enumerate() {
        if let Some(j) = views.iter().position(|u| u.sensor == r && u.frame == view.frame) {
            pairs[view.sensor].push((j, i));
        }
    }
    pairs
}

/// Pairs (sensor, other sensor) where a scan of the first is, point for point, a scan of the
/// second: the same sensor picked twice. Compared by a hash of the points' bits.
fn same_scans(rig: &Rig) -> Vec<(String, String)> {
    use std::collections::HashMap;
    use std::hash::{DefaultHasher, Hash, Hasher};
    let mut seen: HashMap<u64, &str> = HashMap::new();
    let mut found: Vec<(String, String)> = Vec::new();
    for scan in rig.scans.iter().filter(|s| !s.points.is_empty()) {
        let mut hasher = DefaultHasher::new();
        scan.points.iter().flatten().for_each(|c| c.to_bits().hash(&mut hasher));
        let key = hasher.finish();
        match seen.get(&key) {
            Some(&other) if other != scan.sensor => {
                if !found.iter().any(|(s, _)| *s == scan.sensor) {
                    found.push((scan.sensor.clone(), other.to_string()));
                }
                if !found.iter().any(|(s, _)| s == other) {
                    found.push((other.to_string(), scan.sensor.clone()));
                }
            }
            Some(_) => {}
            None => {
                seen.insert(key, &scan.sensor);
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    use super::*;
    use crate::jrmpc::Mixture;
    use crate::twin::{Miscalibration, Model, Preset, Twin};

    /// A JRMPC registration whose views of the second sensor are turned by `angle` about the
    /// vehicle's x axis (through the ground).
    fn turned(views: &Views, angle: f64) -> Registration {
        let turn = Pose::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), angle),
        );
        let poses = views
            .views
            .iter()
            .map(|v| if v.sensor == views.reference { Pose::identity() } else { turn })
            .collect();
        let mixture = Mixture { means: Vec::new(), variances: Vec::new(), priors: Vec::new() };
        let (iterations, converged, cancelled) = (1, false, false);
        Registration {
            poses,
            mixture,
            iterations,
            converged,
            cancelled,
            unsupported: Vec::new(),
            history: Vec::new(),
        }
    }

    /// A JRMPC registration folded over about an axis in the levelled ground is a hypothesis
    /// like any other: its refinement lands the scans worse than the refinement from the
    /// start, and the selection takes the latter; the result is the truth's.
    #[test]
    fn a_folded_jrmpc_result_loses_the_selection() {
        let twin = Twin::new(&Model::RayCast(Preset::paper()), 2, 1, &Miscalibration::default());
        let settings = Settings { align_globally: Some(false), ..Settings::default() };
        let views = Views::new(&twin.rig(), Method::Gmm, &settings).expect("views");
        let folded = turned(&views, std::f64::consts::PI);
        let mut pairs = views.frame_pairs(Some(&folded)).expect("gmm pairs");
        let count = pairs.pairs().len();
        pairs.run(&views.clouds(), 0..count, 1, &mut |_| crate::jrmpc::Control::Continue);
        let c = super::super::finish::finish(views, Some(folded), Some(pairs)).expect("finished");
        let chosen = c.selection[0].chosen();
        assert!(!matches!(chosen.source, Source::Jrmpc | Source::Refined), "{:?}", chosen.source);
        let error = twin.correction(1).inverse() * c.sensors[1].correction;
        let (angle, distance) = (error.rotation.angle(), error.translation.vector.norm());
        assert!(angle < 0.1f64.to_radians() && distance < 0.01, "{angle} rad, {distance} m");
    }

    /// Without a ROI, the paper twin's full scans are cropped around the four cubes found
    /// (the three calibration cubes at 12.3 m and the validation cube at 18.3 m), not to the
    /// whole overlap; without a target, to the overlap.
    #[test]
    fn without_a_roi_the_region_is_around_the_targets_found() {
        let twin = Twin::new(&Model::RayCast(Preset::paper()), 1, 1, &Miscalibration::default());
        let mut rig = twin.rig();
        rig.roi = None;
        let settings = Settings { align_globally: Some(false), ..Settings::default() };
        let roi = *Views::new(&rig, Method::Gmm, &settings).expect("views").roi();
        let none = Settings { target: Target::None, ..settings };
        let overlap = *Views::new(&rig, Method::Gmm, &none).expect("views").roi();
        eprintln!("around the targets {roi:?}, overlap {overlap:?}");
        let cubes = [[12.3, -1.5], [12.3, 0.0], [12.3, 1.5], [18.3, 0.0]];
        assert!(cubes.iter().all(|c| roi.contains([c[0], c[1], 0.25])), "{roi:?}");
        assert!(roi.max[0] - roi.min[0] < 10.0 && roi.max[1] - roi.min[1] < 8.0, "{roi:?}");
        assert!(roi.min[2] > -1.0 && roi.max[2] < 1.5, "{roi:?}");
        assert!(overlap.max[0] - overlap.min[0] > 30.0, "{overlap:?}");
    }
}
