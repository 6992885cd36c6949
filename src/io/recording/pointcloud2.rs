//! `sensor_msgs/PointCloud2` to a [`Cloud`], in full generality: fields in any order and of
//! any type, padding, any `point_step` and `row_step`, either endianness, organised clouds.
//! Missing returns (a NaN or infinite coordinate, or exactly `0 0 0`) are dropped and counted,
//! as the file readers do, so a scan from a recording equals the same scan from a PCD file.

use super::index::Encoding;
use super::wire::Wire;
use crate::cloud::Cloud;

/// A decoded point cloud message.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCloud {
    /// `header.stamp` (ns since the epoch).
    pub stamp_ns: i64,
    pub frame_id: String,
    /// Valid points (m, the sensor's frame), with `intensity` when the message has that field.
    pub cloud: Cloud,
    /// Points dropped as missing returns.
    pub dropped: usize,
    pub width: usize,
    pub height: usize,
}

/// One `PointField`: where in a point it starts and how to read it.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub name: String,
    pub offset: u32,
    /// 1..=8: INT8, UINT8, INT16, UINT16, INT32, UINT32, FLOAT32, FLOAT64.
    pub datatype: u8,
    pub count: u32,
}

impl Field {
    fn size(&self) -> Option<usize> {
        Some(match self.datatype {
            1 | 2 => 1,
            3 | 4 => 2,
            5..=7 => 4,
            8 => 8,
            _ => return None,
        })
    }

    /// The value at `b` (at least `size` bytes).
    fn read(&self, b: &[u8], big_endian: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().unwrap_or([0; $n]);
                f64::from(if big_endian { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) })
            }};
        }
        match self.datatype {
            1 => f64::from(b[0] as i8),
            2 => f64::from(b[0]),
            3 => get!(i16, 2),
            4 => get!(u16, 2),
            5 => get!(i32, 4),
            6 => get!(u32, 4),
            7 => get!(f32, 4),
            _ => get!(f64, 8),
        }
    }
}

/// A message's `header.stamp` (ns since the epoch), reading the header alone.
pub fn stamp(data: &[u8], encoding: Encoding) -> Result<i64, String> {
    Wire::new(data, encoding)?.header().map(|(stamp_ns, _)| stamp_ns)
}

/// Decodes one PointCloud2 message; the error says what is wrong with it.
pub fn decode(data: &[u8], encoding: Encoding) -> Result<PointCloud, String> {
    let mut w = Wire::new(data, encoding)?;
    let (stamp_ns, frame_id) = w.header()?;
    let height = w.u32("height")? as usize;
    let width = w.u32("width")? as usize;
    let n_fields = w.u32("fields length")? as usize;
    let mut fields = Vec::with_capacity(n_fields.min(64));
    for _ in 0..n_fields {
        let name = w.string("field name")?;
        let offset = w.u32("field offset")?;
        let datatype = w.u8("field datatype")?;
        let count = w.u32("field count")?;
        fields.push(Field { name, offset, datatype, count });
    }
    let big_endian = w.u8("is_bigendian")? != 0;
    let point_step = w.u32("point_step")? as usize;
    let row_step = w.u32("row_step")? as usize;
    let len = w.u32("data length")? as usize;
    let bytes = w.bytes(len, "data")?;
    points(&fields, big_endian, point_step, row_step, width, height, bytes)
        .map(|(cloud, dropped)| PointCloud { stamp_ns, frame_id, cloud, dropped, width, height })
}

/// The field named `name`, checked to lie within `point_step`.
fn field<'f>(
    fields: &'f [Field],
    name: &str,
    point_step: usize,
) -> Result<Option<&'f Field>, String> {
    let Some(f) = fields.iter().find(|f| f.name == name) else { return Ok(None) };
    let size =
        f.size().ok_or_else(|| format!("field {name} has unknown datatype {}", f.datatype))?;
    let end = f.offset as usize + size;
    if end > point_step {
        return Err(format!("field {name} ends at byte {end}, beyond point_step {point_step}"));
    }
    Ok(Some(f))
}

fn points(
    fields: &[Field],
    big_endian: bool,
    point_step: usize,
    row_step: usize,
    width: usize,
    height: usize,
    data: &[u8],
) -> Result<(Cloud, usize), String> {
    let [x, y, z] = ["x", "y", "z"].map(|n| field(fields, n, point_step));
    let (Some(x), Some(y), Some(z)) = (x?, y?, z?) else {
        return Err("no x, y and z fields".into());
    };
    let intensity = field(fields, "intensity", point_step)?;
    // Rows may be padded (row_step beyond width * point_step), never overlap.
    let row = width.checked_mul(point_step).filter(|&r| r <= row_step || height <= 1);
    let row = row
        .ok_or_else(|| format!("row_step {row_step} < width {width} x point_step {point_step}"))?;
    let needed = height
        .checked_sub(1)
        .map_or(Some(0), |h| h.checked_mul(row_step).and_then(|s| s.checked_add(row)));
    match needed {
        Some(n) if n <= data.len() => {}
        _ => {
            return Err(format!(
                "{width} x {height} points of {point_step} bytes need more than the {} data bytes",
                data.len()
            ));
        }
    }
    if width == 0 || height == 0 {
        return Ok((Cloud { points: Vec::new(), intensity: intensity.map(|_| Vec::new()) }, 0));
    }
    let mut cloud = Cloud {
        points: Vec::with_capacity(width.saturating_mul(height)),
        intensity: intensity.map(|_| Vec::new()),
    };
    let mut dropped = 0;
    for r in 0..height {
        for c in 0..width {
            let p = &data[r * row_step + c * point_step..][..point_step];
            let v = [x, y, z].map(|f| f.read(&p[f.offset as usize..], big_endian) as f32);
            if v.iter().any(|c| !c.is_finite()) || v.iter().all(|&c| c == 0.0) {
                dropped += 1;
                continue;
            }
            cloud.points.push(v);
            if let (Some(f), Some(out)) = (intensity, &mut cloud.intensity) {
                out.push(f.read(&p[f.offset as usize..], big_endian) as f32);
            }
        }
    }
    Ok((cloud, dropped))
}
