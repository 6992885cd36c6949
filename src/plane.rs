//! Planes in 3D: `normal . p + offset = 0`, and the principal axes of a point set that give a
//! least-squares plane. A leaf shared by levelling, the bird's-eye search and the plane
//! adjustment, so none of them imports another for it.

use nalgebra::{Matrix3, SymmetricEigen, U3, Vector3};
use serde::{Deserialize, Serialize};

/// A plane `normal . p + offset = 0` with a unit normal pointing up (+z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    pub normal: Vector3<f64>,
    pub offset: f64,
}

impl Plane {
    /// Signed distance (m) of `p` above the plane.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) + self.offset
    }

    /// The point of the plane nearest to `p`.
    pub fn project(&self, p: &Vector3<f64>) -> Vector3<f64> {
        p - self.normal * self.distance(p)
    }
}

/// The centroid of `points` (at least one) and the eigen-decomposition of their covariance
/// about it: the least-squares plane's normal is the eigenvector of the smallest eigenvalue.
pub fn principal_axes<'a, I>(points: I) -> Option<(Vector3<f64>, SymmetricEigen<f64, U3>)>
where
    I: IntoIterator<Item = &'a Vector3<f64>>,
    I::IntoIter: Clone + ExactSizeIterator,
{
    let points = points.into_iter();
    let n = points.len() as f64;
    let centroid = points.clone().fold(Vector3::zeros(), |s, p| s + p) / n;
    let covariance = points.fold(Matrix3::zeros(), |s, p| {
        let d = p - centroid;
        s + d * d.transpose()
    }) / n;
    Some((centroid, SymmetricEigen::try_new(covariance, f64::EPSILON, 1000)?))
}
