//! Mesh readers against committed fixtures (tests/fixtures/mesh, written by
//! make_meshes.py with trimesh, plyfile and numpy-stl: writers independent of ours).

use gmmcalib::Aabb;
use gmmcalib::io::mesh::{Mesh, parse_mesh};
use gmmcalib::io::{IoError, Offset};

fn fixture(name: &str) -> Vec<u8> {
    let path = format!("{}/tests/fixtures/mesh/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn parse(name: &str) -> Result<Mesh, IoError> {
    parse_mesh(&fixture(name), name)
}

#[test]
fn the_unit_cube_reads_alike_in_every_format() {
    let cube = Aabb::new([-0.5; 3], [0.5; 3]);
    for name in ["cube.obj", "cube_ascii.ply", "cube_le.ply", "cube_ascii.stl", "cube_binary.stl"] {
        let mesh = parse(name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(mesh.triangles.len(), 12, "{name}");
        assert_eq!(mesh.vertices.len(), 8, "{name}: STL's repeated corners merged");
        assert!((mesh.area() - 6.0).abs() < 1e-9, "{name}: area {}", mesh.area());
        assert_eq!(mesh.bounds(), cube, "{name}");
        // Standing on the ground: the base centre at the origin.
        assert_eq!(mesh.centred().bounds(), Aabb::new([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0]));
        // Samples lie on the surface: one coordinate at +-0.5, the normal along it.
        for (p, n) in mesh.sample_with_normals(200, 3) {
            let axis = (0..3).find(|&i| (n[i].abs() - 1.0).abs() < 1e-9).expect("axis normal");
            assert!((p[axis].abs() - 0.5).abs() < 1e-9, "{name}: {p:?} off the face {n:?}");
            // Outward: the formats' winding is counter-clockwise seen from outside.
            assert!(p[axis] * n[axis] > 0.0, "{name}: normal {n:?} inward at {p:?}");
        }
    }
}

#[test]
fn bad_meshes_give_named_errors() {
    let cases = [
        ("bad_no_faces.ply", "no faces"),
        ("bad_nan.ply", "not finite"),
        ("bad_index.ply", "index out of range"),
        ("bad_point_cloud.ply", "a point cloud, not a mesh: it has no faces"),
        ("bad_truncated.stl", "truncated"),
    ];
    for (name, expected) in cases {
        let e = parse(name).expect_err(name);
        eprintln!("{e}");
        assert_eq!(e.file, name);
        assert!(e.problem.contains(expected), "{e} (expected '{expected}')");
    }
    // Where it went wrong: the line of the bad face, the byte where the data stops.
    assert!(matches!(parse("bad_index.ply").unwrap_err().offset, Some(Offset::Line(_))));
    let cut = parse("bad_truncated.stl").unwrap_err();
    assert_eq!(cut.offset, Some(Offset::Byte(84 + 11 * 50)), "{cut}");
}

#[test]
fn sampling_is_deterministic_per_seed() {
    let mesh = parse("cube.obj").expect("a cube");
    assert_eq!(mesh.sample(500, 42), mesh.sample(500, 42));
    assert_ne!(mesh.sample(500, 42), mesh.sample(500, 43));
    // Uniform over the surface: the mean of many samples is the cube's centre.
    let points = mesh.sample(20_000, 1);
    for i in 0..3 {
        let mean = points.iter().map(|p| p[i]).sum::<f64>() / points.len() as f64;
        assert!(mean.abs() < 0.01, "axis {i}: mean {mean}");
    }
}
