//! Local surface shape from each point's k nearest neighbours: PCA normals for point-to-plane
//! ICP and plane-regularised covariances for GICP (Segal et al. 2009, section III.B, with the
//! eigenvalues replaced as in fast_gicp / small_gicp).

use nalgebra::{Matrix3, SymmetricEigen, U3, Vector3};

use super::kdtree::{KdTree, Neighbour};

/// Eigenvalues (m^2) of a GICP covariance: `PLANE_IN_PLANE` along the two largest principal
/// directions of the neighbourhood, `PLANE_NORMAL` along the normal (the paper's epsilon).
pub const PLANE_IN_PLANE: f64 = 1.0;
pub const PLANE_NORMAL: f64 = 1e-3;

/// A neighbourhood whose largest variance (m^2) is below this has no usable shape: its points
/// coincide to within a micrometre.
const MIN_VARIANCE: f64 = 1e-12;

/// Unit normal of each point (sign arbitrary): the direction of least variance of its `k`
/// nearest neighbours in `tree`, which must be built from `points`. Zero where the
/// neighbourhood has no shape (all neighbours coincide, or the point is not finite). With
/// `keep`, also every point's [`Neighbourhood`] from the same search (else none): a target
/// that the verdict reads too is searched once.
pub fn normals(
    points: &[[f32; 3]],
    tree: &KdTree,
    k: usize,
    keep: bool,
) -> (Vec<Vector3<f64>>, Vec<Option<Neighbourhood>>) {
    shapes(points, tree, k, Vector3::zeros(), least_spread, keep)
}

/// GICP covariance (m^2) of each point: the principal directions of its `k` nearest
/// neighbours in `tree` (built from `points`) with eigenvalues `PLANE_IN_PLANE`,
/// `PLANE_IN_PLANE`, `PLANE_NORMAL`, so every surface is modelled as a thin plane. Identity
/// (no preferred direction) where the neighbourhood has no shape. With `keep`, also every
/// point's [`Neighbourhood`], as [`normals`] gives them.
pub fn plane_covariances(
    points: &[[f32; 3]],
    tree: &KdTree,
    k: usize,
    keep: bool,
) -> (Vec<Matrix3<f64>>, Vec<Option<Neighbourhood>>) {
    shapes(points, tree, k, Matrix3::identity(), thin_plane, keep)
}

/// The direction of least spread of a neighbourhood with principal axes `eig`.
fn least_spread(eig: &SymmetricEigen<f64, U3>) -> Vector3<f64> {
    eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned()
}

/// The GICP covariance of a neighbourhood with principal axes `eig`.
fn thin_plane(eig: &SymmetricEigen<f64, U3>) -> Matrix3<f64> {
    let normal_axis = eig.eigenvalues.imin();
    let values =
        Vector3::from_fn(|i, _| if i == normal_axis { PLANE_NORMAL } else { PLANE_IN_PLANE });
    let v = &eig.eigenvectors;
    v * Matrix3::from_diagonal(&values) * v.transpose()
}

/// The plane-regularised covariance of a surface with unit `normal`: `PLANE_IN_PLANE` along
/// the surface, `PLANE_NORMAL` across it.
pub fn plane_covariance(normal: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::identity() * PLANE_IN_PLANE
        - normal * normal.transpose() * (PLANE_IN_PLANE - PLANE_NORMAL)
}

/// What a point's nearest neighbours say of the surface there beyond ICP's normal or
/// covariance (the verdict's evidence reads the surface's thickness and sampling from it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbourhood {
    /// Distance (m) to the farthest of the neighbours.
    pub reach: f64,
    /// The principal variances (m^2), least first, and the unit direction of the least (sign
    /// arbitrary); `None` where the neighbourhood has no shape.
    pub shape: Option<([f64; 3], Vector3<f64>)>,
}

/// Every point's [`Neighbourhood`] of `k` nearest neighbours in `tree` (built from `points`);
/// `None` where fewer than three neighbours were found, which say nothing of a surface.
pub fn neighbourhoods(points: &[[f32; 3]], tree: &KdTree, k: usize) -> Vec<Option<Neighbourhood>> {
    shapes(points, tree, k, (), |_| (), true).1
}

/// `shape(eigen-decomposition of the neighbourhood covariance)` for every point, or
/// `shapeless` where the neighbourhood has no shape; with `keep`, also every point's
/// [`Neighbourhood`] from the same search (else none).
fn shapes<T: Clone>(
    points: &[[f32; 3]],
    tree: &KdTree,
    k: usize,
    shapeless: T,
    shape: impl Fn(&SymmetricEigen<f64, U3>) -> T,
    keep: bool,
) -> (Vec<T>, Vec<Option<Neighbourhood>>) {
    let mut out = vec![shapeless; points.len()];
    let mut neighbourhoods = if keep { vec![None; points.len()] } else { Vec::new() };
    tree.for_each_k_nearest(k, |i, neighbours| {
        // Indices beyond `points` (a tree built from other points) are skipped, not a panic.
        let Some(q) = points.get(i).map(|p| p.map(f64::from)) else {
            return;
        };
        let eig = neighbourhood_covariance(points, q, neighbours).and_then(|c| {
            // Bounded iterations: a decomposition that does not converge is treated as shapeless.
            let eig = SymmetricEigen::try_new(c, f64::EPSILON, 1000)?;
            let largest = eig.eigenvalues.max();
            (largest.is_finite() && largest > MIN_VARIANCE).then_some(eig)
        });
        if let Some(eig) = &eig {
            out[i] = shape(eig);
        }
        if keep && neighbours.len() >= 3 {
            neighbourhoods[i] = Some(neighbourhood(neighbours, eig.as_ref()));
        }
    });
    (out, neighbourhoods)
}

/// The [`Neighbourhood`] of `neighbours` (nearest first), whose covariance has the principal
/// axes `eig`.
fn neighbourhood(neighbours: &[Neighbour], eig: Option<&SymmetricEigen<f64, U3>>) -> Neighbourhood {
    let reach = neighbours.last().map_or(0.0, |n| n.sq_distance.sqrt());
    let shape = eig.map(|eig| {
        let mut axes: [(f64, usize); 3] = [0, 1, 2].map(|j| (eig.eigenvalues[j], j));
        axes.sort_by(|a, b| a.0.total_cmp(&b.0));
        (axes.map(|(v, _)| v), eig.eigenvectors.column(axes[0].1).into_owned())
    });
    Neighbourhood { reach, shape }
}

/// Sample covariance (m^2) of the neighbours, accumulated relative to `q` to keep precision
/// far from the origin. `None` for fewer than two neighbours or an index beyond `points`.
fn neighbourhood_covariance(
    points: &[[f32; 3]],
    q: [f64; 3],
    neighbours: &[Neighbour],
) -> Option<Matrix3<f64>> {
    if neighbours.len() < 2 {
        return None;
    }
    let mut sum = Vector3::zeros();
    let mut sum_sq = Matrix3::zeros();
    for nb in neighbours {
        let p = points.get(nb.index)?;
        let d = Vector3::new(p[0] as f64 - q[0], p[1] as f64 - q[1], p[2] as f64 - q[2]);
        sum += d;
        sum_sq += d * d.transpose();
    }
    let n = neighbours.len() as f64;
    let mean = sum / n;
    Some(sum_sq / n - mean * mean.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 m x 1 m grid in the plane through the origin with normal (0, 0.6, 0.8).
    fn tilted_plane() -> (Vec<[f32; 3]>, Vector3<f64>) {
        let normal = Vector3::new(0.0, 0.6, 0.8);
        let u = Vector3::x();
        let v = normal.cross(&u);
        let points = (0..121)
            .map(|i| {
                let p = u * ((i % 11) as f64 * 0.1) + v * ((i / 11) as f64 * 0.1);
                [p.x as f32, p.y as f32, p.z as f32]
            })
            .collect();
        (points, normal)
    }

    #[test]
    fn normals_of_a_plane() {
        let (points, normal) = tilted_plane();
        let tree = KdTree::new(&points);
        for n in normals(&points, &tree, 20, false).0 {
            assert!((n.dot(&normal).abs() - 1.0).abs() < 1e-6, "{n}");
        }
    }

    #[test]
    fn covariances_are_thin_planes() {
        let (points, normal) = tilted_plane();
        let tree = KdTree::new(&points);
        let in_plane: Vector3<f64> = Vector3::x();
        for c in plane_covariances(&points, &tree, 20, false).0 {
            assert!(((normal.transpose() * c * normal)[0] - PLANE_NORMAL).abs() < 1e-6);
            assert!(((in_plane.transpose() * c * in_plane)[0] - PLANE_IN_PLANE).abs() < 1e-6);
            assert!((c - c.transpose()).abs().max() < 1e-12);
        }
    }

    #[test]
    fn plane_covariance_from_a_normal() {
        let (points, normal) = tilted_plane();
        let tree = KdTree::new(&points);
        for c in plane_covariances(&points, &tree, 20, false).0 {
            assert!((c - plane_covariance(&normal)).abs().max() < 1e-6);
        }
    }

    #[test]
    fn mismatched_tree_does_not_panic() {
        let (points, _) = tilted_plane();
        let tree = KdTree::new(&points);
        let fewer = &points[..10];
        assert_eq!(normals(fewer, &tree, 20, false).0.len(), 10);
        assert_eq!(plane_covariances(fewer, &tree, 20, false).0.len(), 10);
    }

    #[test]
    fn shapeless_neighbourhoods() {
        // Three copies of one point and a NaN: no shape anywhere.
        let points = vec![[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [f32::NAN, 0.0, 0.0]];
        let tree = KdTree::new(&points);
        assert!(normals(&points, &tree, 20, false).0.iter().all(|n| *n == Vector3::zeros()));
        let covariances = plane_covariances(&points, &tree, 20, false).0;
        assert_eq!(covariances.len(), 4);
        assert!(covariances.iter().all(|c| *c == Matrix3::identity()));
    }
}
