//! The selection score: how much of each sensor's structure lands on the other sensors'
//! surfaces, both ways, over the whole of their scans of the same instants. A point lands when
//! a surface of the other scan lies within that surface's own sampling distance of it; how
//! well it lands is a Gaussian of its distance along the surface normal, in units of the two
//! neighbourhoods' measured thickness (noise and curvature together), so a sparse 32-beam pair
//! and a dense solid-state pair are judged alike.

use nalgebra::Point3;

use super::SelectSettings;
use super::surface::Surface;
use crate::se3::Pose;

/// Every sensor's scans of the frames scored, prepared once.
pub struct Scenes {
    /// Per sensor, its scored frames: (frame name, surface).
    surfaces: Vec<Vec<(String, Surface)>>,
    settings: SelectSettings,
}

/// One sensor's placement among the others, scored: per class of point (0 the scans'
/// dominant planes, 1 the rest), the weights of the points compared, overlapping and landing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorScore {
    /// Weight of the points that land on a surface, each by how well (Gaussian of its
    /// noise-scaled distance).
    pub agreeing: [f64; 2],
    /// Weight of the points with a surface of the other scan beside them.
    pub overlapping: [f64; 2],
    /// Weight of every point compared: the same for every hypothesis.
    pub total: [f64; 2],
    /// Landing weight per block and class, in a fixed order of (other sensor, frame,
    /// direction, block, class): the same layout for every hypothesis of the sensor, for the
    /// paired comparison.
    pub(crate) blocks: Vec<[f64; 2]>,
}

impl SensorScore {
    /// The share of points landing on another sensor's surface, the mean over the classes
    /// present (0..=1).
    pub fn value(&self) -> f64 {
        self.shares(&self.agreeing)
    }

    /// The share of points with another sensor's surface beside them, as [`SensorScore::value`].
    pub fn overlap(&self) -> f64 {
        self.shares(&self.overlapping)
    }

    /// The mean over the classes present of `of` over the total.
    fn shares(&self, of: &[f64; 2]) -> f64 {
        let present: Vec<usize> = (0..2).filter(|&c| self.total[c] > 0.0).collect();
        let sum: f64 = present.iter().map(|&c| of[c] / self.total[c]).sum();
        if present.is_empty() { 0.0 } else { sum / present.len() as f64 }
    }

    /// Each block's part of [`SensorScore::value`].
    fn block_values(&self) -> Vec<f64> {
        let present = (0..2).filter(|&c| self.total[c] > 0.0).count().max(1) as f64;
        let scale = self.total.map(|t| if t > 0.0 { 1.0 / (t * present) } else { 0.0 });
        self.blocks.iter().map(|b| b[0] * scale[0] + b[1] * scale[1]).collect()
    }

    /// `self` scores above `other` by more than `z` standard errors of the difference, the
    /// error taken from the spread of the per-block differences (blocks, not points, are
    /// roughly independent: neighbouring points share their surfaces' errors).
    pub fn beats(&self, other: &SensorScore, z: f64) -> bool {
        let (mine, theirs) = (self.block_values(), other.block_values());
        let n = mine.len().min(theirs.len());
        if n < 2 {
            return self.value() > other.value();
        }
        let d: Vec<f64> = (0..n).map(|b| mine[b] - theirs[b]).collect();
        let sum: f64 = d.iter().sum();
        let mean = sum / n as f64;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        sum > z * (n as f64 * var).sqrt()
    }
}

impl Scenes {
    /// Surfaces of each sensor's scans of up to `settings.frames` frames, spread over the
    /// reference's (`scans[s]`: sensor s's (frame name, points in its own frame), in the rig's
    /// order).
    pub fn new(
        scans: &[Vec<(&str, &[[f32; 3]])>],
        reference: usize,
        settings: &SelectSettings,
        threads: usize,
    ) -> Self {
        let names: Vec<&str> = scans.get(reference).map_or_else(Vec::new, |own| {
            let count = own.len();
            let wanted = settings.frames.clamp(1, count.max(1));
            (0..wanted).map(|k| own[k * count / wanted].0).collect()
        });
        let jobs: Vec<(usize, &str, &[[f32; 3]])> = scans
            .iter()
            .enumerate()
            .flat_map(|(s, own)| {
                own.iter().filter(|(f, _)| names.contains(f)).map(move |&(f, p)| (s, f, p))
            })
            .collect();
        let built = crate::on_threads(&jobs, crate::threads_here(threads), |(_, _, points)| {
            Surface::new(points, settings)
        });
        let mut surfaces: Vec<Vec<(String, Surface)>> = scans.iter().map(|_| Vec::new()).collect();
        for ((s, frame, _), surface) in jobs.into_iter().zip(built) {
            if let Some(surface) = surface {
                surfaces[s].push((frame.to_string(), surface));
            }
        }
        Self { surfaces, settings: settings.clone() }
    }

    /// Sensor `s` placed at `poses[s]` among the others at theirs (`T_vehicle_sensor` each):
    /// its points on their surfaces and theirs on its, frame by frame.
    pub fn score(&self, s: usize, poses: &[Pose]) -> SensorScore {
        let mut score = SensorScore::default();
        self.each_pair(s, poses, |source, target, t_target_source, _, _| {
            self.compare(source, target, t_target_source, &mut score)
        });
        score
    }

    /// Sensor `s`'s scored surfaces.
    pub(super) fn surfaces_of(&self, s: usize) -> impl Iterator<Item = &Surface> {
        self.surfaces.get(s).into_iter().flatten().map(|(_, surface)| surface)
    }

    /// Calls `f(source, target, T_target_source, source is s, T_vehicle_source)` for every
    /// comparison sensor `s`'s score is made of, in a fixed order: each other sensor, each
    /// frame both scanned, `s` onto the other, then the other onto `s`.
    pub(super) fn each_pair(
        &self,
        s: usize,
        poses: &[Pose],
        mut f: impl FnMut(&Surface, &Surface, &Pose, bool, &Pose),
    ) {
        let Some(own) = self.surfaces.get(s) else { return };
        for (o, theirs) in self.surfaces.iter().enumerate() {
            if o == s {
                continue;
            }
            let t_o_s = poses[o].inverse() * poses[s];
            for (frame, mine) in own {
                let Some((_, other)) = theirs.iter().find(|(f, _)| f == frame) else { continue };
                f(mine, other, &t_o_s, true, &poses[s]);
                f(other, mine, &t_o_s.inverse(), false, &poses[o]);
            }
        }
    }

    /// `source`'s samples mapped by `t_target_source` onto `target`, added to `score` (its
    /// blocks appended).
    fn compare(
        &self,
        source: &Surface,
        target: &Surface,
        t_target_source: &Pose,
        score: &mut SensorScore,
    ) {
        let at = score.blocks.len();
        score.blocks.resize(at + source.block_count, [0.0; 2]);
        for (k, &i) in source.samples.iter().enumerate() {
            let (weight, class) = (source.weights[k], source.classes[k] as usize);
            score.total[class] += weight;
            let p = source.points[i].map(f64::from);
            let q = (t_target_source * Point3::new(p[0], p[1], p[2])).coords;
            let Some(near) = target.tree.nearest_within([q.x, q.y, q.z], self.settings.max_gate)
            else {
                continue;
            };
            let j = near.index;
            // Beside the other scan's surface, within its sampling distance, or not on it.
            if near.sq_distance.sqrt() > 2.0 * target.reach[j] as f64 {
                continue;
            }
            let Some(normal) = target.normals[j] else { continue };
            score.overlapping[class] += weight;
            let x = target.points[j].map(f64::from);
            let e = normal.x * (q.x - x[0]) + normal.y * (q.y - x[1]) + normal.z * (q.z - x[2]);
            let sigma2 = (source.noise[i] as f64).powi(2) + (target.noise[j] as f64).powi(2);
            let landed = weight * (-0.5 * e * e / sigma2).exp();
            score.agreeing[class] += landed;
            score.blocks[at + source.blocks[k] as usize][class] += landed;
        }
    }
}
