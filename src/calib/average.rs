//! Averaging per-frame corrections into one, with the per-axis spread as uncertainty.

use nalgebra::Vector3;

use super::Spread;
use crate::se3::{Pose, mean_pose};

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
}
