//! A triangle mesh placed in the twin's scene, with exact ray intersection (Möller & Trumbore
//! 1997), so targets of any shape can be scanned like the boxes.

use nalgebra::{Translation3, UnitQuaternion, Vector3};

use crate::cloud::Aabb;
use crate::mesh::Mesh;
use crate::se3::Pose;

/// A mesh at a pose: `pose` is `T_world_mesh` (the mesh's own coordinates, m, mapped into the
/// world frame).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshObject {
    mesh: Mesh,
    /// The mesh's bounds in its own frame: rays that miss them skip every triangle.
    bounds: Aabb,
    pub pose: Pose,
}

impl MeshObject {
    /// `mesh` placed at `pose` (`T_world_mesh`). Every index must name a vertex (as in any mesh
    /// [`crate::io::mesh::parse_mesh`] returns); ray casting panics otherwise.
    pub fn new(mesh: Mesh, pose: Pose) -> Self {
        Self { bounds: mesh.bounds(), mesh, pose }
    }

    /// `mesh` standing on the ground (its lowest point at z = 0, as [`Mesh::centred`] puts it)
    /// with its base centre at `(x, y)` (m), turned by `yaw` (rad) about world +z.
    pub fn on_ground(mesh: &Mesh, x: f64, y: f64, yaw: f64) -> Self {
        let pose = Pose::from_parts(
            Translation3::new(x, y, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        );
        Self::new(mesh.centred(), pose)
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// True when `p` (m, world) lies inside the mesh's bounding box (in its own frame) grown
    /// by `margin` (m) on every side.
    pub fn contains(&self, p: Vector3<f64>, margin: f64) -> bool {
        let q = self.pose.inverse_transform_vector(&(p - self.pose.translation.vector));
        (0..3).all(|i| q[i] >= self.bounds.min[i] - margin && q[i] <= self.bounds.max[i] + margin)
    }

    /// Distance (m) along the unit ray `origin + t dir` (world) to the nearest triangle, `None`
    /// when the ray misses or the hit lies beyond `max_range`. Triangles are two-sided.
    pub fn intersect(
        &self,
        origin: Vector3<f64>,
        dir: Vector3<f64>,
        max_range: f64,
    ) -> Option<f64> {
        // In the mesh's frame the rotation keeps `dir` a unit vector, so t is the same.
        let o = self.pose.inverse_transform_vector(&(origin - self.pose.translation.vector));
        let d = self.pose.inverse_transform_vector(&dir);
        if !self.ray_meets_bounds(&o, &d, max_range) {
            return None;
        }
        let corner = |i: u32| Vector3::from(self.mesh.vertices[i as usize]);
        self.mesh
            .triangles
            .iter()
            .filter_map(|t| moller_trumbore(&o, &d, [corner(t[0]), corner(t[1]), corner(t[2])]))
            .filter(|&t| t <= max_range)
            .min_by(f64::total_cmp)
    }

    /// Slab test against the (slightly grown) bounds: can the ray reach them within range?
    fn ray_meets_bounds(&self, o: &Vector3<f64>, d: &Vector3<f64>, max_range: f64) -> bool {
        const GROW: f64 = 1e-9;
        let (mut enter, mut exit) = (0.0f64, max_range);
        for i in 0..3 {
            let (lo, hi) = (self.bounds.min[i] - GROW, self.bounds.max[i] + GROW);
            if d[i] == 0.0 {
                if o[i] < lo || o[i] > hi {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo - o[i]) / d[i], (hi - o[i]) / d[i]);
            enter = enter.max(a.min(b));
            exit = exit.min(a.max(b));
        }
        enter <= exit
    }
}

/// Distance along the ray `o + t d` to triangle `[a, b, c]`, `None` when it misses, runs
/// parallel to it, or meets it behind the origin (Möller & Trumbore 1997, section 2).
fn moller_trumbore(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    [a, b, c]: [Vector3<f64>; 3],
) -> Option<f64> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(&e2);
    let det = e1.dot(&p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = d.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(&q) * inv;
    (t > 0.0).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::scene::OrientedBox;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// An axis-aligned box centred on the origin as 12 triangles.
    fn box_mesh(size: [f64; 3]) -> Mesh {
        let h = size.map(|s| s / 2.0);
        crate::twin::shapes::cuboid(h.map(|v| -v), h, 0)
    }

    #[test]
    fn a_box_mesh_is_hit_where_the_box_is() {
        let size = [1.0, 2.0, 0.5];
        let (centre, yaw) = ([10.0, -1.0, 0.25], 0.4);
        let exact = OrientedBox::new(centre, yaw, size);
        let pose = Pose::from_parts(
            Translation3::from(Vector3::from(centre)),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        );
        let mesh = MeshObject::new(box_mesh(size), pose);
        assert!((mesh.mesh().area() - 2.0 * (2.0 + 0.5 + 1.0)).abs() < 1e-12);
        let mut rng = Pcg64::seed_from_u64(4);
        let origin = Vector3::new(0.0, 0.0, 1.0);
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..4000 {
            let aim = Vector3::new(10.0, rng.random_range(-4.0..2.0), rng.random_range(-1.0..1.5));
            let dir = (aim - origin).normalize();
            match (exact.intersect(origin, dir, 50.0), mesh.intersect(origin, dir, 50.0)) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() < 1e-9, "{a} vs {b}");
                    hits += 1;
                }
                (None, None) => misses += 1,
                other => panic!("{other:?} along {dir:?}"),
            }
        }
        assert!(hits > 200 && misses > 200, "{hits} hits, {misses} misses");
        // Range and direction: nothing beyond max_range, nothing behind the origin.
        let dir = (Vector3::from(centre) - origin).normalize();
        let t = mesh.intersect(origin, dir, 50.0).expect("a hit");
        assert_eq!(mesh.intersect(origin, dir, t - 1e-6), None);
        assert_eq!(mesh.intersect(origin, -dir, 50.0), None);
        assert!(mesh.contains(origin + dir * t, 1e-9));
        assert!(!mesh.contains(origin, 0.1));
    }

    #[test]
    fn on_ground_stands_the_mesh_at_its_base() {
        let cube = box_mesh([0.5; 3]);
        let placed = MeshObject::on_ground(&cube, 12.0, 1.0, 0.3);
        // Straight down onto the top face from above its centre.
        let t = placed.intersect(Vector3::new(12.0, 1.0, 2.0), -Vector3::z(), 10.0);
        assert!((t.expect("a hit") - 1.5).abs() < 1e-12);
        assert!(placed.contains(Vector3::new(12.0, 1.0, 0.01), 0.0));
    }
}
