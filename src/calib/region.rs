//! The region of interest when none is given: where the sensors' clouds overlap once each is
//! placed by its start (nominal, or the global alignment's). A targetless scene is its own
//! target, so the region is the part of it that the reference and another sensor both see.

use std::collections::HashSet;

use nalgebra::Point3;

use crate::cloud::{Aabb, is_valid_point};
use crate::se3::Pose;

/// Where the region the scans were cropped to came from.
#[cfg_attr(feature = "ts", derive(ts_rs::TS))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "source", rename_all = "camelCase")]
pub enum RoiSource {
    /// The user's.
    Given,
    /// Around the objects of the target's shape and size found standing in the reference's
    /// points (`found` of them), within the clouds' overlap. Whether they are the targets is
    /// the reconstruction's to say.
    Targets { found: usize },
    /// The clouds' overlap at the starts ([`overlap_region`]): no ROI given and no target found.
    Overlap,
}

/// Columns (m) of the bird's-eye grid the overlap is measured on.
const COLUMN: f64 = 1.0;
/// Farther than this from the vehicle (m) a scan is too sparse to register.
const REACH: f64 = 40.0;
/// The region spans the 2nd to the 98th percentile of the shared columns along x and y: a few
/// stray columns (a far building seen through a gap) must not stretch it.
const TAIL: f64 = 0.02;
/// Heights kept (m): from this far below the reference's ground to this far above it.
const BELOW: f64 = 1.0;
const ABOVE: f64 = 3.0;

/// The box over the columns occupied both by the reference's points (sensor `r`) and by
/// another sensor's, with every sensor's points placed by its start; a sensor that shares no
/// column with the reference (a chain of units, each overlapping only its neighbour) adds the
/// columns it shares with the others. `None` when no column is shared.
pub fn overlap_region(scans: &[Vec<[f32; 3]>], starts: &[Pose], r: usize) -> Option<Aabb> {
    let placed = |s: usize| {
        let pose = starts[s];
        scans[s]
            .iter()
            .filter(|p| is_valid_point(p))
            .map(move |p| pose * Point3::from(p.map(f64::from)))
            .filter(|q| q.coords.xy().norm() < REACH)
    };
    let columns = |s: usize| -> HashSet<[i64; 2]> {
        placed(s).map(|q| [(q.x / COLUMN).floor() as i64, (q.y / COLUMN).floor() as i64]).collect()
    };
    let all: Vec<HashSet<[i64; 2]>> = (0..scans.len()).map(columns).collect();
    let others_than = |s: usize| -> HashSet<[i64; 2]> {
        (0..scans.len()).filter(|&o| o != s).flat_map(|o| all[o].iter().copied()).collect()
    };
    let mut shared: HashSet<[i64; 2]> = all[r].intersection(&others_than(r)).copied().collect();
    for s in (0..scans.len()).filter(|&s| s != r && all[s].is_disjoint(&all[r])) {
        shared.extend(all[s].intersection(&others_than(s)));
    }
    let shared: Vec<[i64; 2]> = shared.into_iter().collect();
    if shared.is_empty() {
        return None;
    }
    let percentile = |axis: usize, q: f64| {
        let mut v: Vec<i64> = shared.iter().map(|c| c[axis]).collect();
        v.sort_unstable();
        v[((v.len() - 1) as f64 * q) as usize] as f64 * COLUMN
    };
    // The reference's ground, near the vehicle: the 5th percentile of its heights.
    let mut heights: Vec<f64> =
        placed(r).filter(|q| q.coords.xy().norm() < 15.0).map(|q| q.z).collect();
    if heights.is_empty() {
        return None;
    }
    heights.sort_by(f64::total_cmp);
    let ground = heights[heights.len() / 20];
    Some(Aabb::new(
        [percentile(0, TAIL), percentile(1, TAIL), ground - BELOW],
        [percentile(0, 1.0 - TAIL) + COLUMN, percentile(1, 1.0 - TAIL) + COLUMN, ground + ABOVE],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    #[test]
    fn the_region_is_where_both_see() {
        // Ground from x 0 to 20 for the reference, 10 to 30 for the other (in the vehicle frame).
        let ground = |from: f64| -> Vec<[f32; 3]> {
            (0..200)
                .flat_map(|i| {
                    (0..20).map(move |j| {
                        [(from + i as f64 * 0.1) as f32, (j as f64 * 0.2 - 2.0) as f32, 0.0]
                    })
                })
                .collect()
        };
        let other_pose = pose_from_xyz_rpy([1.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
        // The other sensor's points in its own frame: shifted back by its pose.
        let other: Vec<[f32; 3]> = ground(10.0).iter().map(|p| [p[0] - 1.0, p[1], p[2]]).collect();
        let region =
            overlap_region(&[ground(0.0), other], &[Pose::identity(), other_pose], 0).unwrap();
        assert!(
            (region.min[0] - 10.0).abs() < 1.01 && (region.max[0] - 20.0).abs() < 1.01,
            "{region:?}"
        );
        assert!((region.min[2] + 1.0).abs() < 1e-9 && (region.max[2] - 3.0).abs() < 1e-9);
        let far: Vec<[f32; 3]> = ground(0.0).iter().map(|p| [p[0] + 100.0, p[1], p[2]]).collect();
        assert_eq!(overlap_region(&[ground(0.0), far], &[Pose::identity(); 2], 0), None);
    }

    #[test]
    fn a_sensor_that_overlaps_only_its_neighbour_keeps_its_link() {
        let ground = |from: f64| -> Vec<[f32; 3]> {
            (0..200)
                .flat_map(|i| {
                    (0..20).map(move |j| [(from + i as f64 * 0.1) as f32, j as f32 * 0.2, 0.0])
                })
                .collect()
        };
        // The reference sees x 0-20, the middle unit 10-30, the last 25-45: only the middle
        // unit shares columns with the reference.
        let scans = [ground(0.0), ground(10.0), ground(25.0)];
        let region = overlap_region(&scans, &[Pose::identity(); 3], 0).unwrap();
        assert!((region.min[0] - 10.0).abs() < 1.01, "{region:?}");
        assert!((region.max[0] - 30.0).abs() < 1.01, "{region:?}");
    }
}
