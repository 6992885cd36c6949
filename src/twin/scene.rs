//! Scene geometry of the digital twin: an optional ground plane (z = 0), oriented boxes and
//! placed triangle meshes ([`MeshObject`]), with exact ray intersection. All coordinates are in the world (here: vehicle) frame, metres.

use nalgebra::Vector3;

use super::mesh_object::MeshObject;

/// A box standing upright, turned about the world +z axis.
#[derive(Clone, Debug, PartialEq)]
pub struct OrientedBox {
    /// Centre (m, world frame).
    pub centre: Vector3<f64>,
    /// Rotation about world +z (rad), counter-clockwise seen from above.
    pub yaw: f64,
    /// Edge lengths along the box's own x, y, z axes (m).
    pub size: Vector3<f64>,
}

impl OrientedBox {
    /// A box from its centre (m), yaw (rad) and edge lengths (m).
    pub fn new(centre: [f64; 3], yaw: f64, size: [f64; 3]) -> Self {
        Self { centre: centre.into(), yaw, size: size.into() }
    }

    /// A cube of edge `edge` (m) resting on the ground (z = 0) with its centre above `(x, y)` (m).
    pub fn cube_on_ground(x: f64, y: f64, edge: f64, yaw: f64) -> Self {
        Self::new([x, y, edge / 2.0], yaw, [edge; 3])
    }

    /// A world-frame vector expressed in the box's axes (rotation by `-yaw` about z).
    fn to_local(&self, v: Vector3<f64>) -> Vector3<f64> {
        let (s, c) = self.yaw.sin_cos();
        Vector3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z)
    }

    /// True when `p` (m, world) lies inside the box grown by `margin` (m) on every side.
    pub fn contains(&self, p: Vector3<f64>, margin: f64) -> bool {
        let q = self.to_local(p - self.centre);
        (0..3).all(|i| q[i].abs() <= self.size[i] / 2.0 + margin)
    }

    /// Distance (m) along the unit ray `origin + t dir` to the box surface, `None` when the ray
    /// misses or the hit lies beyond `max_range`. Slab method in the box's own frame; from inside
    /// the box the exit point is returned.
    pub fn intersect(
        &self,
        origin: Vector3<f64>,
        dir: Vector3<f64>,
        max_range: f64,
    ) -> Option<f64> {
        let o = self.to_local(origin - self.centre);
        let d = self.to_local(dir);
        let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..3 {
            let h = self.size[i] / 2.0;
            if d[i] == 0.0 {
                // Parallel to this slab: inside it everywhere or nowhere.
                if o[i].abs() > h {
                    return None;
                }
                continue;
            }
            let (a, b) = ((-h - o[i]) / d[i], (h - o[i]) / d[i]);
            enter = enter.max(a.min(b));
            exit = exit.min(a.max(b));
        }
        if enter > exit || exit < 0.0 {
            return None;
        }
        let t = if enter >= 0.0 { enter } else { exit };
        (t <= max_range).then_some(t)
    }
}

/// What the rays can hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Whether the ground plane z = 0 is present.
    pub ground: bool,
    pub boxes: Vec<OrientedBox>,
    /// Triangle meshes (targets of any shape).
    pub meshes: Vec<MeshObject>,
}

impl Scene {
    /// Distance (m) along the unit ray to the plane z = 0, `None` when the ray runs parallel to
    /// it, away from it, or hits it beyond `max_range`.
    pub fn intersect_ground(
        origin: Vector3<f64>,
        dir: Vector3<f64>,
        max_range: f64,
    ) -> Option<f64> {
        if dir.z == 0.0 {
            return None;
        }
        let t = -origin.z / dir.z;
        (t >= 0.0 && t <= max_range).then_some(t)
    }

    /// Distance (m) to the nearest surface along the unit ray `origin + t dir`, `None` when
    /// nothing lies within `max_range` (m).
    pub fn intersect(
        &self,
        origin: Vector3<f64>,
        dir: Vector3<f64>,
        max_range: f64,
    ) -> Option<f64> {
        let ground =
            if self.ground { Self::intersect_ground(origin, dir, max_range) } else { None };
        // Boxes first, then meshes, then the ground: `min_by` keeps the first of equal
        // distances, so a scene without meshes casts exactly as before they existed.
        self.boxes
            .iter()
            .filter_map(|b| b.intersect(origin, dir, max_range))
            .chain(self.meshes.iter().filter_map(|m| m.intersect(origin, dir, max_range)))
            .chain(ground)
            .min_by(f64::total_cmp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const X: Vector3<f64> = Vector3::new(1.0, 0.0, 0.0);

    #[test]
    fn axis_aligned_box_hit_at_exact_range() {
        let b = OrientedBox::new([10.0, 0.0, 1.0], 0.0, [1.0, 2.0, 2.0]);
        let t = b.intersect(Vector3::new(0.0, 0.3, 1.2), X, 100.0).unwrap();
        assert!((t - 9.5).abs() < 1e-9, "{t}");
        // From the far side, along -x.
        let t = b.intersect(Vector3::new(20.0, 0.0, 1.0), -X, 100.0).unwrap();
        assert!((t - 9.5).abs() < 1e-9, "{t}");
        // Just past the side face: a miss.
        assert_eq!(b.intersect(Vector3::new(0.0, 1.01, 1.0), X, 100.0), None);
        // Behind the origin: a miss.
        assert_eq!(b.intersect(Vector3::new(20.0, 0.0, 1.0), X, 100.0), None);
    }

    #[test]
    fn yawed_box_hit_at_exact_range() {
        let yaw = 30f64.to_radians();
        let b = OrientedBox::new([10.0, 0.0, 0.25], yaw, [1.0, 1.0, 0.5]);
        // The near face has outward normal (-cos yaw, -sin yaw) at distance 0.5 from the centre.
        let expected = 10.0 - 0.5 / yaw.cos();
        let t = b.intersect(Vector3::new(0.0, 0.0, 0.25), X, 100.0).unwrap();
        assert!((t - expected).abs() < 1e-9, "{t} vs {expected}");
        // An unrotated box would be hit at 9.5 instead: the yaw matters.
        assert!((t - 9.5).abs() > 0.05);
        // A ray along the diagonal of a 45 deg box hits the vertex at 10 - sqrt(2)/2.
        let b45 = OrientedBox::new([10.0, 0.0, 0.0], 45f64.to_radians(), [1.0, 1.0, 1.0]);
        let t = b45.intersect(Vector3::zeros(), X, 100.0).unwrap();
        assert!((t - (10.0 - 0.5 * 2f64.sqrt())).abs() < 1e-9, "{t}");
    }

    #[test]
    fn ground_hit_at_exact_range_and_up_ray_misses() {
        let scene = Scene { ground: true, ..Default::default() };
        let origin = Vector3::new(1.0, 2.0, 1.6);
        let dir = Vector3::new(3.0, 4.0, -1.6).normalize();
        let expected = (9.0f64 + 16.0 + 1.6 * 1.6).sqrt();
        let t = scene.intersect(origin, dir, 50.0).unwrap();
        assert!((t - expected).abs() < 1e-9, "{t} vs {expected}");
        let p = origin + dir * t;
        assert!(p.z.abs() < 1e-12 && (p.x - 4.0).abs() < 1e-9 && (p.y - 6.0).abs() < 1e-9);
        assert_eq!(scene.intersect(origin, Vector3::new(0.6, 0.0, 0.8), 50.0), None);
        assert_eq!(scene.intersect(origin, X, 50.0), None);
    }

    #[test]
    fn nothing_beyond_max_range() {
        let scene = Scene {
            ground: true,
            boxes: vec![OrientedBox::new([10.0, 0.0, 1.0], 0.0, [1.0, 1.0, 1.0])],
            ..Default::default()
        };
        let origin = Vector3::new(0.0, 0.0, 1.0);
        assert!(scene.intersect(origin, X, 9.6).is_some());
        assert_eq!(scene.intersect(origin, X, 9.4), None);
        let down = Vector3::new(1.0, 0.0, -1.0).normalize();
        assert!(scene.intersect(origin, down, 1.5).is_some());
        assert_eq!(scene.intersect(origin, down, 1.4), None);
    }

    #[test]
    fn nearest_surface_wins() {
        let scene = Scene {
            ground: true,
            boxes: vec![
                OrientedBox::new([20.0, 0.0, 1.0], 0.0, [1.0, 1.0, 2.0]),
                OrientedBox::new([10.0, 0.0, 1.0], 0.3, [1.0, 1.0, 2.0]),
            ],
            ..Default::default()
        };
        // Slightly downward: would reach the ground at 100 m, the near box comes first.
        let dir = Vector3::new(1.0, 0.0, -0.01).normalize();
        let t = scene.intersect(Vector3::new(0.0, 0.0, 1.0), dir, 200.0).unwrap();
        let single = scene.boxes[1].intersect(Vector3::new(0.0, 0.0, 1.0), dir, 200.0).unwrap();
        assert_eq!(t, single);
        assert!(t < 10.0);
    }

    #[test]
    fn contains_respects_yaw_and_margin() {
        let b = OrientedBox::cube_on_ground(10.0, 0.0, 0.5, 45f64.to_radians());
        assert!(b.contains(Vector3::new(10.0 + 0.34, 0.0, 0.25), 0.0));
        assert!(!b.contains(Vector3::new(10.0 + 0.36, 0.0, 0.25), 0.0));
        assert!(b.contains(Vector3::new(10.0, 0.0, 0.52), 0.03));
        assert!(!b.contains(Vector3::new(10.0, 0.0, 0.52), 0.01));
    }
}
