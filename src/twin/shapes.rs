//! Mesh targets built in code for the twin: a chair (GMMCalib's CAD-model target) and a board
//! on a stand. Each stands on z = 0 with its base centred on the origin ([`Mesh::centred`]'s
//! convention) and faces -x, towards sensors placed behind it at smaller x.

use crate::mesh::Mesh;

/// Faces of a cuboid, as bits: the ones a part leaves out where it meets another part (a
/// hidden face would draw surface samples that no sensor can see).
const BOTTOM: u8 = 1;
const TOP: u8 = 2;

/// A chair: a 0.45 x 0.45 m seat (0.04 m thick) with its top 0.45 m above the ground, four
/// 0.04 m square legs at its corners, and a backrest 0.45 m tall (0.04 m thick) standing on the
/// seat's back (+x) edge. About 0.9 m tall.
pub fn chair() -> Mesh {
    const SEAT: f64 = 0.45;
    const HEIGHT: f64 = 0.45;
    const SLAB: f64 = 0.04;
    const LEG: f64 = 0.04;
    let h = SEAT / 2.0;
    let mut parts = vec![cuboid([-h, -h, HEIGHT - SLAB], [h, h, HEIGHT], 0)];
    for (sx, sy) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
        // Flush with the seat's corner, so the seat's underside hides each leg's top.
        let (x, y) = (sx * (h - LEG / 2.0), sy * (h - LEG / 2.0));
        let r = LEG / 2.0;
        parts.push(cuboid([x - r, y - r, 0.0], [x + r, y + r, HEIGHT - SLAB], TOP));
    }
    parts.push(cuboid([h - SLAB, -h, HEIGHT], [h, h, HEIGHT + 0.45], BOTTOM));
    merge(&parts)
}

/// A board 0.8 m wide and 0.6 m tall (0.03 m thick), its lower edge 0.6 m above the ground, on
/// a 0.03 m square pole standing on a 0.4 x 0.4 x 0.02 m foot.
pub fn board_on_stand() -> Mesh {
    const FOOT: f64 = 0.02;
    const LOWER_EDGE: f64 = 0.6;
    let (t, pole) = (0.03 / 2.0, 0.03 / 2.0);
    merge(&[
        cuboid([-0.2, -0.2, 0.0], [0.2, 0.2, FOOT], 0),
        cuboid([-pole, -pole, FOOT], [pole, pole, LOWER_EDGE], BOTTOM | TOP),
        cuboid([-t, -0.4, LOWER_EDGE], [t, 0.4, LOWER_EDGE + 0.6], 0),
    ])
}

/// The axis-aligned box between `lo` and `hi` (m) as triangles wound counter-clockwise seen
/// from outside, less the faces named in `skip`.
pub(super) fn cuboid(lo: [f64; 3], hi: [f64; 3], skip: u8) -> Mesh {
    // Corner k takes hi on axis i when bit i of k is set.
    let vertices = (0..8)
        .map(|k: usize| std::array::from_fn(|i| if k >> i & 1 == 1 { hi[i] } else { lo[i] }))
        .collect();
    let quads: [(u8, [u32; 4]); 6] = [
        (BOTTOM, [0, 2, 3, 1]),
        (TOP, [4, 5, 7, 6]),
        (0, [0, 1, 5, 4]),
        (0, [2, 6, 7, 3]),
        (0, [0, 4, 6, 2]),
        (0, [1, 3, 7, 5]),
    ];
    let triangles = quads
        .iter()
        .filter(|(face, _)| face & skip == 0)
        .flat_map(|(_, q)| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh { vertices, triangles }
}

/// One mesh of all `parts` (indices shifted; coincident corners kept apart).
fn merge(parts: &[Mesh]) -> Mesh {
    let mut out = Mesh::default();
    for part in parts {
        let base = out.vertices.len() as u32;
        out.vertices.extend_from_slice(&part.vertices);
        out.triangles.extend(part.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::Aabb;

    fn close(a: Aabb, b: Aabb) -> bool {
        (0..3).all(|i| (a.min[i] - b.min[i]).abs() < 1e-12 && (a.max[i] - b.max[i]).abs() < 1e-12)
    }

    #[test]
    fn shapes_stand_centred_on_the_origin_with_outward_faces() {
        let chair = chair();
        assert!(close(chair.bounds(), Aabb::new([-0.225, -0.225, 0.0], [0.225, 0.225, 0.9])));
        let board = board_on_stand();
        assert!(close(board.bounds(), Aabb::new([-0.2, -0.4, 0.0], [0.2, 0.4, 1.2])));
        for mesh in [chair, board] {
            assert!(close(mesh.centred().bounds(), mesh.bounds()), "already centred");
            // Every part is a convex box, so outward normals point away from its own centre:
            // checked through the samples against the whole mesh's normals.
            for (p, n) in mesh.sample_with_normals(500, 2) {
                assert!((n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0).abs() < 1e-12);
                assert!(p.iter().all(|c| c.is_finite()));
            }
        }
        // A cuboid's winding is outward: the top face's normal is +z.
        let top = cuboid([0.0; 3], [1.0; 3], 0);
        let up = top.sample_with_normals(200, 1).into_iter().filter(|(p, _)| p[2] == 1.0);
        assert!(up.into_iter().all(|(_, n)| n == [0.0, 0.0, 1.0]));
        let area = |m: &Mesh| m.area();
        assert!((area(&top) - 6.0).abs() < 1e-12);
        assert!((area(&cuboid([0.0; 3], [1.0; 3], TOP | BOTTOM)) - 4.0).abs() < 1e-12);
    }
}
