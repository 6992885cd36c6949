//! Any bytes named `.obj`, `.ply` or `.stl` (the first byte picks which; the rest is the file)
//! must parse to an error or to a mesh that is safe to use: indices in range, finite vertices, a
//! finite positive area, and finite samples. Never a panic.
#![no_main]

use gmmcalib::io::mesh::parse_mesh;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else { return };
    let name = ["fuzz.obj", "fuzz.ply", "fuzz.stl"][usize::from(pick % 3)];
    let Ok(mesh) = parse_mesh(bytes, name) else { return };
    let n = mesh.vertices.len();
    assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
    assert!(mesh.vertices.iter().flatten().all(|c| c.is_finite()));
    let area = mesh.area();
    assert!(area.is_finite() && area > 0.0, "area {area}");
    assert!(mesh.bounds().is_valid());
    for (p, normal) in mesh.sample_with_normals(8, 1) {
        assert!(p.iter().all(|c| c.is_finite()), "{p:?}");
        assert!(normal.iter().all(|c| c.is_finite()), "{normal:?}");
    }
});
