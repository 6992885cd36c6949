//! Averaging per-frame corrections into one, with the per-axis spread as uncertainty.

use nalgebra::Vector3;

use super::Spread;
use crate::se3::{Pose, mean_pose};

/// Frames need this many before any is called an outlier.
const MIN_FRAMES_FOR_REJECTION: usize = 4;
/// A frame is an outlier when it deviates from the mean by more than this many times the
/// median deviation, plus a floor (rad, m) so that frames agreeing tightly are all kept.
const OUTLIER_FACTOR: f64 = 3.0;
const FLOOR: (f64, f64) = (0.0005, 0.002);

/// Like [`average`], but frames far from the others (rotation or translation beyond three
/// median deviations, with 4 or more frames) are left out; their indices come back too.
pub fn robust_average(corrections: &[Pose]) -> Option<(Pose, Spread, Vec<usize>)> {
    let (mean, spread) = average(corrections)?;
    if corrections.len() < MIN_FRAMES_FOR_REJECTION {
        return Some((mean, spread, Vec::new()));
    }
    let deviations: Vec<(f64, f64)> = corrections
        .iter()
        .map(|c| {
            let d = mean.inverse() * c;
            (d.rotation.angle(), d.translation.vector.norm())
        })
        .collect();
    let median = |pick: fn(&(f64, f64)) -> f64| {
        let mut v: Vec<f64> = deviations.iter().map(pick).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let limit =
        (OUTLIER_FACTOR * median(|d| d.0) + FLOOR.0, OUTLIER_FACTOR * median(|d| d.1) + FLOOR.1);
    let (kept, rejected): (Vec<usize>, Vec<usize>) = (0..corrections.len())
        .partition(|&i| deviations[i].0 <= limit.0 && deviations[i].1 <= limit.1);
    let inliers: Vec<Pose> = kept.iter().map(|&i| corrections[i]).collect();
    let (mean, spread) = average(&inliers)?;
    Some((mean, spread, rejected))
}

/// Chordal-mean rotation and mean translation of `corrections`, and their per-axis spread;
/// `None` when there is nothing to average.
pub fn average(corrections: &[Pose]) -> Option<(Pose, Spread)> {
    let mean = mean_pose(corrections)?;
    let n = corrections.len() as f64;
    let (mut xyz, mut rot) = (Vector3::zeros(), Vector3::zeros());
    for c in corrections {
        let dt = c.translation.vector - mean.translation.vector;
        let dr = (mean.rotation.inverse() * c.rotation).scaled_axis();
        xyz += dt.component_mul(&dt);
        rot += dr.component_mul(&dr);
    }
    let std = |v: Vector3<f64>| [v.x, v.y, v.z].map(|s| (s / n).sqrt());
    Some((mean, Spread { xyz: std(xyz), rpy: std(rot), frames: corrections.len() }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    #[test]
    fn mean_and_spread_of_two_frames() {
        let a = pose_from_xyz_rpy([1.0, 0.0, 0.0], [0.01, 0.0, 0.0]);
        let b = pose_from_xyz_rpy([1.2, 0.0, 0.0], [-0.01, 0.0, 0.0]);
        let (mean, spread) = average(&[a, b]).unwrap();
        assert!((mean.translation.vector.x - 1.1).abs() < 1e-12 && mean.rotation.angle() < 1e-12);
        assert!((spread.xyz[0] - 0.1).abs() < 1e-12 && spread.xyz[1] == 0.0);
        assert!((spread.rpy[0] - 0.01).abs() < 1e-9);
        assert_eq!(spread.frames, 2);
        assert!(average(&[]).is_none());
    }

    #[test]
    fn robust_average_leaves_out_a_far_frame() {
        let mut frames: Vec<Pose> = (0..6)
            .map(|i| {
                pose_from_xyz_rpy([1.0 + 0.001 * i as f64, 0.0, 0.0], [0.0, 0.0, 0.0002 * i as f64])
            })
            .collect();
        frames.push(pose_from_xyz_rpy([1.3, 0.0, 0.0], [0.0, 0.0, 0.05]));
        let (mean, spread, rejected) = robust_average(&frames).unwrap();
        assert_eq!(rejected, vec![6]);
        assert_eq!(spread.frames, 6);
        assert!((mean.translation.vector.x - 1.0025).abs() < 1e-9);
        // Three frames are too few to judge: all are kept.
        let (_, _, rejected) = robust_average(&[frames[0], frames[1], frames[6]]).unwrap();
        assert!(rejected.is_empty());
    }
}
