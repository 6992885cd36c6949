//! Livox's `CustomMsg` (`livox_ros_driver/CustomMsg`, `livox_ros_driver2/CustomMsg` and
//! `livox_ros_driver2/msg/CustomMsg`) to the same [`PointCloud`] as a PointCloud2 gives.
//!
//! ```text
//! std_msgs/Header header
//! uint64 timebase          # ns, the first point's time
//! uint32 point_num         # not used: the sequence's own length counts the points
//! uint8 lidar_id
//! uint8[3] rsvd
//! CustomPoint[] points     # uint32 offset_time; float32 x, y, z (m); uint8 reflectivity,
//!                          # tag, line
//! ```
//!
//! A point is 19 bytes. ROS 1 packs them; CDR aligns each point's `offset_time` to 4, so a
//! point takes 20 bytes there (the last one 19), and `timebase` is aligned to 8.
//! Reflectivity (0..255) becomes the intensity. Missing returns (a NaN or infinite coordinate,
//! or exactly `0 0 0`) are dropped and counted as for a PointCloud2. The `tag` (the driver's
//! noise confidence and return number, whose bits differ between models) is not used: every
//! other point is kept, as the driver published it.

use super::index::Encoding;
use super::pointcloud2::PointCloud;
use super::wire::Wire;
use crate::cloud::Cloud;

/// Bytes of one point's fields.
const POINT: u64 = 19;

/// Decodes one `CustomMsg`; the error says what is wrong with it.
pub fn decode(data: &[u8], encoding: Encoding) -> Result<PointCloud, String> {
    let mut w = Wire::new(data, encoding)?;
    let (stamp_ns, frame_id) = w.header()?;
    w.u64("timebase")?;
    w.u32("point_num")?;
    w.bytes(4, "lidar_id and rsvd")?;
    let n = w.u32("points length")?;
    let stride = match encoding {
        Encoding::Cdr => 20,
        Encoding::Ros1 => POINT,
    };
    // u64: 2^32 points of 20 bytes cannot overflow it, as usize could on wasm32.
    let need = u64::from(n).checked_sub(1).map_or(0, |k| k * stride + POINT);
    let left = w.left();
    if need > left as u64 {
        return Err(format!("points: {n} points need {need} bytes, {left} left in the message"));
    }
    let bytes = w.bytes(need as usize, "points")?;
    let big_endian = w.big_endian();
    let f32_at = |p: &[u8], at: usize| {
        let b: [u8; 4] = p[at..at + 4].try_into().unwrap_or([0; 4]);
        if big_endian { f32::from_be_bytes(b) } else { f32::from_le_bytes(b) }
    };
    let n = n as usize;
    let mut cloud = Cloud { points: Vec::with_capacity(n), intensity: Some(Vec::with_capacity(n)) };
    let mut dropped = 0;
    for k in 0..n {
        let p = &bytes[k * stride as usize..][..POINT as usize];
        let v = [4, 8, 12].map(|at| f32_at(p, at));
        if v.iter().any(|c| !c.is_finite()) || v.iter().all(|&c| c == 0.0) {
            dropped += 1;
            continue;
        }
        cloud.points.push(v);
        if let Some(out) = &mut cloud.intensity {
            out.push(f32::from(p[16]));
        }
    }
    Ok(PointCloud { stamp_ns, frame_id, cloud, dropped, width: n, height: 1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ROS 1 message of `points` (x, y, z, reflectivity), `declared` in the sequence length.
    fn ros1(points: &[([f32; 3], u8)], declared: u32) -> Vec<u8> {
        let mut m = Vec::new();
        m.extend(7u32.to_le_bytes()); // seq
        m.extend(5u32.to_le_bytes()); // sec
        m.extend(250u32.to_le_bytes()); // nsec
        m.extend(5u32.to_le_bytes());
        m.extend(b"livox");
        m.extend(5_000_000_250u64.to_le_bytes());
        m.extend((points.len() as u32).to_le_bytes());
        m.extend([1, 0, 0, 0]);
        m.extend(declared.to_le_bytes());
        for (k, (p, r)) in points.iter().enumerate() {
            m.extend((k as u32 * 10).to_le_bytes());
            p.iter().for_each(|c| m.extend(c.to_le_bytes()));
            m.extend([*r, 0, 3]);
        }
        m
    }

    #[test]
    fn drops_missing_returns_and_keeps_reflectivity() {
        let pts = [
            ([1.0, 2.0, 3.0], 9),
            ([0.0; 3], 1),
            ([f32::NAN, 0.0, 1.0], 2),
            ([4.0, 0.0, 0.0], 200),
        ];
        let pc = decode(&ros1(&pts, 4), Encoding::Ros1).unwrap();
        assert_eq!(pc.cloud.points, [[1.0, 2.0, 3.0], [4.0, 0.0, 0.0]]);
        assert_eq!(pc.cloud.intensity, Some(vec![9.0, 200.0]));
        assert_eq!(
            (pc.stamp_ns, pc.frame_id.as_str(), pc.dropped, pc.width),
            (5_000_000_250, "livox", 2, 4)
        );
    }

    #[test]
    fn a_count_beyond_the_message_is_named() {
        let e = decode(&ros1(&[([1.0, 2.0, 3.0], 9)], 3), Encoding::Ros1).unwrap_err();
        assert_eq!(e, "points: 3 points need 57 bytes, 19 left in the message");
        let e = decode(&ros1(&[], u32::MAX), Encoding::Ros1).unwrap_err();
        assert!(e.starts_with("points: 4294967295 points need 81604378605 bytes"), "{e}");
    }
}
