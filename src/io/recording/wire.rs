//! The two ROS serialisations, read field by field. ROS 1: little endian, packed, strings as
//! `u32 length, bytes`. CDR (ROS 2): a 4-byte encapsulation header (`00 01` little endian,
//! `00 00` big endian), then each primitive aligned to its size from the end of that header,
//! strings as `u32 length (NUL included), bytes, NUL`.

use super::index::Encoding;

/// A message being read. Errors are plain strings: the caller attaches file, topic, message.
pub struct Wire<'a> {
    data: &'a [u8],
    pos: usize,
    /// Where alignment counts from (after CDR's header); CDR only.
    origin: usize,
    cdr: bool,
    big_endian: bool,
}

impl<'a> Wire<'a> {
    pub fn new(data: &'a [u8], encoding: Encoding) -> Result<Self, String> {
        match encoding {
            Encoding::Ros1 => Ok(Self { data, pos: 0, origin: 0, cdr: false, big_endian: false }),
            Encoding::Cdr => {
                let big_endian = match data.get(..2) {
                    Some([0, 0]) => true,
                    Some([0, 1]) => false,
                    Some(h) => return Err(format!("CDR encapsulation {h:02x?} is not plain CDR")),
                    None => return Err("message shorter than its CDR header".into()),
                };
                if data.len() < 4 {
                    return Err("message shorter than its CDR header".into());
                }
                Ok(Self { data, pos: 4, origin: 4, cdr: true, big_endian })
            }
        }
    }

    fn align(&mut self, n: usize) {
        if self.cdr {
            let rel = self.pos - self.origin;
            self.pos += (n - rel % n) % n;
        }
    }

    /// Bytes not read yet.
    pub fn left(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    /// Whether multi-byte values are big-endian (a big-endian CDR message).
    pub fn big_endian(&self) -> bool {
        self.big_endian
    }

    pub fn bytes(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let left = self.left();
        if n > left {
            return Err(format!("{what}: {n} bytes declared, {left} left in the message"));
        }
        let out = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        self.align(N);
        let mut a: [u8; N] = self.bytes(N, what)?.try_into().map_err(|_| what.to_string())?;
        if self.big_endian {
            a.reverse();
        }
        Ok(a)
    }

    pub fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.bytes(1, what)?[0])
    }

    pub fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub fn u64(&mut self, what: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub fn i32(&mut self, what: &str) -> Result<i32, String> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub fn f64(&mut self, what: &str) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    pub fn string(&mut self, what: &str) -> Result<String, String> {
        let n = self.u32(what)? as usize;
        let mut b = self.bytes(n, what)?;
        if self.cdr {
            b = b.strip_suffix(&[0]).unwrap_or(b);
        }
        String::from_utf8(b.to_vec()).map_err(|_| format!("{what}: not UTF-8"))
    }

    /// `std_msgs/Header`: the stamp (ns) and frame id; ROS 1's `seq` is skipped.
    pub fn header(&mut self) -> Result<(i64, String), String> {
        if !self.cdr {
            self.u32("header seq")?;
        }
        let sec = if self.cdr {
            i64::from(self.i32("stamp sec")?)
        } else {
            i64::from(self.u32("stamp sec")?)
        };
        let nsec = i64::from(self.u32("stamp nanosec")?);
        let frame = self.string("frame_id")?;
        Ok((sec * 1_000_000_000 + nsec, frame))
    }
}
