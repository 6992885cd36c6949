//! Planes in 3D: `normal . p + offset = 0`, and the principal axes of a point set that give a
//! least-squares plane. A leaf shared by levelling, the bird's-eye search and the plane
//! adjustment, so none of them imports another for it.

use nalgebra::{Matrix3, SymmetricEigen, U3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// A plane `normal . p + offset = 0` with a unit normal pointing up (+z).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    pub normal: Vector3<f64>,
    pub offset: f64,
}

impl Plane {
    /// The same plane with its normal the other way.
    pub fn flipped(self) -> Plane {
        Plane { normal: -self.normal, offset: -self.offset }
    }

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

/// The least-squares plane through the points' centroid (its normal the direction of least
/// spread, signed as the eigen solver gives it) and the points' extent (m) along the in-plane
/// direction of lesser spread (the side of a uniformly covered rectangle); `None` when the
/// normal is not finite.
pub fn least_squares_plane<'a, I>(points: I) -> Option<(Plane, f64)>
where
    I: IntoIterator<Item = &'a Vector3<f64>>,
    I::IntoIter: Clone + ExactSizeIterator,
{
    let (centroid, eig) = principal_axes(points)?;
    let normal = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    let mut spread: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    spread.sort_by(f64::total_cmp);
    let extent = (12.0 * spread[1].max(0.0)).sqrt();
    normal
        .iter()
        .all(|c| c.is_finite())
        .then(|| (Plane { normal, offset: -normal.dot(&centroid) }, extent))
}

/// Coordinates along a ground plane: an orthonormal basis (u, v) of it, u along the vehicle's x
/// where it can be, with (u, v, normal) right-handed, so a 2D rotation by an angle in (u, v) is
/// the 3D rotation by that angle about the normal. Shared by the searches seen from above.
pub(crate) struct GroundFrame {
    pub plane: Plane,
    pub u: Vector3<f64>,
    pub v: Vector3<f64>,
}

impl GroundFrame {
    pub fn new(plane: Plane) -> Self {
        let n = plane.normal;
        let u = (Vector3::x() - n * n.x)
            .try_normalize(1e-9)
            .unwrap_or_else(|| (Vector3::y() - n * n.y).normalize());
        Self { plane, u, v: n.cross(&u) }
    }

    /// `p`'s coordinates along the plane.
    pub fn along(&self, p: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(p.dot(&self.u), p.dot(&self.v))
    }

    /// The plane vector of coordinates `c`.
    pub fn vector(&self, c: Vector2<f64>) -> Vector3<f64> {
        self.u * c.x + self.v * c.y
    }

    /// Plane coordinates of the points whose height above the plane lies in `heights`.
    pub fn structure(&self, points: &[Vector3<f64>], heights: [f64; 2]) -> Vec<Vector2<f64>> {
        points
            .iter()
            .filter(|p| (heights[0]..=heights[1]).contains(&self.plane.distance(p)))
            .map(|p| self.along(p))
            .collect()
    }
}
