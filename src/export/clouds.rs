//! Cloud and mesh writers: PCD (`binary`, `binary_compressed`) and PLY
//! (`binary_little_endian`), f32 x, y, z and intensity when the cloud has one; OBJ for a mesh.
//! The readers (`io`) return exactly the written values (bit for bit) for every valid point;
//! points the readers treat as missing returns (NaN/inf, exact zero) are written as given and
//! dropped again on reading.

use crate::cloud::Cloud;
use crate::lzf;

/// The intensity to write: present only when it has one value per point.
fn intensity_of(cloud: &Cloud) -> Option<&[f32]> {
    cloud.intensity.as_deref().filter(|v| v.len() == cloud.points.len())
}

fn pcd_header(shape: [usize; 2], with_intensity: bool, data: &str) -> String {
    let [width, height] = shape;
    let n = width * height;
    let (fields, size, ty, count) = if with_intensity {
        ("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 1")
    } else {
        ("x y z", "4 4 4", "F F F", "1 1 1")
    };
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\n\
         TYPE {ty}\nCOUNT {count}\nWIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n\
         DATA {data}\n"
    )
}

/// Little-endian f32 records `x y z [intensity]`, point after point.
fn point_major(cloud: &Cloud, intensity: Option<&[f32]>) -> Vec<u8> {
    let fields = if intensity.is_some() { 4 } else { 3 };
    let mut out = Vec::with_capacity(cloud.points.len() * fields * 4);
    for (i, p) in cloud.points.iter().enumerate() {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if let Some(value) = intensity.and_then(|v| v.get(i)) {
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
    out
}

/// A triangle mesh as Wavefront OBJ text: `v x y z` lines, then `f a b c` (1-based).
pub fn write_obj(mesh: &crate::mesh::Mesh) -> String {
    let mut out = String::from("# gmmcalib\n");
    for v in &mesh.vertices {
        out += &format!("v {:?} {:?} {:?}\n", v[0], v[1], v[2]);
    }
    for t in &mesh.triangles {
        out += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    out
}

/// PCD v0.7, `DATA binary`: `FIELDS x y z [intensity]`, all `F` of size 4, `HEIGHT 1`.
pub fn write_pcd_binary(cloud: &Cloud) -> Vec<u8> {
    binary_pcd(cloud, [cloud.len(), 1])
}

/// [`write_pcd_binary`] for an organized scan: `WIDTH width`, `HEIGHT height` (row-major
/// points, misses kept in place). `None` unless `width * height` is the point count.
pub fn write_pcd_binary_organized(cloud: &Cloud, width: usize, height: usize) -> Option<Vec<u8>> {
    (width.checked_mul(height) == Some(cloud.len())).then(|| binary_pcd(cloud, [width, height]))
}

fn binary_pcd(cloud: &Cloud, shape: [usize; 2]) -> Vec<u8> {
    let intensity = intensity_of(cloud);
    let mut out = pcd_header(shape, intensity.is_some(), "binary").into_bytes();
    out.extend_from_slice(&point_major(cloud, intensity));
    out
}

/// PCD v0.7, `DATA binary_compressed`: the same fields as [`write_pcd_binary`], laid out field
/// by field and LZF-compressed (stored raw when compression would not shrink it).
///
/// The format records sizes as u32, so a cloud of more than about 268 million points (4 GiB of
/// fields) cannot be written this way; `None` then.
pub fn write_pcd_binary_compressed(cloud: &Cloud) -> Option<Vec<u8>> {
    let intensity = intensity_of(cloud);
    let mut raw = Vec::with_capacity(cloud.len() * 16);
    for axis in 0..3 {
        raw.extend(cloud.points.iter().flat_map(|p| p[axis].to_le_bytes()));
    }
    raw.extend(intensity.unwrap_or_default().iter().flat_map(|v| v.to_le_bytes()));
    let mut packed = lzf::compress(&raw);
    if packed.len() >= raw.len() {
        packed = raw.clone();
    }
    let (packed_len, raw_len) = (u32::try_from(packed.len()).ok()?, u32::try_from(raw.len()).ok()?);
    let mut out =
        pcd_header([cloud.len(), 1], intensity.is_some(), "binary_compressed").into_bytes();
    out.extend_from_slice(&packed_len.to_le_bytes());
    out.extend_from_slice(&raw_len.to_le_bytes());
    out.extend_from_slice(&packed);
    Some(out)
}

/// PLY `binary_little_endian 1.0` with one `vertex` element: `float x, y, z [, intensity]`.
pub fn write_ply_binary(cloud: &Cloud) -> Vec<u8> {
    let intensity = intensity_of(cloud);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by gmmcalib\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n",
        cloud.len()
    );
    if intensity.is_some() {
        header.push_str("property float intensity\n");
    }
    header.push_str("end_header\n");
    let mut out = header.into_bytes();
    out.extend_from_slice(&point_major(cloud, intensity));
    out
}
