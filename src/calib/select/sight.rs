//! What a scan saw through: its returns binned by direction from the sensor (azimuth and
//! elevation cells), each cell keeping its nearest return's range. Every ray of a cell went at
//! least that far through empty space, so another sensor's point placed well in front of every
//! ray around its direction contradicts this scan: it stands where this sensor saw nothing.
//! Overlap alone rewards a placement that piles one sensor's view onto another's; free space
//! tells such a placement from one that fits (the free-space consistency of map evaluation and
//! of occupancy mapping).
//!
//! The scan must be in its sensor's own frame (the sensor at the origin), as scans are given.

use std::collections::HashMap;

/// Cell edges tried (deg), finest first: the finest whose occupied cells hold
/// [`POINTS_PER_CELL`] returns on average, so a cell's nearest return is a measurement, not
/// one stray ray.
const CELLS_DEG: [f64; 6] = [0.1, 0.2, 0.4, 0.8, 1.6, 3.2];
const POINTS_PER_CELL: f64 = 4.0;
/// Returns nearer than this (m) are the sensor's own mount, not the scene.
const NEAREST: f64 = 0.3;
/// Occupied cells of the 3 x 3 around a direction needed before it says anything.
const MIN_CELLS: usize = 2;

/// A scan's free space, by direction.
pub struct Sight {
    /// Cell edge (rad).
    cell: f64,
    /// Azimuth cells in a turn.
    around: i64,
    /// (azimuth cell, elevation cell) -> nearest range (m) of the returns in it.
    nearest: HashMap<(i64, i64), f32>,
}

impl Sight {
    /// From a scan's valid returns, in the sensor's frame.
    pub fn new(points: &[[f32; 3]]) -> Self {
        let ranged: Vec<([f64; 3], f64)> = points
            .iter()
            .map(|p| p.map(f64::from))
            .map(|p| (p, (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()))
            .filter(|&(_, r)| r >= NEAREST)
            .collect();
        let mut sight = Self::with_cell(CELLS_DEG[0].to_radians(), &ranged);
        for deg in &CELLS_DEG[1..] {
            let filled = ranged.len() as f64 / sight.nearest.len().max(1) as f64;
            if filled >= POINTS_PER_CELL {
                break;
            }
            sight = Self::with_cell(deg.to_radians(), &ranged);
        }
        sight
    }

    fn with_cell(cell: f64, ranged: &[([f64; 3], f64)]) -> Self {
        let around = (std::f64::consts::TAU / cell).ceil() as i64;
        let mut sight = Self { cell, around, nearest: HashMap::new() };
        for &(p, r) in ranged {
            let key = sight.key(p, r);
            let nearest = sight.nearest.entry(key).or_insert(f32::INFINITY);
            *nearest = nearest.min(r as f32);
        }
        sight
    }

    /// The cell edge (rad): a ray of a neighbouring cell passes up to about twice this
    /// (times the range) beside a direction.
    pub fn cell(&self) -> f64 {
        self.cell
    }

    fn key(&self, p: [f64; 3], r: f64) -> (i64, i64) {
        let azimuth = p[1].atan2(p[0]);
        let elevation = (p[2] / r).clamp(-1.0, 1.0).asin();
        let a = (azimuth / self.cell).floor() as i64;
        ((a.rem_euclid(self.around)), (elevation / self.cell).floor() as i64)
    }

    /// Whether a point `q` (this sensor's frame) stands in space this scan saw through: nearer
    /// by more than `margin` (m) than every return in the 3 x 3 cells around its direction,
    /// with at least [`MIN_CELLS`] of them holding returns. A direction with no returns
    /// around it (the sky, outside the field of view) says nothing.
    pub fn sees_through(&self, q: [f64; 3], margin: f64) -> bool {
        let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        if r < NEAREST {
            return false;
        }
        let (a, e) = self.key(q, r);
        let mut cells = 0;
        for da in -1..=1 {
            for de in -1..=1 {
                let key = ((a + da).rem_euclid(self.around), e + de);
                let Some(&nearest) = self.nearest.get(&key) else { continue };
                if r + margin >= nearest as f64 {
                    return false;
                }
                cells += 1;
            }
        }
        cells >= MIN_CELLS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall 10 m ahead, seen through a fan of rays.
    fn wall() -> Sight {
        let mut points = Vec::new();
        for i in -50..=50 {
            for j in -20..=20 {
                let (y, z) = (i as f32 * 0.05, j as f32 * 0.05);
                points.push([10.0, y, z]);
            }
        }
        Sight::new(&points)
    }

    #[test]
    fn a_point_before_the_wall_is_seen_through_and_one_on_it_or_behind_is_not() {
        let sight = wall();
        assert!(sight.sees_through([5.0, 0.0, 0.0], 0.1));
        assert!(!sight.sees_through([9.95, 0.0, 0.0], 0.1));
        assert!(!sight.sees_through([12.0, 0.0, 0.0], 0.1));
        // Beside the wall, where no ray went, nothing is known.
        assert!(!sight.sees_through([5.0, 5.0, 0.0], 0.1));
        assert!(!sight.sees_through([-5.0, 0.0, 0.0], 0.1));
    }

    #[test]
    fn the_cell_grows_until_its_cells_hold_several_returns() {
        let sight = wall();
        // 4141 returns over about 29 x 11 deg: 0.1 deg cells would hold one each.
        assert!(sight.cell().to_degrees() > 0.15, "{}", sight.cell().to_degrees());
        assert!(sight.cell().to_degrees() < 1.0, "{}", sight.cell().to_degrees());
    }
}
