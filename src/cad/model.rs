//! The fixed mixture: Gaussian centres on the placed CAD surface, each with its unit normal and
//! its anisotropy, computed from the surface's local curvature as CADCalib does
//! (`cad_calib.py`, `_initialize_anisotropy`; `cad_model.py`, `compute_surface_variation_at_points`).

use nalgebra::{Matrix3, Vector3};

use crate::icp::kdtree::KdTree;

/// Neighbours (the sample itself included) whose spread gives a sample's surface variation:
/// CADCalib's `k_neighbors = 12` (`cad_model.py`, `compute_surface_variation_at_points`).
const CURVATURE_NEIGHBOURS: usize = 12;

/// Percentiles of `log1p(curvature)` mapped to 0 and 1 before clamping (CADCalib's
/// `np.percentile(curv, [10, 90])`).
const LOW_PERCENTILE: f64 = 10.0;
const HIGH_PERCENTILE: f64 = 90.0;

/// CADCalib's guard against dividing by zero (`+ 1e-12` in the curvature ratio, the percentile
/// span and the normal's length).
const TINY: f64 = 1e-12;

/// The fixed mixture: centres on the placed CAD surface with normals and anisotropies.
///
/// Centre `k`'s precision is `(I + a_k n_k n_k^T) / sigma^2`: along the normal its standard
/// deviation is `sigma / sqrt(1 + a_k)`, in the tangent plane `sigma`, so a flat face (large
/// `a_k`) pulls points onto its plane and an edge (small `a_k`) onto its point.
#[derive(Clone, Debug, PartialEq)]
pub struct CadModel {
    /// Centre positions in the vehicle frame (m).
    pub centres: Vec<Vector3<f64>>,
    /// Unit surface normals, one per centre (the sign does not matter: only `n n^T` is used).
    pub normals: Vec<Vector3<f64>>,
    /// Anisotropy `a_k >= 0`, one per centre.
    pub anisotropy: Vec<f64>,
}

impl CadModel {
    /// From surface samples (points with unit normals, e.g. `Mesh::sample_with_normals` of the
    /// placed mesh, in the vehicle frame): anisotropy from curvature as CADCalib computes it.
    ///
    /// Following CADCalib: each sample's curvature is the surface variation
    /// `lambda_min / (lambda_0 + lambda_1 + lambda_2 + 1e-12)` of the second moment of its 12
    /// nearest samples (itself included) about itself; `c = log1p(curvature)` is normalised
    /// between its 10th and 90th percentiles (numpy's linear interpolation) and clamped to
    /// [0, 1]; `a_k = a_max (1 - c_k)`. Face middles get `a_max`, edges and corners (above the
    /// 90th percentile) 0. The samples play both parts CADCalib gives two sets (the centres,
    /// and 50 000 surface samples the neighbours come from): a sample's neighbourhood spans
    /// about two sample spacings, so a few centres near an edge whose neighbours all lie on
    /// one face stay flat. Normals are normalised (a zero normal stays zero: that centre is
    /// isotropic).
    pub fn from_samples(samples: &[([f64; 3], [f64; 3])], a_max: f64) -> Self {
        let centres: Vec<Vector3<f64>> = samples.iter().map(|(p, _)| Vector3::from(*p)).collect();
        // CADCalib: `normals /= norm(normals) + 1e-12`.
        let normals = samples
            .iter()
            .map(|(_, n)| Vector3::from(*n) / (Vector3::from(*n).norm() + TINY))
            .collect();
        let curvature = surface_variation(&centres);
        let anisotropy = anisotropy_from_curvature(&curvature, a_max);
        Self { centres, normals, anisotropy }
    }

    /// Number of centres.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// True when the model has no centre.
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }
}

/// CADCalib's curvature proxy per sample: the smallest eigenvalue's share of the second moment
/// of its nearest samples about itself (not about their mean, as CADCalib computes it).
/// Samples that are not finite get 0.
fn surface_variation(points: &[Vector3<f64>]) -> Vec<f64> {
    let as_f32: Vec<[f32; 3]> =
        points.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
    let tree = KdTree::new(&as_f32);
    let mut curvature = vec![0.0; points.len()];
    tree.for_each_k_nearest(CURVATURE_NEIGHBOURS, |i, neighbours| {
        let p = points[i];
        let mut moment = Matrix3::zeros();
        for n in neighbours {
            let d = points[n.index] - p;
            moment += d * d.transpose();
        }
        moment /= neighbours.len().max(1) as f64;
        let eigenvalues = moment.symmetric_eigenvalues();
        let smallest = eigenvalues.min().max(0.0);
        curvature[i] = smallest / (eigenvalues.sum() + TINY);
    });
    curvature
}

/// `a_max (1 - clamp((log1p(c) - p10) / (p90 - p10 + 1e-12), 0, 1))` per sample (CADCalib,
/// `_initialize_anisotropy`).
fn anisotropy_from_curvature(curvature: &[f64], a_max: f64) -> Vec<f64> {
    let curv: Vec<f64> = curvature.iter().map(|c| c.ln_1p()).collect();
    let mut sorted = curv.clone();
    sorted.sort_by(f64::total_cmp);
    let (Some(p10), Some(p90)) =
        (percentile(&sorted, LOW_PERCENTILE), percentile(&sorted, HIGH_PERCENTILE))
    else {
        return Vec::new();
    };
    curv.iter().map(|c| a_max * (1.0 - ((c - p10) / (p90 - p10 + TINY)).clamp(0.0, 1.0))).collect()
}

/// numpy's default (linear) percentile `q` (0..=100) of ascending `sorted`; `None` when empty.
fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let position = q / 100.0 * last as f64;
    let below = (position.floor() as usize).min(last);
    let above = (below + 1).min(last);
    let frac = position - below as f64;
    Some(sorted[below] + frac * (sorted[above] - sorted[below]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_matches_numpy_linear() {
        let v = [1.0, 2.0, 3.0, 4.0, 10.0];
        // np.percentile([1, 2, 3, 4, 10], [10, 90]) == [1.4, 7.6]
        assert!((percentile(&v, 10.0).unwrap() - 1.4).abs() < 1e-12);
        assert!((percentile(&v, 90.0).unwrap() - 7.6).abs() < 1e-12);
        assert_eq!(percentile(&[5.0], 90.0), Some(5.0));
        assert_eq!(percentile(&[], 10.0), None);
    }
}
