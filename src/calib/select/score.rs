//! The selection score: how much of each sensor's structure lands on the other sensors'
//! surfaces, both ways, over the whole of their scans of the same instants. A point lands when
//! a surface of the other scan lies within that surface's own sampling distance of it; how
//! well it lands is a Gaussian of its distance along the surface normal, in units of the two
//! neighbourhoods' measured thickness (noise and curvature together), so a sparse 32-beam pair
//! and a dense solid-state pair are judged alike. A point that stands where the other sensor
//! saw through (well in front of every one of its rays around it) counts against, three times
//! ([`CONTRADICTION_WEIGHT`]): overlap alone would reward piling one sensor's view onto
//! another's.

use nalgebra::Point3;

use super::SelectSettings;
use super::surface::Surface;
use crate::se3::Pose;

/// What a point standing where the other sensor saw through weighs against a placement, in
/// landing points. Chance makes the two unequal. A wrong placement lands points by chance on
/// whatever broad planes both sensors see (ground, long walls: 13-18 % of the `mid100` twin's
/// `left` unit at overlays turned 90-125 deg), while a right one puts points in another's free
/// space only where the scene differs between their views (0-1.7 % at the results chosen on the
/// seven real-rig runs: one per ten landings or fewer). Weighed alike, an overlay piling a narrow
/// unit's view onto its neighbour's (18 % landing, 6 % in free space) beat the right placement
/// (3 % landing, none in free space); weighed three times, overlap gains a placement nothing
/// unless it lands more than three points for each it puts in free space, which right
/// placements do ten to a hundred times over.
pub const CONTRADICTION_WEIGHT: f64 = 3.0;

/// Every sensor's scans of the frames scored, prepared once.
pub struct Scenes {
    /// Per sensor, its scored frames: (frame name, surface).
    surfaces: Vec<Vec<(String, Surface)>>,
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
    /// Weight of the points standing in the other scan's free space (less what of them
    /// lands).
    pub contradicting: [f64; 2],
    /// Weight of every point compared: the same for every hypothesis.
    pub total: [f64; 2],
    /// Landing weight per block and class, in a fixed order of (other sensor, frame,
    /// direction, block, class): the same layout for every hypothesis of the sensor, for the
    /// paired comparison.
    pub(crate) blocks: Vec<[f64; 2]>,
}

impl SensorScore {
    /// The share of points landing on another sensor's surface less [`CONTRADICTION_WEIGHT`]
    /// times the share standing in its free space, the mean over the classes present.
    pub fn value(&self) -> f64 {
        self.shares(
            &[0, 1].map(|c| self.agreeing[c] - CONTRADICTION_WEIGHT * self.contradicting[c]),
        )
    }

    /// The share of points landing on another sensor's surface, as [`SensorScore::value`].
    pub fn landing(&self) -> f64 {
        self.shares(&self.agreeing)
    }

    /// The share of points standing where another sensor saw through, as
    /// [`SensorScore::value`].
    pub fn contradiction(&self) -> f64 {
        self.shares(&self.contradicting)
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

    /// One point of weight `weight` and class `class` in block `block`.
    fn add(
        &mut self,
        block: usize,
        class: usize,
        weight: f64,
        overlapping: bool,
        landed: f64,
        against: f64,
    ) {
        self.total[class] += weight;
        if overlapping {
            self.overlapping[class] += weight;
        }
        self.agreeing[class] += landed;
        self.contradicting[class] += against;
        self.blocks[block][class] += landed - CONTRADICTION_WEIGHT * against;
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
        // Only blocks where the two differ carry evidence: their count sets the degrees of
        // freedom, so a difference resting on a handful of blocks must be larger to count.
        let d: Vec<f64> = (0..n).map(|b| mine[b] - theirs[b]).filter(|d| *d != 0.0).collect();
        let sum: f64 = d.iter().sum();
        if d.len() < 2 {
            return false;
        }
        let m = d.len() as f64;
        let mean = sum / m;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0);
        sum > student_t(z, d.len() - 1) * (m * var).sqrt()
    }
}

/// The Student-t quantile with `df` degrees of freedom at the normal quantile `z`'s level:
/// exact for one and two degrees of freedom, Cornish-Fisher beyond (within 1 % from three).
pub(crate) fn student_t(z: f64, df: usize) -> f64 {
    let p = 0.5 * (1.0 + erf(z / std::f64::consts::SQRT_2));
    match df {
        0 => f64::INFINITY,
        1 => (std::f64::consts::PI * (p - 0.5)).tan(),
        2 => (2.0 * p - 1.0) * (2.0 / (4.0 * p * (1.0 - p))).sqrt(),
        _ => {
            let v = df as f64;
            let (z3, z5) = (z.powi(3), z.powi(5));
            z + (z3 + z) / (4.0 * v)
                + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z.powi(7) + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v.powi(3))
        }
    }
}

/// The error function (Abramowitz and Stegun 7.1.26, error below 1.5e-7).
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    (1.0 - poly * (-x * x).exp()).copysign(x)
}

/// One sensor's scans, frame by frame: (frame name, points in the sensor's frame).
pub type FrameScans<'a> = Vec<(&'a str, &'a [[f32; 3]])>;

impl Scenes {
    /// Surfaces of each sensor's scans of up to `settings.frames` frames, spread over the
    /// reference's (`scans[s]`: sensor s's (frame name, points in its own frame), in the rig's
    /// order).
    pub fn new(
        scans: &[FrameScans],
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
        Self { surfaces }
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

    /// How finely the scans place sensor `s` at `poses[s]` (the others at theirs), per axis of
    /// the vehicle frame: one sigma, rotation about x, y, z through the sensor (rad) and
    /// position along x, y, z (m). Along each axis, both ways, the smallest move after which
    /// the placement beats the moved one by `z` standard errors of the paired block test
    /// (doubled until it does, then halved back by bisection), divided by `z`. What the
    /// scans cannot tell apart they cannot tell apart, whatever a fit's curvature says.
    pub fn resolve(&self, s: usize, poses: &[Pose], z: f64) -> ([f64; 3], [f64; 3]) {
        const FIRST: [f64; 2] = [0.01 * std::f64::consts::PI / 180.0, 0.001];
        const DOUBLINGS: usize = 10;
        const BISECTIONS: usize = 3;
        let at = self.score(s, poses);
        let origin = poses[s].translation.vector;
        let moved = |axis: usize, delta: f64| -> Pose {
            let mut e = nalgebra::Vector3::zeros();
            e[axis % 3] = 1.0;
            let motion = if axis < 3 {
                let turn = nalgebra::UnitQuaternion::from_scaled_axis(e * delta);
                Pose::from_parts((origin - turn * origin).into(), turn)
            } else {
                Pose::from_parts((e * delta).into(), nalgebra::UnitQuaternion::identity())
            };
            motion * poses[s]
        };
        let told = |axis: usize, delta: f64| -> bool {
            let mut shifted = poses.to_vec();
            shifted[s] = moved(axis, delta);
            at.beats(&self.score(s, &shifted), z)
        };
        let mut sigma = [0.0; 6];
        for (axis, out) in sigma.iter_mut().enumerate() {
            let first = FIRST[axis / 3];
            let mut found = 0.0;
            for sign in [1.0, -1.0] {
                let (mut low, mut high) = (0.0, first);
                let mut steps = 0;
                while !told(axis, sign * high) && steps < DOUBLINGS {
                    (low, high) = (high, 2.0 * high);
                    steps += 1;
                }
                for _ in 0..BISECTIONS {
                    let mid = 0.5 * (low + high);
                    if told(axis, sign * mid) { high = mid } else { low = mid }
                }
                found += 0.5 * high;
            }
            *out = found / z;
        }
        ([sigma[0], sigma[1], sigma[2]], [sigma[3], sigma[4], sigma[5]])
    }

    /// The share of sensor `s`'s points with a surface of sensor `o`'s scans of the same
    /// frames beside them, each placed by `poses` (`T_vehicle_sensor`).
    pub fn overlap_with(&self, s: usize, o: usize, poses: &[Pose]) -> f64 {
        let mut score = SensorScore::default();
        let t_o_s = poses[o].inverse() * poses[s];
        for (mine, other) in self.shared_frames(s, o) {
            self.compare(mine, other, &t_o_s, &mut score);
        }
        score.overlap()
    }

    /// Sensor `s` against sensor `o` alone at two placements of every sensor (`at`, `moved`):
    /// its points on `o`'s surfaces and `o`'s on its, frame by frame, counting only the points
    /// with a surface of the other beside them at both. Whether `moved` then beats `at` is a
    /// question of how well the shared structure fits, not of how much of the scans a placement
    /// brings into overlap (a slide along the ground brings more: the `sideways` twin's two
    /// flank sensors 2.5 m along it).
    pub fn score_with(&self, s: usize, o: usize, at: &[Pose], moved: &[Pose]) -> [SensorScore; 2] {
        self.score_shared_over(s, &[o], at, moved)
    }

    /// [`Scenes::score_with`] against every other sensor: sensor `s` at two placements, judged
    /// on the structure it shares with the others at both.
    pub fn score_shared(&self, s: usize, at: &[Pose], moved: &[Pose]) -> [SensorScore; 2] {
        let others: Vec<usize> = (0..self.surfaces.len()).filter(|&o| o != s).collect();
        self.score_shared_over(s, &others, at, moved)
    }

    fn score_shared_over(
        &self,
        s: usize,
        others: &[usize],
        at: &[Pose],
        moved: &[Pose],
    ) -> [SensorScore; 2] {
        let mut scores = [SensorScore::default(), SensorScore::default()];
        for &o in others {
            self.add_shared(s, o, at, moved, &mut scores);
        }
        scores
    }

    /// Sensor `s` against sensor `o` at `at` and at `moved`, the points beside a surface of
    /// the other at both, added to `scores`.
    fn add_shared(
        &self,
        s: usize,
        o: usize,
        at: &[Pose],
        moved: &[Pose],
        scores: &mut [SensorScore; 2],
    ) {
        let t = |poses: &[Pose]| poses[o].inverse() * poses[s];
        let (t_at, t_moved) = (t(at), t(moved));
        for (mine, other) in self.shared_frames(s, o) {
            let both = [
                (mine, other, [t_at, t_moved]),
                (other, mine, [t_at.inverse(), t_moved.inverse()]),
            ];
            for (source, target, ts) in both {
                let block = scores[0].blocks.len();
                for score in scores.iter_mut() {
                    score.blocks.resize(block + source.block_count, [0.0; 2]);
                }
                for k in 0..source.samples.len() {
                    let seen = ts.map(|t| self.point(source, target, k, &t));
                    if !(seen[0].0 && seen[1].0) {
                        continue;
                    }
                    let (weight, class) = (source.weights[k], source.classes[k] as usize);
                    for (score, (_, landed, against)) in scores.iter_mut().zip(seen) {
                        let b = block + source.blocks[k] as usize;
                        score.add(b, class, weight, true, landed, against);
                    }
                }
            }
        }
    }

    /// Sensor `s`'s and sensor `o`'s surfaces of each frame both scored, in `s`'s order.
    fn shared_frames(&self, s: usize, o: usize) -> impl Iterator<Item = (&Surface, &Surface)> {
        let theirs = self.surfaces.get(o).map_or(&[][..], Vec::as_slice);
        self.surfaces.get(s).into_iter().flatten().filter_map(move |(frame, mine)| {
            theirs.iter().find(|(f, _)| f == frame).map(|(_, other)| (mine, other))
        })
    }

    /// Sensor `s`'s scored frames: (frame name, surface).
    pub(crate) fn frames_of(&self, s: usize) -> impl Iterator<Item = (&str, &Surface)> {
        self.surfaces.get(s).into_iter().flatten().map(|(f, surface)| (f.as_str(), surface))
    }

    /// Sensor `s`'s scored surfaces.
    fn surfaces_of(&self, s: usize) -> impl Iterator<Item = &Surface> {
        self.surfaces.get(s).into_iter().flatten().map(|(_, surface)| surface)
    }

    /// The finest motion (m) the score resolves for sensor `s`: the coarsest voxel its scans
    /// were thinned to. Placements closer than this are one placement to the score, whose
    /// differences there come from the thinning, not the scans.
    pub fn resolution(&self, s: usize) -> f64 {
        self.surfaces_of(s).map(|surface| surface.voxel).fold(0.0, f64::max)
    }

    /// How far apart (m, root mean square over its scored points) sensor `s`'s points lie under
    /// two placements `a` and `b` (`T_vehicle_sensor` each).
    pub fn apart(&self, s: usize, a: &Pose, b: &Pose) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        let motion = a * b.inverse();
        for surface in self.surfaces_of(s) {
            for &i in &surface.samples {
                let p = surface.points[i].map(f64::from);
                let q = b * Point3::new(p[0], p[1], p[2]);
                sum += (motion * q - q).norm_squared();
                n += 1;
            }
        }
        if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
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
        for o in (0..self.surfaces.len()).filter(|&o| o != s) {
            let t_o_s = poses[o].inverse() * poses[s];
            for (mine, other) in self.shared_frames(s, o) {
                f(mine, other, &t_o_s, true, &poses[s]);
                f(other, mine, &t_o_s.inverse(), false, &poses[o]);
            }
        }
    }

    /// `source`'s samples mapped by `t_target_source` onto `target`, added to `score` (its
    /// blocks appended).
    pub(super) fn compare(
        &self,
        source: &Surface,
        target: &Surface,
        t_target_source: &Pose,
        score: &mut SensorScore,
    ) {
        let at = score.blocks.len();
        score.blocks.resize(at + source.block_count, [0.0; 2]);
        for k in 0..source.samples.len() {
            let (weight, class) = (source.weights[k], source.classes[k] as usize);
            let (overlapping, landed, against) = self.point(source, target, k, t_target_source);
            score.add(at + source.blocks[k] as usize, class, weight, overlapping, landed, against);
        }
    }

    /// Sample `k` of `source` placed by `t_target_source` against `target`: whether a surface
    /// of it lies beside the point, how well the point lands on it and how much of its weight
    /// stands where `target` saw through.
    fn point(
        &self,
        source: &Surface,
        target: &Surface,
        k: usize,
        t_target_source: &Pose,
    ) -> (bool, f64, f64) {
        let (i, weight) = (source.samples[k], source.weights[k]);
        let p = source.points[i].map(f64::from);
        let q = (t_target_source * Point3::new(p[0], p[1], p[2])).coords;
        let (overlapping, landed) = match target.landing([q.x, q.y, q.z]) {
            Some((j, normal)) => {
                let x = target.points[j].map(f64::from);
                let e = normal.x * (q.x - x[0]) + normal.y * (q.y - x[1]) + normal.z * (q.z - x[2]);
                let sigma2 = (source.noise[i] as f64).powi(2) + (target.noise[j] as f64).powi(2);
                (true, weight * (-0.5 * e * e / sigma2).exp())
            }
            None => (false, 0.0),
        };
        // In front of the other sensor's rays by three noise widths of both scans (taken
        // alike), and by what a neighbouring ray's range differs on a surface inclined
        // 45 deg: nothing a right placement's noise or sampling explains.
        let margin = 3.0 * std::f64::consts::SQRT_2 * source.noise[i] as f64
            + q.norm() * target.sight.cell();
        let against =
            if target.sight.sees_through([q.x, q.y, q.z], margin) { weight - landed } else { 0.0 };
        (overlapping, landed, against)
    }
}

#[cfg(test)]
mod tests {
    use super::student_t;

    /// Against tables (one-sided 97.7 %, z = 2): few blocks ask for a larger difference.
    #[test]
    fn the_critical_value_grows_as_the_blocks_get_few() {
        let table = [(1, 13.97), (2, 4.53), (3, 3.31), (5, 2.65), (10, 2.28), (30, 2.08)];
        for (df, t) in table {
            let got = student_t(2.0, df);
            assert!((got - t).abs() < 0.02 * t, "df {df}: {got} against {t}");
        }
        assert!((student_t(2.0, 10_000) - 2.0).abs() < 1e-3);
    }
}
