//! A little-endian cursor over a record's bytes, used by the container readers. Every read is
//! bounds-checked and fails with the absolute file offset, so a lying length never panics.

use super::error::Bad;

pub struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
    /// File offset of `data[0]` (for messages; 0 inside decompressed chunks).
    base: u64,
}

impl<'a> Cursor<'a> {
    pub fn new(data: &'a [u8], base: u64) -> Self {
        Self { data, pos: 0, base }
    }

    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// The file offset of the next byte.
    pub fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    pub fn bytes(&mut self, n: usize, what: &str) -> Result<&'a [u8], Bad> {
        if n > self.remaining() {
            return Err(Bad::at(
                self.offset(),
                format!("{what}: {n} bytes declared, {} left", self.remaining()),
            ));
        }
        let out = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    pub fn u8(&mut self, what: &str) -> Result<u8, Bad> {
        Ok(self.bytes(1, what)?[0])
    }

    pub fn u16(&mut self, what: &str) -> Result<u16, Bad> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    pub fn u32(&mut self, what: &str) -> Result<u32, Bad> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub fn u64(&mut self, what: &str) -> Result<u64, Bad> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], Bad> {
        let b = self.bytes(N, what)?;
        Ok(b.try_into().unwrap_or([0; N]))
    }

    /// A u32-length-prefixed byte string.
    pub fn prefixed(&mut self, what: &str) -> Result<&'a [u8], Bad> {
        let n = self.u32(what)? as usize;
        self.bytes(n, what)
    }

    /// A u32-length-prefixed UTF-8 string.
    pub fn string(&mut self, what: &str) -> Result<String, Bad> {
        let at = self.offset();
        let b = self.prefixed(what)?;
        String::from_utf8(b.to_vec()).map_err(|_| Bad::at(at, format!("{what}: not UTF-8")))
    }
}

/// CRC-32 (IEEE 802.3, reflected, as zlib), MCAP's checksum; a byte-wise table built at
/// compile time (one dependency fewer).
pub fn crc32(data: &[u8]) -> u32 {
    const TABLE: [u32; 256] = {
        let mut table = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 == 1 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
                k += 1;
            }
            table[i] = c;
            i += 1;
        }
        table
    };
    !data.iter().fold(!0u32, |crc, &b| TABLE[((crc ^ u32::from(b)) & 0xFF) as usize] ^ (crc >> 8))
}
