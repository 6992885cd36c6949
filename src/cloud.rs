//! Point clouds: a flat list of xyz points (metres) with optional intensity, and the
//! pre-processing every pipeline needs (invalid-point filter, crop, voxel downsample).

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::se3::Pose;

/// One scan: points `x, y, z` in the sensor's own frame (m). Scans of different sensors with
/// the same frame name were captured at the same time.
#[derive(Clone, Debug)]
pub struct Scan {
    pub sensor: String,
    pub frame: String,
    pub points: Vec<[f32; 3]>,
    /// Where the scan came from (a file's name, a recording's message), for messages.
    pub source: Option<String>,
}

/// An axis-aligned box (metres), bounds inclusive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// Lower and upper corners of the box around `points`; infinite (lower above upper) when
/// there are none.
pub fn bounds<'a>(
    points: impl IntoIterator<Item = &'a Vector3<f64>>,
) -> (Vector3<f64>, Vector3<f64>) {
    points.into_iter().fold(
        (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    )
}

/// Mean of `points` (summed in f64, in order); `None` when there are none.
pub fn centroid<'a>(points: impl IntoIterator<Item = &'a [f32; 3]>) -> Option<[f64; 3]> {
    let (mut sum, mut n) = ([0.0f64; 3], 0usize);
    for p in points {
        for i in 0..3 {
            sum[i] += f64::from(p[i]);
        }
        n += 1;
    }
    (n > 0).then(|| sum.map(|s| s / n as f64))
}

impl Aabb {
    pub fn new(min: [f64; 3], max: [f64; 3]) -> Self {
        Self { min, max }
    }

    /// True when every bound is finite and `min <= max` on each axis.
    pub fn is_valid(&self) -> bool {
        (0..3).all(|i| {
            self.min[i].is_finite() && self.max[i].is_finite() && self.min[i] <= self.max[i]
        })
    }

    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|i| p[i] >= self.min[i] && p[i] <= self.max[i])
    }
}

/// A point cloud. Points are stored contiguously as `[x, y, z]` (f32, as sensors deliver them);
/// `intensity`, when present, has one value per point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    pub points: Vec<[f32; 3]>,
    pub intensity: Option<Vec<f32>>,
}

impl Cloud {
    pub fn from_points(points: Vec<[f32; 3]>) -> Self {
        Self { points, intensity: None }
    }

    /// Builds a cloud from a flat `x, y, z, x, y, z, ...` slice; `None` when the length is not a
    /// multiple of three.
    pub fn from_flat(xyz: &[f32]) -> Option<Self> {
        if xyz.len() % 3 != 0 {
            return None;
        }
        Some(Self::from_points(xyz.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()))
    }

    /// The points as a flat `x, y, z, ...` vector.
    pub fn to_flat(&self) -> Vec<f32> {
        self.points.iter().flatten().copied().collect()
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Keeps the points for which `keep(point)` holds, with their intensities.
    fn retain(&mut self, mut keep: impl FnMut(&[f32; 3]) -> bool) {
        let mask: Vec<bool> = self.points.iter().map(&mut keep).collect();
        let mut flags = mask.iter();
        self.points.retain(|_| *flags.next().unwrap_or(&false));
        if let Some(intensity) = &mut self.intensity {
            let mut flags = mask.iter();
            intensity.retain(|_| *flags.next().unwrap_or(&false));
        }
    }

    /// Drops points with a NaN or infinite coordinate and exact-zero returns (`0 0 0`, `-0 0 0`),
    /// which is how sensors mark missing returns. Returns how many were dropped.
    pub fn drop_invalid(&mut self) -> usize {
        let before = self.len();
        self.retain(is_valid_point);
        before - self.len()
    }

    /// The points inside `roi` (bounds inclusive).
    pub fn cropped(&self, roi: &Aabb) -> Cloud {
        let mut out = self.clone();
        out.retain(|p| roi.contains(p.map(f64::from)));
        out
    }

    /// Every point mapped through `pose` (`p' = pose * p`).
    pub fn transformed(&self, pose: &Pose) -> Cloud {
        Cloud { points: transformed(&self.points, pose), intensity: self.intensity.clone() }
    }

    /// Mean of the points in f64, `None` when empty.
    pub fn centroid(&self) -> Option<[f64; 3]> {
        centroid(&self.points)
    }

    /// One point per occupied voxel of edge `voxel` (m): the centroid of the points in it
    /// (intensity averaged too). Output order is the order in which voxels are first seen, so
    /// the result is deterministic. A non-positive or non-finite `voxel` returns a copy.
    pub fn voxel_downsampled(&self, voxel: f64) -> Cloud {
        if !(voxel.is_finite() && voxel > 0.0) {
            return self.clone();
        }
        let mut slot_of: HashMap<[i64; 3], usize> = HashMap::new();
        let mut sums: Vec<([f64; 3], f64, u32)> = Vec::new();
        for (i, p) in self.points.iter().enumerate() {
            let key = p.map(|c| (c as f64 / voxel).floor() as i64);
            let slot = *slot_of.entry(key).or_insert_with(|| {
                sums.push(([0.0; 3], 0.0, 0));
                sums.len() - 1
            });
            let (sum, intensity, count) = &mut sums[slot];
            for k in 0..3 {
                sum[k] += p[k] as f64;
            }
            *intensity += self.intensity.as_ref().map_or(0.0, |v| v[i] as f64);
            *count += 1;
        }
        let points = sums.iter().map(|(s, _, n)| s.map(|c| (c / *n as f64) as f32)).collect();
        let intensity = self
            .intensity
            .as_ref()
            .map(|_| sums.iter().map(|(_, i, n)| (*i / *n as f64) as f32).collect());
        Cloud { points, intensity }
    }
}

/// False for a point with a NaN or infinite coordinate, or an exact-zero return.
pub fn is_valid_point(p: &[f32; 3]) -> bool {
    p.iter().all(|c| c.is_finite()) && p.iter().any(|&c| c != 0.0)
}

/// Every point of `points` mapped through `pose` (`p' = pose * p`), in f64 and back.
pub fn transformed(points: &[[f32; 3]], pose: &Pose) -> Vec<[f32; 3]> {
    points
        .iter()
        .map(|p| {
            let q = pose * nalgebra::Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            [q.x as f32, q.y as f32, q.z as f32]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    #[test]
    fn drops_nan_inf_and_zero_returns() {
        let mut cloud = Cloud {
            points: vec![
                [1.0, 2.0, 3.0],
                [f32::NAN, 0.0, 1.0],
                [0.0, 0.0, 0.0],
                [-0.0, 0.0, -0.0],
                [f32::INFINITY, 1.0, 1.0],
                [0.0, 0.0, 1e-3],
            ],
            intensity: Some(vec![10.0, 11.0, 12.0, 13.0, 14.0, 15.0]),
        };
        assert_eq!(cloud.drop_invalid(), 4);
        assert_eq!(cloud.points, vec![[1.0, 2.0, 3.0], [0.0, 0.0, 1e-3]]);
        assert_eq!(cloud.intensity, Some(vec![10.0, 15.0]));
    }

    #[test]
    fn crop_is_inclusive() {
        let cloud = Cloud::from_points(vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1.0001, 0.5, 0.5]]);
        let roi = Aabb::new([0.0; 3], [1.0; 3]);
        assert_eq!(cloud.cropped(&roi).points, vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]);
        assert!(roi.is_valid());
        assert!(!Aabb::new([0.0; 3], [1.0, -1.0, 1.0]).is_valid());
        assert!(!Aabb::new([f64::NAN; 3], [1.0; 3]).is_valid());
    }

    #[test]
    fn voxel_downsample_averages_per_voxel() {
        let cloud = Cloud {
            points: vec![[0.1, 0.1, 0.1], [0.3, 0.3, 0.3], [1.5, 0.1, 0.1]],
            intensity: Some(vec![1.0, 3.0, 5.0]),
        };
        let down = cloud.voxel_downsampled(1.0);
        assert_eq!(down.len(), 2);
        assert!((down.points[0][0] - 0.2).abs() < 1e-6);
        assert_eq!(down.intensity, Some(vec![2.0, 5.0]));
        assert_eq!(cloud.voxel_downsampled(0.0), cloud);
    }

    #[test]
    fn flat_round_trip_and_transform() {
        let cloud = Cloud::from_flat(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(cloud.to_flat(), vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert!(Cloud::from_flat(&[1.0, 2.0]).is_none());
        let moved = cloud.transformed(&pose_from_xyz_rpy([1.0, 0.0, 0.0], [0.0; 3]));
        assert_eq!(moved.points[0], [2.0, 2.0, 3.0]);
        assert_eq!(cloud.centroid(), Some([2.5, 3.5, 4.5]));
    }
}
