//! Rigid transforms.
//!
//! Naming: `T_a_b` maps a point from frame `b` to frame `a`: `p_a = T_a_b * p_b`.
//! Euler angles are roll, pitch, yaw about the fixed x, y, z axes, `R = Rz(yaw) Ry(pitch) Rx(roll)`
//! (ROS RPY, URDF `rpy`, scipy `from_euler('xyz')`). Metres and radians throughout.

use nalgebra::{
    Isometry3, Matrix4, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3, Vector4,
};

/// A rigid transform (rotation + translation), f64.
pub type Pose = Isometry3<f64>;

/// A pose as seven numbers: its unit quaternion `x, y, z, w` and its translation (m), exactly
/// as held (how a pose crosses between workers).
pub fn to_quaternion_xyz(pose: &Pose) -> [f64; 7] {
    let (q, t) = (pose.rotation.coords, pose.translation.vector);
    [q.x, q.y, q.z, q.w, t.x, t.y, t.z]
}

/// The pose [`to_quaternion_xyz`] wrote; `None` for anything else (a wrong length, a number
/// that is not finite, a quaternion that is not a unit one).
pub fn from_quaternion_xyz(flat: &[f64]) -> Option<Pose> {
    let &[x, y, z, w, tx, ty, tz] = flat else { return None };
    let q = Quaternion::from(Vector4::new(x, y, z, w));
    if !flat.iter().all(|v| v.is_finite()) || (q.norm() - 1.0).abs() > 1e-9 {
        return None;
    }
    Some(Pose::from_parts(Translation3::new(tx, ty, tz), UnitQuaternion::new_unchecked(q)))
}

/// Pose from a translation (m) and roll, pitch, yaw (rad).
pub fn pose_from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Pose {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

/// `p -> rotation (p - pivot) + pivot + shift`: a rotation about a point, then a shift.
pub fn rotation_about(
    rotation: UnitQuaternion<f64>,
    pivot: &Vector3<f64>,
    shift: &Vector3<f64>,
) -> Pose {
    Isometry3::from_parts(Translation3::from(pivot + shift), rotation)
        * Isometry3::translation(-pivot.x, -pivot.y, -pivot.z)
}

/// Roll, pitch, yaw (rad) of a rotation. At gimbal lock (pitch = +-90 deg) the split between
/// roll and yaw is not unique; the returned triple still rebuilds the same rotation.
pub fn rpy(rotation: &UnitQuaternion<f64>) -> [f64; 3] {
    let m = rotation.to_rotation_matrix().into_inner();
    // R = Rz Ry Rx: m20 = -sin(pitch); hypot keeps pitch accurate near +-90 deg.
    let cos_pitch = m[(0, 0)].hypot(m[(1, 0)]);
    let pitch = (-m[(2, 0)]).atan2(cos_pitch);
    if cos_pitch > 1e-6 {
        [m[(2, 1)].atan2(m[(2, 2)]), pitch, m[(1, 0)].atan2(m[(0, 0)])]
    } else {
        // At (or within 1e-6 rad of) gimbal lock only roll -+ yaw is well conditioned, and it is
        // read from m01, m11; yaw comes from the tiny m10, m00 (zero at exact lock), so any error
        // in it moves roll and yaw together, which changes the rotation by only cos(pitch) times.
        let s = -m[(2, 0)].signum();
        let yaw = if cos_pitch > 1e-12 { m[(1, 0)].atan2(m[(0, 0)]) } else { 0.0 };
        let roll = (s * m[(0, 1)]).atan2(m[(1, 1)]) + s * yaw;
        [wrap_angle(roll), pitch, yaw]
    }
}

/// Wraps an angle (rad) to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w == -PI { PI } else { w }
}

/// Translation (m) and roll, pitch, yaw (rad) of a pose.
pub fn xyz_rpy(pose: &Pose) -> ([f64; 3], [f64; 3]) {
    let t = pose.translation.vector;
    ([t.x, t.y, t.z], rpy(&pose.rotation))
}

/// The 4x4 homogeneous matrix, row-major.
pub fn to_row_major(pose: &Pose) -> [f64; 16] {
    let m = pose.to_homogeneous();
    std::array::from_fn(|i| m[(i / 4, i % 4)])
}

/// Pose from a row-major 4x4 matrix; the rotation block is re-orthonormalised.
pub fn from_row_major(m: &[f64; 16]) -> Pose {
    let h = Matrix4::from_row_slice(m);
    let r = Rotation3::from_matrix(&h.fixed_view::<3, 3>(0, 0).into_owned());
    Isometry3::from_parts(
        Translation3::new(m[3], m[7], m[11]),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// Rotation angle (rad) of `a^-1 b`.
pub fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    a.angle_to(b)
}

/// Chordal L2 mean of rotations: the unit eigenvector of `sum q q^T` with the largest
/// eigenvalue (Markley et al. 2007). Insensitive to the sign of each quaternion.
/// Returns `None` for an empty slice.
pub fn mean_rotation(rotations: &[UnitQuaternion<f64>]) -> Option<UnitQuaternion<f64>> {
    if rotations.is_empty() {
        return None;
    }
    let m = rotations.iter().fold(nalgebra::Matrix4::zeros(), |acc, q| {
        let v = q.coords;
        acc + v * v.transpose()
    });
    let eig = m.symmetric_eigen();
    let (best, _) =
        eig.eigenvalues.iter().enumerate().fold((0, f64::NEG_INFINITY), |(bi, bv), (i, &v)| {
            if v > bv { (i, v) } else { (bi, bv) }
        });
    let c = eig.eigenvectors.column(best);
    Some(UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(c[3], c[0], c[1], c[2])))
}

/// Mean pose: chordal mean rotation and arithmetic mean translation.
pub fn mean_pose(poses: &[Pose]) -> Option<Pose> {
    let rotations: Vec<_> = poses.iter().map(|p| p.rotation).collect();
    let rotation = mean_rotation(&rotations)?;
    let sum = poses.iter().fold(Vector3::zeros(), |acc, p| acc + p.translation.vector);
    Some(Isometry3::from_parts(Translation3::from(sum / poses.len() as f64), rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: &Pose, b: &Pose, tol: f64) -> bool {
        angle_between(&a.rotation, &b.rotation) < tol
            && (a.translation.vector - b.translation.vector).norm() < tol
    }

    #[test]
    fn rpy_matches_rz_ry_rx() {
        let (r, p, y) = (0.1, -0.2, 0.3);
        let expected = Rotation3::from_axis_angle(&Vector3::z_axis(), y)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), p)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), r);
        let pose = pose_from_xyz_rpy([0.0; 3], [r, p, y]);
        let got = pose.rotation.to_rotation_matrix();
        assert!((got.matrix() - expected.matrix()).abs().max() < 1e-12);
        let back = rpy(&pose.rotation);
        assert!((back[0] - r).abs() < 1e-12 && (back[1] - p).abs() < 1e-12);
        assert!((back[2] - y).abs() < 1e-12);
    }

    #[test]
    fn round_trips_including_gimbal_lock() {
        for pitch in [0.0, 0.7, FRAC_PI_2 - 1e-9, FRAC_PI_2, -FRAC_PI_2, -FRAC_PI_2 + 1e-7] {
            for (roll, yaw) in [(0.3, -1.2), (-2.9, 3.0), (0.0, 0.0)] {
                let pose = pose_from_xyz_rpy([1.0, -2.0, 3.5], [roll, pitch, yaw]);
                // Euler -> pose -> Euler -> pose gives the same rotation.
                let (xyz, angles) = xyz_rpy(&pose);
                assert!(close(&pose, &pose_from_xyz_rpy(xyz, angles), 1e-9));
                // Matrix round trip.
                assert!(close(&pose, &from_row_major(&to_row_major(&pose)), 1e-12));
                // Quaternion round trip.
                let q = UnitQuaternion::from_quaternion(pose.rotation.into_inner());
                assert!(angle_between(&q, &pose.rotation) < 1e-12);
            }
        }
    }

    #[test]
    fn row_major_layout() {
        let pose = pose_from_xyz_rpy([1.0, 2.0, 3.0], [0.0, 0.0, FRAC_PI_2]);
        let m = to_row_major(&pose);
        assert_eq!([m[3], m[7], m[11], m[15]], [1.0, 2.0, 3.0, 1.0]);
        // Yaw 90 deg maps x to y: first column is (0, 1, 0).
        assert!(m[0].abs() < 1e-12 && (m[4] - 1.0).abs() < 1e-12 && m[8].abs() < 1e-12);
    }

    #[test]
    fn compose_and_inverse() {
        let a = pose_from_xyz_rpy([0.5, -1.0, 2.0], [0.1, 0.2, -0.3]);
        let b = pose_from_xyz_rpy([-0.2, 0.3, 0.1], [-0.4, 0.05, 1.0]);
        let p = nalgebra::Point3::new(1.0, 2.0, 3.0);
        assert!(((a * b) * p - a * (b * p)).norm() < 1e-12);
        assert!(close(&(a.inverse() * a), &Pose::identity(), 1e-12));
    }

    #[test]
    fn chordal_mean_of_symmetric_rotations() {
        let centre = UnitQuaternion::from_euler_angles(0.2, -0.1, 0.7);
        let axes = [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()];
        let mut rotations = Vec::new();
        for axis in axes {
            for angle in [0.05, -0.05] {
                rotations.push(centre * UnitQuaternion::from_axis_angle(&axis, angle));
            }
        }
        // Flipping a quaternion's sign describes the same rotation and must not matter.
        let flipped = UnitQuaternion::new_unchecked(-rotations[0].into_inner());
        rotations[0] = flipped;
        let mean = mean_rotation(&rotations).unwrap();
        assert!(angle_between(&mean, &centre) < 1e-12);
        assert!(mean_rotation(&[]).is_none());
    }

    #[test]
    fn mean_pose_averages_translation() {
        let a = pose_from_xyz_rpy([1.0, 0.0, 0.0], [0.0, 0.0, 0.1]);
        let b = pose_from_xyz_rpy([3.0, 2.0, 0.0], [0.0, 0.0, -0.1]);
        let m = mean_pose(&[a, b]).unwrap();
        assert!((m.translation.vector - Vector3::new(2.0, 1.0, 0.0)).norm() < 1e-12);
        assert!(m.rotation.angle() < 1e-12);
    }
}
