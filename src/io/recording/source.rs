//! Random access to a recording's bytes. Containers read their summary and then only the
//! chunks holding the chosen messages, so a multi-gigabyte file never has to be in memory:
//! natively through `std::fs::File`, in the page through `File.slice` in a worker.

/// Bytes at an offset. `read_at` fills `buf` completely or fails (a short file is an error
/// the container reports as truncation).
pub trait ReadAt {
    /// The total size in bytes.
    fn size(&self) -> u64;
    /// Fills `buf` with the bytes at `offset..offset + buf.len()`.
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()>;
}

/// Reads `len` bytes at `offset` of `src`; a length beyond the file, or a failed read, is an
/// error naming what was being read. The containers read every record through it.
pub(super) fn read(
    src: &mut dyn ReadAt,
    offset: u64,
    len: u64,
    what: &str,
) -> Result<Vec<u8>, super::error::Bad> {
    use super::error::Bad;
    let end = offset.checked_add(len).filter(|&e| e <= src.size());
    if end.is_none() {
        let size = src.size();
        return Err(Bad::at(offset, format!("{what}: {len} bytes declared, file ends at {size}")));
    }
    let mut buf = vec![0; len as usize];
    src.read_at(offset, &mut buf).map_err(|e| Bad::at(offset, format!("{what}: {e}")))?;
    Ok(buf)
}

impl ReadAt for &[u8] {
    fn size(&self) -> u64 {
        self.len() as u64
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        let start = usize::try_from(offset).unwrap_or(usize::MAX);
        let end = start.checked_add(buf.len()).filter(|&e| e <= self.len());
        match end {
            Some(end) => {
                buf.copy_from_slice(&self[start..end]);
                Ok(())
            }
            None => Err(std::io::ErrorKind::UnexpectedEof.into()),
        }
    }
}

impl ReadAt for Vec<u8> {
    fn size(&self) -> u64 {
        self.len() as u64
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.as_slice().read_at(offset, buf)
    }
}

impl<T: ReadAt + ?Sized> ReadAt for Box<T> {
    fn size(&self) -> u64 {
        (**self).size()
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        (**self).read_at(offset, buf)
    }
}

/// A file on disk; the size is taken once at open.
#[cfg(not(target_arch = "wasm32"))]
pub struct FileSource {
    file: std::fs::File,
    size: u64,
}

#[cfg(not(target_arch = "wasm32"))]
impl FileSource {
    pub fn open(path: &std::path::Path) -> std::io::Result<Self> {
        let file = std::fs::File::open(path)?;
        let size = file.metadata()?.len();
        Ok(Self { file, size })
    }
}

#[cfg(not(target_arch = "wasm32"))]
impl ReadAt for FileSource {
    fn size(&self) -> u64 {
        self.size
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        use std::io::{Read, Seek, SeekFrom};
        self.file.seek(SeekFrom::Start(offset))?;
        self.file.read_exact(buf)
    }
}
