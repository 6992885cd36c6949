use super::*;
use crate::cloud::Aabb;
use crate::io::Offset;
use crate::mesh::triangle_area;

/// A unit cube [0, 1]^3 as OBJ quads, with the forms writers use: `v/vt/vn`, `v//vn`, negative
/// (relative) indices, comments, and statements the reader skips.
const CUBE_OBJ: &str = "# a cube\nmtllib cube.mtl\no cube\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1 # last\n\
vt 0 0\nvn 0 0 -1\ns off\n\
f 1/1/1 4/1/1 3/1/1 2/1/1\nf 5//1 6//1 7//1 8//1\n\
f -8 -7 -3 -4\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

fn err(bytes: &[u8], name: &str) -> IoError {
    parse_mesh(bytes, name).expect_err("an error")
}

fn unit_cube() -> Mesh {
    parse_mesh(CUBE_OBJ.as_bytes(), "cube.obj").expect("a cube")
}

/// The cube's 12 triangles as binary STL, its header beginning with "solid" as many writers do.
fn cube_stl_binary() -> Vec<u8> {
    let cube = unit_cube();
    let mut out = b"solid cube, binary all the same".to_vec();
    out.resize(80, b' ');
    out.extend_from_slice(&(cube.triangles.len() as u32).to_le_bytes());
    for t in &cube.triangles {
        out.extend_from_slice(&[0u8; 12]);
        for i in t {
            for c in cube.vertices[*i as usize] {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        out.extend_from_slice(&[0u8; 2]);
    }
    out
}

#[test]
fn obj_cube_has_area_six_and_unit_bounds() {
    let cube = unit_cube();
    assert_eq!(cube.vertices.len(), 8);
    assert_eq!(cube.triangles.len(), 12, "six quads fanned into two triangles each");
    assert!((cube.area() - 6.0).abs() < 1e-12);
    assert_eq!(cube.bounds(), Aabb::new([0.0; 3], [1.0; 3]));
    // Relative indices resolve against the vertices seen so far: -8 is the first.
    assert_eq!(cube.triangles[4], [0, 1, 5]);
}

#[test]
fn stl_ascii_and_binary_give_the_obj_cube() {
    let cube = unit_cube();
    let binary = parse_mesh(&cube_stl_binary(), "cube.STL").expect("binary STL");
    let mut ascii = String::from("solid cube\n");
    for t in &cube.triangles {
        ascii += "  facet normal 0 0 0\n    outer loop\n";
        for i in t {
            let [x, y, z] = cube.vertices[*i as usize];
            ascii += &format!("      vertex {x} {y} {z}\n");
        }
        ascii += "    endloop\n  endfacet\n";
    }
    ascii += "endsolid cube\n";
    let ascii = parse_mesh(ascii.as_bytes(), "cube.stl").expect("ascii STL");
    for mesh in [binary, ascii] {
        assert_eq!(mesh.vertices.len(), 8, "repeated corners merged");
        assert_eq!(mesh.triangles.len(), 12);
        assert!((mesh.area() - 6.0).abs() < 1e-12);
        assert_eq!(mesh.bounds(), cube.bounds());
    }
}

#[test]
fn ply_faces_may_come_first_and_big_endian_reads() {
    let ascii = "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\nend_header\n\
        4 0 1 2 3\n0 0 0\n2 0 0\n2 1 0\n0 1 0\n";
    let mesh = parse_mesh(ascii.as_bytes(), "quad.ply").expect("a quad");
    assert_eq!(mesh.triangles, [[0, 1, 2], [0, 2, 3]]);
    assert!((mesh.area() - 2.0).abs() < 1e-12);

    let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\n\
        property double y\nproperty double z\nproperty uchar extra\nelement face 1\n\
        property list uchar uint vertex_index\nend_header\n"
        .to_vec();
    for p in [[0.0f64, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]] {
        p.iter().for_each(|c| be.extend_from_slice(&c.to_be_bytes()));
        be.push(7);
    }
    be.push(3);
    [0u32, 1, 2].iter().for_each(|i| be.extend_from_slice(&i.to_be_bytes()));
    let mesh = parse_mesh(&be, "tri.ply").expect("a triangle");
    assert_eq!(mesh.vertices[2], [0.0, 4.0, 0.0]);
    assert!((mesh.area() - 6.0).abs() < 1e-12);
    let cut = err(&be[..be.len() - 2], "tri.ply");
    assert!(cut.problem.starts_with("truncated"), "{cut}");
    assert!(matches!(cut.offset, Some(Offset::Byte(_))));
}

#[test]
fn bad_meshes_are_named_errors() {
    let cases: [(&[u8], &str, &str); 12] = [
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "a.obj", "no faces"),
        (b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "a.obj", "not finite"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "a.obj", "index out of range"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "a.obj", "index out of range"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", "a.obj", "index out of range"),
        (b"v 0 0 0\nv 1 0 0\nf 1 2\n", "a.obj", "3 or more corners"),
        (b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "a.obj", "zero area"),
        (
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
              property float z\nend_header\n1 2 3\n",
            "a.ply",
            "a point cloud, not a mesh: it has no faces",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
              property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
              end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
            "a.ply",
            "index out of range",
        ),
        (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", "a.stl", "truncated"),
        (&[0u8; 40], "a.stl", "truncated"),
        (b"v 0 0 0", "a.off", "unknown mesh extension"),
    ];
    for (bytes, name, expected) in cases {
        let e = err(bytes, name);
        assert!(e.problem.contains(expected), "{name}: {e} (expected {expected})");
        assert_eq!(e.file, name);
    }
    // A binary STL cut short says how much is missing, at the byte where the data stops.
    let stl = cube_stl_binary();
    let e = err(&stl[..stl.len() - 10], "cut.stl");
    assert!(e.problem.contains("declares 12 triangles"), "{e}");
    assert_eq!(e.offset, Some(Offset::Byte(84 + 11 * 50)));
    // Errors carry their line.
    let e = err(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "line.obj");
    assert_eq!(e.offset, Some(Offset::Line(4)));
}

#[test]
fn samples_are_seeded_on_the_surface_and_area_weighted() {
    let cube = unit_cube();
    let a = cube.sample_with_normals(3000, 5);
    assert_eq!(a, cube.sample_with_normals(3000, 5));
    assert_ne!(cube.sample(10, 5), cube.sample(10, 6));
    assert_eq!(cube.sample(10, 5), a[..10].iter().map(|(p, _)| *p).collect::<Vec<_>>());
    let mut per_face = [0usize; 6];
    for (p, n) in &a {
        // On a face: one coordinate at 0 or 1, the normal along that axis.
        let axis = (0..3).find(|&i| (n[i].abs() - 1.0).abs() < 1e-12).expect("an axis normal");
        let far = (p[axis] - 1.0).abs() < 1e-12;
        assert!(far || p[axis].abs() < 1e-12, "{p:?} {n:?}");
        assert!(p.iter().all(|c| (-1e-12..=1.0 + 1e-12).contains(c)));
        per_face[2 * axis + usize::from(far)] += 1;
    }
    // Equal faces, equal shares: 500 each, within 4 standard deviations (about 20).
    assert!(per_face.iter().all(|&n| n.abs_diff(500) < 90), "{per_face:?}");
    // Two triangles of areas 1 and 3: a quarter of the points on the first.
    let pair = Mesh {
        vertices: vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 5.0]],
        triangles: vec![[0, 1, 2], [1, 2, 3]],
    };
    let on_first = pair.sample(8000, 1).iter().filter(|p| p[2] == 0.0).count();
    let share = on_first as f64 / 8000.0;
    let expected = 1.0 / (1.0 + pair_area_second());
    assert!((share - expected).abs() < 0.02, "{share} vs {expected}");
    assert!(Mesh::default().sample(5, 1).is_empty());
}

/// Area of the second triangle of the pair above: corners (2,0,0), (0,1,0), (0,0,5).
fn pair_area_second() -> f64 {
    triangle_area([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 5.0]])
}

#[test]
fn centred_puts_the_base_centre_at_the_origin() {
    let mut cube = unit_cube();
    cube.vertices.iter_mut().for_each(|p| *p = [p[0] + 3.0, p[1] - 7.0, p[2] * 2.0 + 0.5]);
    let c = cube.centred();
    assert_eq!(c.bounds(), Aabb::new([-0.5, -0.5, 0.0], [0.5, 0.5, 2.0]));
    assert_eq!(c.triangles, cube.triangles);
    assert!((c.area() - cube.area()).abs() < 1e-12);
}
