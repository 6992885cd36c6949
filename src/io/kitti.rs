//! KITTI Velodyne scans (`.bin`): a bare array of little-endian f32 records `x, y, z,
//! intensity` (metres; reflectance in 0..1), 16 bytes per point, no header.

use super::decode::{Builder, Column, Endian, Scalar, decode_columns};
use super::{Decoded, Fault, Format};

const RECORD: usize = 16;

/// Reads a KITTI `.bin` scan.
pub(crate) fn read(bytes: &[u8]) -> Result<Decoded, Fault> {
    if bytes.len() % RECORD != 0 {
        let problem = format!(
            "length {} is not a multiple of {RECORD} bytes (f32 x, y, z, intensity per point)",
            bytes.len()
        );
        return Err(Fault::byte(bytes.len() - bytes.len() % RECORD, problem));
    }
    let n = bytes.len() / RECORD;
    let column = |k: usize| Column { base: 4 * k, stride: RECORD, ty: Scalar::F32 };
    let mut out = Builder::new(n, true);
    let xyz = [column(0), column(1), column(2)];
    // The length check above makes every record whole, so decoding cannot run short.
    if !decode_columns(bytes, n, xyz, Some(column(3)), Endian::Little, &mut out) {
        return Err(Fault::whole("internal: KITTI records out of range"));
    }
    let (cloud, dropped) = out.finish();
    Ok(Decoded { cloud, dropped, format: Format::KittiBin, width: n, height: 1, viewpoint: None })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_records_and_drops_missing_returns() {
        let values = [1.0f32, 2.0, 3.0, 0.5, 0.0, 0.0, 0.0, 0.9, -4.0, 5.5, 6.25, 0.1];
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let decoded = read(&bytes).unwrap();
        assert_eq!(decoded.cloud.points, vec![[1.0, 2.0, 3.0], [-4.0, 5.5, 6.25]]);
        assert_eq!(decoded.cloud.intensity, Some(vec![0.5, 0.1]));
        assert_eq!((decoded.dropped, decoded.width, decoded.height), (1, 3, 1));
    }

    #[test]
    fn rejects_partial_records() {
        let fault = read(&[0u8; 35]).err().unwrap();
        assert_eq!(fault.offset, Some(super::super::Offset::Byte(32)));
        assert!(fault.problem.contains("not a multiple of 16"), "{}", fault.problem);
        assert!(read(&[]).unwrap().cloud.is_empty());
    }
}
