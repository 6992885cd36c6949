//! Bird's-eye search: after levelling, the yaw and in-plane shift that best overlay a sensor's
//! above-ground structure on the reference's, found by exhaustive search over a grid.
//!
//! Why: levelling fixes roll, pitch and height; yaw and the in-plane translation are left to
//! JRMPC, whose basin is a few degrees. A yaw error of 8 deg moves targets 12 m ahead by 1.7 m,
//! further than the spacing of the paper's cubes (1.5 m): the crop then loses a cube for one
//! sensor and the registration swaps the others (docs/method.md, "Beyond the spec"). Seen from above,
//! the structure standing on the ground (targets, poles, walls) has a unique best overlay, and
//! a search over every yaw and shift in the expected error range finds it without a basin.
//!
//! The score of a candidate is the sensor's points, each weighted by its closeness to the
//! nearest cell the reference occupies (1 on it, a Gaussian of the distance off it): the
//! reference as occupancy rather than point counts, because the two sensors sample the same
//! surfaces at different densities.

use nalgebra::{Unit, UnitQuaternion, Vector2, Vector3};

use super::notes::{BevWarning, SearchRange};
use super::shifts::{Rows, raise_closeness, shift_scores, shifts};
use crate::plane::{GroundFrame, Plane};
use crate::se3::{Pose, rotation_about};

/// The search range and resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct BevSettings {
    /// Largest yaw error searched (rad), either side.
    pub max_yaw: f64,
    /// Yaw step (rad). The result is only a start for JRMPC, whose basin is a few degrees.
    pub yaw_step: f64,
    /// Largest in-plane shift of the sensor searched (m), per axis, either side.
    pub max_shift: f64,
    /// Cell size of the bird's-eye grids (m); also the shift step.
    pub cell: f64,
    /// Standard deviation of the blur on the reference's occupancy (m).
    pub blur: f64,
    /// Points between these heights above the reference's ground (m) count as structure.
    pub heights: [f64; 2],
}

impl Default for BevSettings {
    fn default() -> Self {
        Self {
            max_yaw: 10f64.to_radians(),
            yaw_step: 0.5f64.to_radians(),
            max_shift: 0.75,
            cell: 0.05,
            blur: 0.1,
            heights: [0.15, 3.0],
        }
    }
}

/// What the search found for one sensor. The result's JSON (`levelling[].bev`) is this less the
/// motion (the levelling's `motion` includes it) and the count of points searched with.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "camelCase")]
pub struct BevAlignment {
    /// Yaw about the ground normal through the sensor (rad).
    pub yaw: f64,
    /// Shift of the sensor along the ground (m, vehicle frame).
    #[cfg_attr(feature = "ts", ts(type = "[number, number, number]"))]
    pub shift: Vector3<f64>,
    /// The motion applied after levelling: the yaw about the sensor, then the shift.
    #[serde(skip)]
    pub applied: Pose,
    /// The sensor's structure points on the reference's, weighted by closeness, at the best
    /// candidate and with no change.
    pub score: f64,
    pub score_unchanged: f64,
    /// The best candidate lies on the border of the range searched (the largest yaw or shift):
    /// the sensor may be off by more than the search covers, and the true overlay lie beyond.
    pub at_edge: bool,
    /// The sensor's structure points searched with.
    #[serde(skip)]
    pub points: usize,
}

/// Below this share of a sensor's structure points on the reference's (closeness-weighted) at
/// the best candidate, the overlay is not trusted. On the twin every calibration, within the
/// spec and beyond it, ends at 0.94 or more; sensors that see different sides of the scene
/// can legitimately score lower, so this only warns.
const LOW_OVERLAP: f64 = 0.25;

/// What the user should check after the search, if anything: nothing found to overlay, an
/// overlay that lands little of the sensor's structure on the reference's, or a best candidate
/// on the border of the range (the truth may lie beyond it).
pub fn warning(found: Option<&BevAlignment>, settings: &BevSettings) -> Option<BevWarning> {
    let range = SearchRange { yaw: settings.max_yaw, shift: settings.max_shift };
    let Some(found) = found else {
        return Some(BevWarning::NothingToOverlay { range });
    };
    let share = found.score / found.points.max(1) as f64;
    if share < LOW_OVERLAP {
        return Some(BevWarning::LowOverlap { share, range });
    }
    found.at_edge.then_some(BevWarning::AtEdge { range })
}

/// The reference's blurred occupancy over a rectangle of cells.
struct Occupancy {
    origin: Vector2<f64>,
    cell: f64,
    size: [usize; 2],
    values: Vec<f64>,
}

impl Occupancy {
    fn new(points: &[Vector2<f64>], settings: &BevSettings) -> Option<Self> {
        let cell = settings.cell;
        let pad = 3.0 * settings.blur + cell;
        let mut lo = *points.first()?;
        let mut hi = lo;
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let origin = lo.add_scalar(-pad);
        let extent = hi.add_scalar(pad) - origin;
        let size = [0, 1].map(|i| (extent[i] / cell).ceil() as usize + 1);
        // A search box around a ROI is tens of metres at most; refuse absurd grids.
        if size[0] * size[1] > 16_000_000 {
            return None;
        }
        let mut grid = Self { origin, cell, size, values: vec![0.0; size[0] * size[1]] };
        // In range: the grid pads the points.
        let occupied = points.iter().map(|p| grid.cell_of(p)).collect();
        raise_closeness(&mut grid.values, size, occupied, settings.blur / cell, |w| w);
        Some(grid)
    }

    fn at(&self, i: i64, j: i64) -> f64 {
        if i < 0 || j < 0 || i >= self.size[0] as i64 || j >= self.size[1] as i64 {
            return 0.0;
        }
        self.values[i as usize * self.size[1] + j as usize]
    }

    /// The score of every shift within `steps` cells either way (see [`shift_scores`]).
    fn correlate(&self, counted: &[([i64; 2], f64)], steps: i64, scores: &mut Vec<f64>) {
        let [rows, columns] = self.size;
        let grid = Rows { values: &self.values, rows, columns };
        shift_scores(&grid, counted, [0, 0], steps, scores);
    }

    /// Index of the cell holding `p` (unbounded).
    fn cell_of(&self, p: &Vector2<f64>) -> [i64; 2] {
        [0, 1].map(|a| ((p[a] - self.origin[a]) / self.cell).floor() as i64)
    }
}

/// The yaw about the ground normal through `pivot` (the sensor's position) and the shift along
/// the ground that best overlay `points`' structure on `reference`'s. Both point sets are in
/// the vehicle frame, levelled onto `ground` (the reference's). `None` when either shows no
/// structure above the ground.
pub fn search(
    points: &[Vector3<f64>],
    reference: &[Vector3<f64>],
    ground: &Plane,
    pivot: &Vector3<f64>,
    settings: &BevSettings,
) -> Option<BevAlignment> {
    let frame = GroundFrame::new(*ground);
    let target = Occupancy::new(&frame.structure(reference, settings.heights), settings)?;
    let source = frame.structure(points, settings.heights);
    if source.is_empty() {
        return None;
    }
    let centre = frame.along(pivot);
    let yaw_steps = (settings.max_yaw / settings.yaw_step).round() as i64;
    let shift_steps = (settings.max_shift / settings.cell).round() as i64;
    // (score, yaw step, shift cells): the unchanged candidate unless another scores higher, so
    // ties (no overlap anywhere, say) keep it.
    let unchanged: f64 = source
        .iter()
        .map(|p| {
            let [i, j] = target.cell_of(p);
            target.at(i, j)
        })
        .sum();
    let mut best = (unchanged, 0, [0i64; 2]);
    let mut cells: Vec<[i64; 2]> = Vec::with_capacity(source.len());
    let mut counted: Vec<([i64; 2], f64)> = Vec::with_capacity(source.len());
    let mut scores = Vec::new();
    for k in std::iter::once(0).chain((-yaw_steps..=yaw_steps).filter(|&k| k != 0)) {
        let (sin, cos) = (k as f64 * settings.yaw_step).sin_cos();
        cells.clear();
        cells.extend(source.iter().map(|p| {
            let d = p - centre;
            target.cell_of(&(centre + Vector2::new(cos * d.x - sin * d.y, sin * d.x + cos * d.y)))
        }));
        // Every point counts once (a candidate must not gain by spreading the points over more
        // cells); points sharing a cell are looked up once.
        cells.sort_unstable();
        counted.clear();
        for cell in &cells {
            match counted.last_mut() {
                Some((last, n)) if last == cell => *n += 1.0,
                _ => counted.push((*cell, 1.0)),
            }
        }
        target.correlate(&counted, shift_steps, &mut scores);
        for (&score, shift) in scores.iter().zip(shifts([0, 0], shift_steps)) {
            if score > best.0 {
                best = (score, k, shift);
            }
        }
    }
    let (score, k, [a, b]) = best;
    let yaw = k as f64 * settings.yaw_step;
    let shift = frame.vector(Vector2::new(a as f64, b as f64)) * settings.cell;
    let rotation = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(ground.normal), yaw);
    let applied = rotation_about(rotation, pivot, &shift);
    let at_edge = (yaw_steps > 0 && k.abs() == yaw_steps)
        || (shift_steps > 0 && (a.abs() == shift_steps || b.abs() == shift_steps));
    let points = source.len();
    Some(BevAlignment { yaw, shift, applied, score, score_unchanged: unchanged, at_edge, points })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// Three 0.5 m cubes 12 m ahead (outlines, 2 cm spacing, several heights) on flat ground.
    fn cubes() -> Vec<Vector3<f64>> {
        let mut points = Vec::new();
        for (y, yaw) in [(-1.5f64, 0.0f64), (0.0, 0.35), (1.5, 0.7)] {
            let (s, c) = yaw.sin_cos();
            for t in 0..25 {
                let e = -0.25 + 0.02 * t as f64;
                for [dx, dy] in [[e, -0.25], [e, 0.25], [-0.25, e], [0.25, e]] {
                    for z in [0.2, 0.3, 0.4] {
                        points.push(Vector3::new(12.3 + c * dx - s * dy, y + s * dx + c * dy, z));
                    }
                }
            }
            // Ground around them, which the search must ignore.
            for g in 0..40 {
                points.push(Vector3::new(10.0 + 0.1 * g as f64, y + 0.7, 0.0));
            }
        }
        points
    }

    #[test]
    fn finds_a_yaw_that_moves_the_cubes_past_each_other() {
        let reference = cubes();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let sensor = Vector3::new(2.3, -0.6, 1.6);
        // The sensor's view, mis-yawed by 8 deg about itself and shifted: 1.7 m at the cubes.
        let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, 8f64.to_radians());
        let error = rotation_about(yaw, &sensor, &Vector3::new(0.3, -0.25, 0.0));
        let seen: Vec<Vector3<f64>> =
            reference.iter().map(|p| (error * Point3::from(*p)).coords).collect();
        let pivot = (error * Point3::from(sensor)).coords;
        let found = search(&seen, &reference, &ground, &pivot, &BevSettings::default()).unwrap();
        let left = found.applied * error;
        assert!(left.rotation.angle() < 0.3f64.to_radians(), "{found:?}");
        let at_cubes = (left * Point3::new(12.3, 0.0, 0.3)).coords - Vector3::new(12.3, 0.0, 0.3);
        assert!(at_cubes.norm() < 0.06, "{at_cubes:?} {found:?}");
        assert!(found.score > 2.0 * found.score_unchanged, "{found:?}");
        assert!(!found.at_edge, "{found:?}");
        assert_eq!(warning(Some(&found), &BevSettings::default()), None);
    }

    #[test]
    fn a_sensor_off_by_more_than_the_range_is_found_at_its_edge() {
        let reference = cubes();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let sensor = Vector3::new(2.3, -0.6, 1.6);
        // Moved 1 m ahead, beyond the 0.75 m searched: the best the search can do is the
        // largest shift back.
        let error =
            rotation_about(UnitQuaternion::identity(), &sensor, &Vector3::new(1.0, 0.0, 0.0));
        let seen: Vec<Vector3<f64>> =
            reference.iter().map(|p| (error * Point3::from(*p)).coords).collect();
        let pivot = (error * Point3::from(sensor)).coords;
        let settings = BevSettings::default();
        let found = search(&seen, &reference, &ground, &pivot, &settings).unwrap();
        assert!(found.at_edge, "{found:?}");
        assert!(matches!(warning(Some(&found), &settings), Some(BevWarning::AtEdge { .. })));
        // 3 m ahead: nothing overlaps anywhere in reach, so nothing moves, and it says so.
        let far = rotation_about(UnitQuaternion::identity(), &sensor, &Vector3::new(3.0, 0.0, 0.0));
        let seen: Vec<Vector3<f64>> =
            reference.iter().map(|p| (far * Point3::from(*p)).coords).collect();
        let pivot = (far * Point3::from(sensor)).coords;
        let found = search(&seen, &reference, &ground, &pivot, &settings).unwrap();
        assert_eq!(
            (found.yaw, found.shift, found.score),
            (0.0, Vector3::zeros(), 0.0),
            "{found:?}"
        );
        assert!(matches!(
            warning(Some(&found), &settings),
            Some(BevWarning::LowOverlap { share: 0.0, .. })
        ));
        assert!(matches!(warning(None, &settings), Some(BevWarning::NothingToOverlay { .. })));
    }

    #[test]
    fn keeps_an_aligned_sensor_where_it_is() {
        let reference = cubes();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let pivot = Vector3::new(2.3, 0.6, 1.6);
        let found =
            search(&reference, &reference, &ground, &pivot, &BevSettings::default()).unwrap();
        assert_eq!((found.yaw, found.shift), (0.0, Vector3::zeros()));
        assert_eq!(found.score, found.score_unchanged);
    }

    #[test]
    fn nothing_above_the_ground_finds_nothing() {
        let flat: Vec<Vector3<f64>> =
            (0..100).map(|i| Vector3::new(10.0 + 0.05 * i as f64, 0.0, 0.01)).collect();
        let ground = Plane { normal: Vector3::z(), offset: 0.0 };
        let pivot = Vector3::zeros();
        assert!(search(&flat, &cubes(), &ground, &pivot, &BevSettings::default()).is_none());
        assert!(search(&cubes(), &flat, &ground, &pivot, &BevSettings::default()).is_none());
    }
}
