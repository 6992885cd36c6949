//! Yaw and in-plane shift over the whole range, seen from above: after levelling, the yaw about
//! the ground normal through the sensor and the shift along the ground that best overlay a
//! sensor's above-ground structure on the reference's.
//!
//! Coarse to fine:
//! 1. coarse (0.5 m cells, 2 deg): for every yaw over the full turn, the FFT cross-correlation
//!    of the sensor's occupancy grid with the reference's (blurred) gives the score of every
//!    shift at once; two yaws share one complex FFT (one in the real part, one in the
//!    imaginary part, since both grids are real). The reference's closeness is quantised to
//!    integer steps and the transforms run in f64, so every correlation is an exact integer
//!    after rounding: the peaks and their order are the same on every platform (an f32
//!    transform's rounding differs between native SIMD and wasm, and reordered near-ties);
//! 2. fine (0.1 m cells, 0.25 deg): a direct search around each distinct coarse peak;
//! 3. the best, and the runners-up that are distinct from it (another yaw or shift), each with
//!    its score: a symmetric scene (cubes in a row, a corridor) shows as a runner-up scoring
//!    close to the best, and is reported rather than guessed.
//!
//! The score of a candidate is the share of the sensor's occupied cells that land on the
//! reference's structure, each weighted by its closeness to the nearest occupied reference cell
//! (1 on it): occupancy, not point counts, because the sensors sample the same surfaces at
//! different densities.

use std::sync::Arc;

use nalgebra::{Unit, UnitQuaternion, Vector2, Vector3};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

use super::shifts::{Rows, raise_closeness, shift_scores, shifts};
use crate::plane::{GroundFrame, Plane};
use crate::se3::{Pose, rotation_about};

/// The search range and resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CorrelateSettings {
    /// Points between these heights above the reference's ground (m) count as structure.
    pub heights: [f64; 2],
    /// Sensor structure within this distance of the sensor, along the ground, is used (m).
    pub radius: f64,
    /// Largest in-plane shift of the sensor searched (m), per axis, either side. A yaw error
    /// about the vehicle's origin moves a sensor mounted metres from it by twice as much.
    pub max_shift: f64,
    /// Coarse stage: cell edge (m; also the blur's standard deviation) and yaw step (rad) over
    /// the full turn.
    pub coarse_cell: f64,
    pub coarse_yaw_step: f64,
    /// Fine stage: cell edge (m; the shift step), blur (m) and yaw step (rad).
    pub fine_cell: f64,
    pub fine_blur: f64,
    pub fine_yaw_step: f64,
    /// Runners-up reported besides the best, each a hypothesis the selection scores (the best
    /// five of them levelled). A narrow unit's right overlay ranks below overlays that pile its
    /// view onto its neighbour's: on the `mid100` twin eight put the `left` unit in the right
    /// basin in 8 of 10 tape-measure trials where four did in 2, for 14 % on GMMCalib's cube
    /// sample. The low-ranked ones tie closely; the coarse stage's exact sums keep their order
    /// the same in native code and wasm.
    pub runners_up: usize,
    /// Two candidates are distinct when their yaws differ by more than this (rad) or they put
    /// the centroid of the sensor's structure more than `distinct_shift` (m) apart (a yaw and a
    /// shift trade against each other for structure far from the sensor).
    pub distinct_yaw: f64,
    pub distinct_shift: f64,
    /// Candidates scoring within this share of the best are as good as it; among them the one
    /// that moves the sensor least is taken. The nominal is evidence too: in a sparse scene
    /// (the paper twin's cubes) a placement a cube's spacing away can score a few percent
    /// higher than the true one, and the local search cannot undo a metre.
    pub as_good: f64,
}

impl Default for CorrelateSettings {
    fn default() -> Self {
        Self {
            heights: [0.2, 3.0],
            radius: 30.0,
            max_shift: 6.0,
            coarse_cell: 0.5,
            coarse_yaw_step: 2f64.to_radians(),
            fine_cell: 0.1,
            fine_blur: 0.15,
            fine_yaw_step: 0.25f64.to_radians(),
            runners_up: 8,
            distinct_yaw: 15f64.to_radians(),
            distinct_shift: 1.0,
            as_good: 0.05,
        }
    }
}

/// One candidate overlay.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Yaw about the ground normal through the sensor (rad, in (-pi, pi]).
    pub yaw: f64,
    /// Shift of the sensor along the ground (m, vehicle frame).
    pub shift: Vector3<f64>,
    /// The motion: the yaw about the sensor, then the shift.
    pub applied: Pose,
    /// Share (0..=1) of the sensor's occupied fine cells on the reference's structure,
    /// closeness-weighted.
    pub score: f64,
}

/// What the search found: the best and the distinct runners-up, best first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct YawShift {
    pub best: Candidate,
    pub runners_up: Vec<Candidate>,
    /// The sensor's occupied fine cells (structure within the radius).
    pub cells: usize,
}

impl YawShift {
    /// The best runner-up's score over the best's (0 when there is none): near 1, the scene
    /// allows another overlay almost as good.
    pub fn ambiguity(&self) -> f64 {
        self.runners_up.first().map_or(0.0, |r| r.score / self.best.score.max(1e-12))
    }
}

/// The yaw about the ground normal through `pivot` (the sensor's position) and the shift along
/// the ground that best overlay `points`' structure on `reference`'s, over every yaw and every
/// shift within `max_shift`. Both point sets are in the vehicle frame, levelled onto `ground`
/// (the reference's). `None` when either shows no structure above the ground.
pub fn search(
    points: &[Vector3<f64>],
    reference: &[Vector3<f64>],
    ground: &Plane,
    pivot: &Vector3<f64>,
    settings: &CorrelateSettings,
) -> Option<YawShift> {
    let along = GroundFrame::new(*ground);
    let centre = along.along(pivot);
    // Plane coordinates relative to the sensor, within `radius` of it.
    let near = |points: &[Vector3<f64>], radius: f64| -> Vec<Vector2<f64>> {
        let relative = along.structure(points, settings.heights).into_iter().map(|p| p - centre);
        relative.filter(|p| p.norm() <= radius).collect()
    };
    let reach = settings.radius + settings.max_shift + 2.0 * settings.coarse_cell;
    let source = near(points, settings.radius);
    let target = near(reference, reach);
    if source.is_empty() || target.is_empty() {
        return None;
    }
    // 1. Coarse, over the full turn.
    let middle = source.iter().sum::<Vector2<f64>>() / source.len() as f64;
    let coarse = coarse_peaks(&source, &target, reach, &middle, settings);
    // 2. Fine, around each distinct coarse peak.
    let fine = Grid::closeness(&target, reach, settings.fine_cell, settings.fine_blur);
    let cells = dedup(&source, settings.fine_cell * 0.5);
    // The unchanged placement is a candidate too.
    let unchanged = std::iter::once((0.0, 0.0, Vector2::zeros()));
    let mut refined: Vec<(f64, f64, Vector2<f64>)> = coarse
        .iter()
        .copied()
        .chain(unchanged)
        .map(|(_, yaw, shift)| refine(&cells, &fine, yaw, shift, settings))
        .collect();
    refined.sort_by(|a, b| b.0.total_cmp(&a.0));
    // Among the candidates as good as the best, the smallest motion (the displacement it gives
    // the structure's centroid) first.
    let top = refined.first().map_or(0.0, |c| c.0);
    let moved = |(_, yaw, shift): &(f64, f64, Vector2<f64>)| {
        let (sin, cos) = yaw.sin_cos();
        let turned = Vector2::new(cos * middle.x - sin * middle.y, sin * middle.x + cos * middle.y);
        (turned + shift - middle).norm()
    };
    let cut = refined.iter().take_while(|c| c.0 >= top * (1.0 - settings.as_good)).count();
    refined[..cut].sort_by(|a, b| moved(a).total_cmp(&moved(b)));
    // 3. The best and the distinct runners-up.
    let distinct = distinct(&refined, &middle, settings, settings.runners_up + 1);
    let candidate = |&(score, yaw, shift): &(f64, f64, Vector2<f64>)| {
        let shift = along.vector(shift);
        let rotation = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(ground.normal), yaw);
        Candidate { yaw, shift, applied: rotation_about(rotation, pivot, &shift), score }
    };
    let mut all = distinct.iter().map(candidate);
    let best = all.next()?;
    Some(YawShift { best, runners_up: all.collect(), cells: fine_cells(&cells, &fine) })
}

/// The sensor's occupied fine cells, as the score counts them.
fn fine_cells(points: &[Vector2<f64>], fine: &Grid) -> usize {
    let mut cells: Vec<[i64; 2]> = points.iter().map(|p| fine.cell_of(p)).collect();
    cells.sort_unstable();
    cells.dedup();
    cells.len()
}

/// One point per square of edge `edge`: the fine search rotates every point of the sensor for
/// every yaw, and points closer than a cell add nothing.
fn dedup(points: &[Vector2<f64>], edge: f64) -> Vec<Vector2<f64>> {
    let mut seen = std::collections::HashSet::new();
    points
        .iter()
        .copied()
        .filter(|p| seen.insert([(p.x / edge).floor() as i64, (p.y / edge).floor() as i64]))
        .collect()
}

/// A square grid of `size` cells of edge `cell`, centred on the sensor (plane coordinates
/// relative to it): cell `(i, j)` holds `[(i - size/2) cell, (j - size/2) cell)` along u, v.
struct Grid {
    cell: f64,
    size: usize,
    values: Vec<f32>,
}

impl Grid {
    fn new(reach: f64, cell: f64) -> Self {
        // Sizes with small prime factors keep the FFT fast.
        let mut size = (2.0 * reach / cell).ceil() as usize + 2;
        while !smooth(size) {
            size += 1;
        }
        Self { cell, size, values: vec![0.0; size * size] }
    }

    fn cell_of(&self, p: &Vector2<f64>) -> [i64; 2] {
        let half = (self.size / 2) as i64;
        [(p.x / self.cell).floor() as i64 + half, (p.y / self.cell).floor() as i64 + half]
    }

    /// Each cell's closeness to the nearest cell holding one of `points` ([`raise_closeness`],
    /// sigma `blur`): 1 on it.
    fn closeness(points: &[Vector2<f64>], reach: f64, cell: f64, blur: f64) -> Self {
        let mut grid = Self::new(reach, cell);
        let occupied = points.iter().map(|p| grid.cell_of(p)).collect();
        let size = [grid.size; 2];
        raise_closeness(&mut grid.values, size, occupied, blur / cell, |w| w as f32);
        grid
    }
}

fn smooth(mut n: usize) -> bool {
    for p in [2, 3, 5] {
        while n % p == 0 {
            n /= p;
        }
    }
    n == 1
}

/// A 2-D FFT of a square grid in place, by rows then columns (transposing between).
struct Fft2 {
    size: usize,
    fft: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex64>,
}

impl Fft2 {
    fn new(planner: &mut FftPlanner<f64>, size: usize, inverse: bool) -> Self {
        let fft =
            if inverse { planner.plan_fft_inverse(size) } else { planner.plan_fft_forward(size) };
        let scratch = vec![Complex64::default(); fft.get_inplace_scratch_len()];
        Self { size, fft, scratch }
    }

    /// Transforms `data` (row-major); the result is left transposed, which is undone by the
    /// inverse transform of a product of two forward results.
    fn run(&mut self, data: &mut [Complex64]) {
        self.fft.process_with_scratch(data, &mut self.scratch);
        transpose(data, self.size);
        self.fft.process_with_scratch(data, &mut self.scratch);
        transpose(data, self.size);
    }
}

fn transpose(data: &mut [Complex64], n: usize) {
    for i in 0..n {
        for j in i + 1..n {
            data.swap(i * n + j, j * n + i);
        }
    }
}

/// The coarse correlation's closeness is counted in these steps (of 1): its sums stay below
/// 2^53 by far, and their f64 transforms' errors below half a step.
const CLOSENESS_STEPS: f64 = 256.0;

/// Step 1: the coarse correlation over every yaw; the local maxima in the shift window of
/// every yaw, distinct from each other, best first, as (score, yaw, shift in plane).
fn coarse_peaks(
    source: &[Vector2<f64>],
    target: &[Vector2<f64>],
    reach: f64,
    middle: &Vector2<f64>,
    settings: &CorrelateSettings,
) -> Vec<(f64, f64, Vector2<f64>)> {
    let cell = settings.coarse_cell;
    let reference = Grid::closeness(target, reach, cell, cell);
    let n = reference.size;
    let mut planner = FftPlanner::new();
    let mut forward = Fft2::new(&mut planner, n, false);
    let mut inverse = Fft2::new(&mut planner, n, true);
    let mut spectrum: Vec<Complex64> = reference
        .values
        .iter()
        .map(|&v| Complex64::new((f64::from(v) * CLOSENESS_STEPS).round(), 0.0))
        .collect();
    forward.run(&mut spectrum);
    let window = (settings.max_shift / cell).round() as i64;
    let steps = (std::f64::consts::TAU / settings.coarse_yaw_step).round() as usize;
    let yaw_of = |k: usize| crate::se3::wrap_angle(k as f64 * std::f64::consts::TAU / steps as f64);
    let mut peaks: Vec<(f64, f64, Vector2<f64>)> = Vec::new();
    let mut data = vec![Complex64::default(); n * n];
    let scale = 1.0 / (n * n) as f64;
    for pair in (0..steps).collect::<Vec<_>>().chunks(2) {
        data.fill(Complex64::default());
        // Occupancy of each yaw's rotated structure: yaw a in the real part, b in the imaginary.
        let mut counts = [0usize; 2];
        for (part, &k) in pair.iter().enumerate() {
            let (sin, cos) = yaw_of(k).sin_cos();
            for p in source {
                let q = Vector2::new(cos * p.x - sin * p.y, sin * p.x + cos * p.y);
                let [i, j] = reference.cell_of(&q);
                let slot = &mut data[i as usize * n + j as usize];
                let value = if part == 0 { &mut slot.re } else { &mut slot.im };
                if *value == 0.0 {
                    *value = 1.0;
                    counts[part] += 1;
                }
            }
        }
        forward.run(&mut data);
        for (d, s) in data.iter_mut().zip(&spectrum) {
            *d = d.conj() * s;
        }
        inverse.run(&mut data);
        // Correlation of yaw a in the real part, of yaw b (negated) in the imaginary.
        for (part, &k) in pair.iter().enumerate() {
            let score = |a: i64, b: i64| {
                let index = a.rem_euclid(n as i64) as usize * n + b.rem_euclid(n as i64) as usize;
                let c = data[index] * scale;
                // An integer sum of closeness steps; the rounding drops the transform's error.
                let sum = (if part == 0 { c.re } else { -c.im }).round();
                sum / (CLOSENESS_STEPS * counts[part].max(1) as f64)
            };
            for a in -window..=window {
                for b in -window..=window {
                    let s = score(a, b);
                    let local = (-1..=1).all(|da| {
                        (-1..=1).all(|db| (da == 0 && db == 0) || score(a + da, b + db) <= s)
                    });
                    if local && s > 0.0 {
                        peaks.push((s, yaw_of(k), Vector2::new(a as f64, b as f64) * cell));
                    }
                }
            }
        }
    }
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    // More coarse peaks than are reported: the fine stage may reorder them.
    distinct(&peaks, middle, settings, 2 * settings.runners_up + 4)
}

/// Up to `count` entries of `sorted` (best first), each distinct from those kept before it:
/// another yaw, or another place for `middle` (the centroid of the sensor's structure).
fn distinct(
    sorted: &[(f64, f64, Vector2<f64>)],
    middle: &Vector2<f64>,
    settings: &CorrelateSettings,
    count: usize,
) -> Vec<(f64, f64, Vector2<f64>)> {
    let mut kept: Vec<(f64, f64, Vector2<f64>)> = Vec::new();
    for &c in sorted {
        if kept.len() == count {
            break;
        }
        let place = |(_, yaw, shift): &(f64, f64, Vector2<f64>)| {
            let (sin, cos) = yaw.sin_cos();
            Vector2::new(cos * middle.x - sin * middle.y, sin * middle.x + cos * middle.y) + shift
        };
        let near = kept.iter().any(|k| {
            crate::se3::wrap_angle(k.1 - c.1).abs() <= settings.distinct_yaw
                && (place(k) - place(&c)).norm() <= settings.distinct_shift
        });
        if !near {
            kept.push(c);
        }
    }
    kept
}

/// Step 2: the best yaw and shift within one coarse step of `(yaw, shift)`, on the fine grid.
fn refine(
    source: &[Vector2<f64>],
    fine: &Grid,
    yaw: f64,
    shift: Vector2<f64>,
    settings: &CorrelateSettings,
) -> (f64, f64, Vector2<f64>) {
    let yaw_steps = (settings.coarse_yaw_step / settings.fine_yaw_step).ceil() as i64;
    let window = (settings.coarse_cell / settings.fine_cell).ceil() as i64 + 1;
    let base = [shift.x, shift.y].map(|c| (c / fine.cell).round() as i64);
    let mut best = (f64::NEG_INFINITY, yaw, shift);
    // Each occupied cell once, weighted 1 (the score is the share of them on the reference).
    let mut cells: Vec<([i64; 2], f32)> = Vec::with_capacity(source.len());
    let mut marks = Vec::new();
    let mut scores = Vec::new();
    let grid = Rows { values: &fine.values, rows: fine.size, columns: fine.size };
    for k in -yaw_steps..=yaw_steps {
        let candidate = yaw + k as f64 * settings.fine_yaw_step;
        let (sin, cos) = candidate.sin_cos();
        cells.clear();
        cells.extend(source.iter().map(|p| {
            (fine.cell_of(&Vector2::new(cos * p.x - sin * p.y, sin * p.x + cos * p.y)), 1.0)
        }));
        sort_unique(&mut cells, fine.size, &mut marks);
        let norm = 1.0 / cells.len().max(1) as f64;
        shift_scores(&grid, &cells, base, window, &mut scores);
        for (&score, [a, b]) in scores.iter().zip(shifts(base, window)) {
            let score = score as f64 * norm;
            if score > best.0 {
                let shift = Vector2::new(a as f64, b as f64) * fine.cell;
                best = (score, crate::se3::wrap_angle(candidate), shift);
            }
        }
    }
    best
}

/// Sorts `cells` (each weighted 1) and drops repeats. Where every cell lies on the `size` x
/// `size` grid, through a bitmap of it instead of a sort; `marks` is the bitmap, reused and
/// left cleared.
fn sort_unique(cells: &mut Vec<([i64; 2], f32)>, size: usize, marks: &mut Vec<u64>) {
    let on_grid = |c: &[i64; 2]| c.iter().all(|&x| (0..size as i64).contains(&x));
    if !cells.iter().all(|c| on_grid(&c.0)) {
        cells.sort_unstable_by_key(|c| c.0);
        cells.dedup_by_key(|c| c.0);
        return;
    }
    marks.resize((size * size).div_ceil(64), 0);
    let (mut first, mut last) = (usize::MAX, 0);
    for (c, _) in cells.iter() {
        let k = c[0] as usize * size + c[1] as usize;
        marks[k / 64] |= 1 << (k % 64);
        (first, last) = (first.min(k / 64), last.max(k / 64));
    }
    cells.clear();
    for (w, word) in marks.iter_mut().enumerate().take(last + 1).skip(first) {
        let mut bits = std::mem::take(word);
        while bits != 0 {
            let k = w * 64 + bits.trailing_zeros() as usize;
            cells.push(([(k / size) as i64, (k % size) as i64], 1.0));
            bits &= bits - 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    #[test]
    fn unique_cells_come_sorted_with_or_without_the_bitmap() {
        let mut rng = Pcg64::seed_from_u64(5);
        let size = 70;
        let mut marks = Vec::new();
        // On the grid (the bitmap), then with one cell off it (the sort), repeats in both.
        for range in [0..size as i64, -1..size as i64] {
            for _ in 0..3 {
                let mut cells: Vec<([i64; 2], f32)> = (0..900)
                    .map(|_| {
                        ([rng.random_range(range.clone()), rng.random_range(0..size as i64)], 1.0)
                    })
                    .collect();
                let mut expected = cells.clone();
                expected.sort_unstable_by_key(|c| c.0);
                expected.dedup_by_key(|c| c.0);
                sort_unique(&mut cells, size, &mut marks);
                assert_eq!(cells, expected);
                assert!(marks.iter().all(|&w| w == 0), "the bitmap is left cleared");
            }
        }
    }

    /// A yard seen from above: a wall, an L-shaped building, poles and parked cars (outlines at
    /// several heights) and ground, around the origin; seeded clutter.
    fn yard(seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut points = Vec::new();
        let segment = |a: [f64; 2], b: [f64; 2], top: f64, points: &mut Vec<Vector3<f64>>| {
            let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05) as usize;
            for t in 0..=n {
                let f = t as f64 / n.max(1) as f64;
                for z in [0.5, 1.0, top] {
                    points.push(Vector3::new(
                        a[0] + f * (b[0] - a[0]),
                        a[1] + f * (b[1] - a[1]),
                        z,
                    ));
                }
            }
        };
        segment([-15.0, 9.0], [12.0, 9.0], 2.5, &mut points);
        segment([8.0, -12.0], [18.0, -12.0], 2.5, &mut points);
        segment([18.0, -12.0], [18.0, -2.0], 2.5, &mut points);
        for [x, y] in [[3.0, -6.0], [-9.0, -7.0]] {
            segment([x, y], [x + 4.5, y], 1.4, &mut points);
            segment([x, y + 1.8], [x + 4.5, y + 1.8], 1.4, &mut points);
        }
        for _ in 0..12 {
            let (x, y) = (rng.random_range(-20.0..20.0), rng.random_range(-15.0..15.0));
            segment([x, y], [x + 0.1, y], 2.5, &mut points);
        }
        for _ in 0..3000 {
            points.push(Vector3::new(
                rng.random_range(-20.0..20.0),
                rng.random_range(-15.0..15.0),
                0.0,
            ));
        }
        points
    }

    fn moved(points: &[Vector3<f64>], motion: &Pose) -> Vec<Vector3<f64>> {
        points.iter().map(|p| (motion * Point3::from(*p)).coords).collect()
    }

    #[test]
    fn recovers_a_large_yaw_and_shift() {
        let reference = yard(1);
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let sensor = Vector3::new(1.0, 0.5, 1.6);
        for (k, (yaw, shift)) in
            [(157f64, [2.7, -3.1]), (-95.0, [-3.5, 1.2]), (33.0, [0.4, 3.8])].iter().enumerate()
        {
            // The sensor's view (its own scan of the same yard) under the wrong pose.
            let rotation = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw.to_radians());
            let error = rotation_about(rotation, &sensor, &Vector3::new(shift[0], shift[1], 0.0));
            let seen = moved(&yard(10 + k as u64), &error);
            let pivot = (error * Point3::from(sensor)).coords;
            let found =
                search(&seen, &reference, &ground, &pivot, &CorrelateSettings::default()).unwrap();
            let left = found.best.applied * error;
            assert!(left.rotation.angle() < 0.3f64.to_radians(), "{k}: {found:?}");
            let at = |p: Vector3<f64>| ((left * Point3::from(p)).coords - p).norm();
            assert!(at(sensor) < 0.15 && at(Vector3::new(15.0, 0.0, 0.0)) < 0.2, "{k}: {found:?}");
            assert!(found.best.score > 0.8, "{k}: {found:?}");
            assert!(found.ambiguity() < 0.8, "{k}: {found:?}");
        }
    }

    #[test]
    fn a_row_of_identical_cubes_reports_the_shifted_overlays() {
        // Three identical 0.5 m cubes in a row, 1.5 m apart: shifted by one spacing, two of the
        // three still overlay.
        let mut reference = Vec::new();
        for y in [-1.5, 0.0, 1.5] {
            for t in 0..26 {
                let e = -0.25 + 0.02 * t as f64;
                for [dx, dy] in [[e, -0.25], [e, 0.25], [-0.25, e], [0.25, e]] {
                    for z in [0.25, 0.45] {
                        reference.push(Vector3::new(12.0 + dx, y + dy, z));
                    }
                }
            }
        }
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let pivot = Vector3::new(0.0, 0.0, 1.6);
        let found =
            search(&reference, &reference, &ground, &pivot, &CorrelateSettings::default()).unwrap();
        // Where a candidate puts the middle cube (12 m ahead: a yaw and a shift trade there).
        let middle = |c: &Candidate| (c.applied * Point3::new(12.0, 0.0, 0.3)).coords;
        assert!(found.best.score > 0.95, "{found:?}");
        assert!((middle(&found.best) - Vector3::new(12.0, 0.0, 0.3)).norm() < 0.1, "{found:?}");
        // The runners-up: one spacing either way along the row, 2 of 3 cubes overlaid.
        let shifted: Vec<&Candidate> = found
            .runners_up
            .iter()
            .filter(|c| {
                let m = middle(c);
                c.yaw.abs() < 3f64.to_radians()
                    && (m.y.abs() - 1.5).abs() < 0.15
                    && (m.x - 12.0).abs() < 0.15
            })
            .collect();
        assert_eq!(shifted.len(), 2, "{found:?}");
        for c in &shifted {
            assert!((c.score - 2.0 / 3.0).abs() < 0.1, "{c:?}");
        }
        assert!(found.ambiguity() > 0.6, "{found:?}");
    }
}
