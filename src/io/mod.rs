//! Point-cloud readers: bytes in, values out (the writers are `export`'s). No filesystem
//! access here, so the same code serves the CLI and the browser (where files arrive as
//! `ArrayBuffer`s).
//!
//! Formats: PCD v0.6/v0.7 (`ascii`, `binary`, `binary_compressed`), PLY (`ascii`,
//! `binary_little_endian`, `binary_big_endian`) and KITTI `.bin` (f32 x, y, z, intensity).
//! [`parse_cloud`] picks the reader by file extension and returns a [`ParsedCloud`]; every failure
//! is an [`IoError`] naming the file, the position and the problem. No input panics: sizes from
//! headers are checked against the bytes actually present before anything is allocated.
//!
//! Triangle meshes (a target's shape: OBJ, PLY, STL) are read by [`mesh::parse_mesh`].
//!
//! Missing returns (NaN/inf coordinates and exact zeros `0 0 0`, `-0 0 0`) are dropped while
//! decoding and counted in [`ParsedCloud::dropped`]. Coordinates are metres as stored.

mod decode;
mod kitti;
pub mod mesh;
pub mod opencalib;
mod pcd;
mod ply;
pub mod recording;
mod text;

use std::fmt;

use crate::cloud::Cloud;
use crate::se3::Pose;

/// The on-disk encoding a cloud was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    PcdAscii,
    PcdBinary,
    PcdBinaryCompressed,
    PlyAscii,
    PlyBinaryLittleEndian,
    PlyBinaryBigEndian,
    KittiBin,
}

impl fmt::Display for Format {
    /// The format's own spelling, e.g. `PCD binary_compressed`, `PLY binary_big_endian`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::PcdAscii => "PCD ascii",
            Format::PcdBinary => "PCD binary",
            Format::PcdBinaryCompressed => "PCD binary_compressed",
            Format::PlyAscii => "PLY ascii",
            Format::PlyBinaryLittleEndian => "PLY binary_little_endian",
            Format::PlyBinaryBigEndian => "PLY binary_big_endian",
            Format::KittiBin => "KITTI bin",
        })
    }
}

/// Where in a file a problem was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Offset {
    /// 1-based line number (headers and ASCII data).
    Line(usize),
    /// 0-based byte offset from the start of the file (binary data).
    Byte(usize),
}

/// A file that could not be read: which file, where, and what is wrong with it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IoError {
    pub file: String,
    pub offset: Option<Offset>,
    pub problem: String,
}

impl fmt::Display for IoError {
    /// `scan.pcd, line 7: unknown TYPE/SIZE pair F/2`, `scan.ply, byte 812: ...`, `scan.xyz: ...`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset {
            Some(Offset::Line(n)) => write!(f, "{}, line {}: {}", self.file, n, self.problem),
            Some(Offset::Byte(n)) => write!(f, "{}, byte {}: {}", self.file, n, self.problem),
            None => write!(f, "{}: {}", self.file, self.problem),
        }
    }
}

impl std::error::Error for IoError {}

/// A problem found by a reader, before the file name is attached (readers see only bytes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Fault {
    pub offset: Option<Offset>,
    pub problem: String,
}

impl Fault {
    pub fn line(line: usize, problem: impl Into<String>) -> Self {
        Self { offset: Some(Offset::Line(line)), problem: problem.into() }
    }

    pub fn byte(byte: usize, problem: impl Into<String>) -> Self {
        Self { offset: Some(Offset::Byte(byte)), problem: problem.into() }
    }

    pub fn whole(problem: impl Into<String>) -> Self {
        Self { offset: None, problem: problem.into() }
    }

    fn in_file(self, file: &str) -> IoError {
        IoError { file: file.to_string(), offset: self.offset, problem: self.problem }
    }
}

/// What a format reader hands back; [`parse_cloud_with`] turns it into a [`ParsedCloud`].
pub(crate) struct Decoded {
    pub cloud: Cloud,
    pub dropped: usize,
    pub format: Format,
    pub width: usize,
    pub height: usize,
    /// The PCD `VIEWPOINT` when present and not the identity.
    pub viewpoint: Option<Pose>,
}

/// A cloud read from a file, with what the reader learned about it.
#[derive(Clone, Debug, PartialEq)]
pub struct ParsedCloud {
    /// Valid points only (metres), with `intensity` when the file has an intensity field.
    pub cloud: Cloud,
    /// Points removed because a coordinate was NaN/inf or the return was exactly `0 0 0`.
    pub dropped: usize,
    pub format: Format,
    /// Declared width and height (PCD `WIDTH`/`HEIGHT`; for PLY and KITTI, the point count and 1).
    /// `width * height` counts the points before dropping.
    pub width: usize,
    pub height: usize,
    /// True when a non-identity PCD `VIEWPOINT` was applied to the points.
    pub viewpoint_applied: bool,
}

/// Reader settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadOptions {
    /// Map PCD points through their `VIEWPOINT tx ty tz qw qx qy qz` (`p' = R p + t`) when it is not
    /// the identity. Missing returns are dropped first, in the sensor frame, where they are zero.
    pub apply_viewpoint: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self { apply_viewpoint: true }
    }
}

/// Parses a point cloud with [`ReadOptions::default`], choosing the reader from the extension of
/// `file_name` (`.pcd`, `.ply`, `.bin`, any case). `file_name` also labels every error.
pub fn parse_cloud(bytes: &[u8], file_name: &str) -> Result<ParsedCloud, IoError> {
    parse_cloud_with(bytes, file_name, &ReadOptions::default())
}

/// [`parse_cloud`] with explicit options.
pub fn parse_cloud_with(
    bytes: &[u8],
    file_name: &str,
    opts: &ReadOptions,
) -> Result<ParsedCloud, IoError> {
    let extension = file_name.rsplit_once('.').map(|(_, ext)| ext.to_ascii_lowercase());
    let decoded = match extension.as_deref() {
        Some("pcd") => pcd::read(bytes),
        Some("ply") => ply::read(bytes),
        Some("bin") => kitti::read(bytes),
        _ => Err(Fault::whole("unknown extension: expected .pcd, .ply or .bin")),
    }
    .map_err(|fault| fault.in_file(file_name))?;

    let mut cloud = decoded.cloud;
    let mut dropped = decoded.dropped;
    let mut viewpoint_applied = false;
    if let (true, Some(pose)) = (opts.apply_viewpoint, decoded.viewpoint) {
        transform_in_place(&mut cloud.points, &pose);
        dropped += drop_overflowed(&mut cloud);
        viewpoint_applied = true;
    }
    Ok(ParsedCloud {
        cloud,
        dropped,
        format: decoded.format,
        width: decoded.width,
        height: decoded.height,
        viewpoint_applied,
    })
}

/// `p = pose * p` for every point, computed in f64.
fn transform_in_place(points: &mut [[f32; 3]], pose: &Pose) {
    let m = pose.to_homogeneous();
    for p in points {
        let v = p.map(f64::from);
        *p = std::array::from_fn(|r| {
            (m[(r, 0)] * v[0] + m[(r, 1)] * v[1] + m[(r, 2)] * v[2] + m[(r, 3)]) as f32
        });
    }
}

/// Drops points that a viewpoint pushed beyond the f32 range (coordinates near 3e38 m: only in
/// corrupt files, but every returned point must be finite). Returns how many were dropped.
fn drop_overflowed(cloud: &mut Cloud) -> usize {
    let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite());
    if cloud.points.iter().all(finite) {
        return 0;
    }
    let before = cloud.points.len();
    if let Some(intensity) = &mut cloud.intensity {
        let mut keep = cloud.points.iter().map(finite);
        intensity.retain(|_| keep.next().unwrap_or(false));
    }
    cloud.points.retain(finite);
    before - cloud.points.len()
}
