//! ROS 1 bags, format 2.0 (<http://wiki.ros.org/Bags/Format/2.0>): after `#ROSBAG V2.0\n`,
//! records `header_len u32, header (field_len u32, name=value)..., data_len u32, data`; the op
//! field says what a record is. Messages sit in chunks (`none`, `bz2` or `lz4`); the index at
//! `index_pos` (connections, then one chunk info per chunk) and the index data records after
//! each chunk say where each message is, so opening reads no chunk. A bag without its index
//! (not closed, truncated) is scanned once.

use std::collections::HashMap;

use super::bytes::Cursor;
use super::compression::{self, Compression};
use super::error::{Bad, RecordingError};
use super::index::{ChunkRef, Encoding, Entry, Index, Loc, Progress, Topic};
use super::source::{ReadAt, read};

pub const MAGIC: &[u8; 13] = b"#ROSBAG V2.0\n";

const MESSAGE: u8 = 0x02;
const BAG_HEADER: u8 = 0x03;
const INDEX_DATA: u8 = 0x04;
const CHUNK: u8 = 0x05;
const CONNECTION: u8 = 0x07;

/// A record's header fields.
struct Header<'a> {
    fields: HashMap<&'a [u8], &'a [u8]>,
    at: u64,
}

impl<'a> Header<'a> {
    fn parse(bytes: &'a [u8], at: u64) -> Result<Self, Bad> {
        let mut c = Cursor::new(bytes, at);
        let mut fields = HashMap::new();
        while c.remaining() > 0 {
            let field_at = c.offset();
            let field = c.prefixed("header field")?;
            let eq = field.iter().position(|&b| b == b'=');
            let eq = eq.ok_or_else(|| Bad::at(field_at, "header field without '='"))?;
            fields.insert(&field[..eq], &field[eq + 1..]);
        }
        Ok(Self { fields, at })
    }

    fn get(&self, name: &str) -> Result<&'a [u8], Bad> {
        self.fields
            .get(name.as_bytes())
            .copied()
            .ok_or_else(|| Bad::at(self.at, format!("header without '{name}'")))
    }

    fn op(&self) -> Result<u8, Bad> {
        Ok(*self.get("op")?.first().ok_or_else(|| Bad::at(self.at, "empty op"))?)
    }

    fn u32(&self, name: &str) -> Result<u32, Bad> {
        let v = self.get(name)?;
        v.try_into()
            .map(u32::from_le_bytes)
            .map_err(|_| Bad::at(self.at, format!("'{name}' is not 4 bytes")))
    }

    fn u64(&self, name: &str) -> Result<u64, Bad> {
        let v = self.get(name)?;
        v.try_into()
            .map(u64::from_le_bytes)
            .map_err(|_| Bad::at(self.at, format!("'{name}' is not 8 bytes")))
    }

    /// A ROS time (sec u32, nsec u32) in ns.
    fn time(&self, name: &str) -> Result<u64, Bad> {
        let t = self.u64(name)?;
        Ok((t & 0xFFFF_FFFF) * 1_000_000_000 + (t >> 32))
    }

    fn string(&self, name: &str) -> Result<String, Bad> {
        Ok(String::from_utf8_lossy(self.get(name)?).into_owned())
    }
}

/// A record read from the file: its header, its data, and where the next one starts.
struct Record {
    header: Vec<u8>,
    header_at: u64,
    data: Vec<u8>,
    data_at: u64,
    next: u64,
}

fn u32_at(src: &mut dyn ReadAt, at: u64, what: &str) -> Result<u64, Bad> {
    let b = read(src, at, 4, what)?;
    Ok(u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
}

/// The record at `at`; with `data` false its data is skipped (chunks when only their place
/// is wanted).
fn record(src: &mut dyn ReadAt, at: u64, data: bool) -> Result<Record, Bad> {
    let header_len = u32_at(src, at, "record header length")?;
    let header = read(src, at + 4, header_len, "record header")?;
    let data_len_at = at + 4 + header_len;
    let data_len = u32_at(src, data_len_at, "record data length")?;
    let data_at = data_len_at + 4;
    let next = data_at + data_len;
    if next > src.size() {
        return Err(Bad::at(
            data_len_at,
            format!("record data: {data_len} bytes declared, file ends at {}", src.size()),
        ));
    }
    let data = if data { read(src, data_at, data_len, "record data")? } else { Vec::new() };
    Ok(Record { header, header_at: at + 4, data, data_at, next })
}

/// Connections (conn id -> topic index) and topics as they are met.
#[derive(Default)]
struct Registry {
    connections: HashMap<u32, usize>,
    topics: Vec<Topic>,
}

impl Registry {
    fn connection(&mut self, header: &Header, data: &[u8], data_at: u64) -> Result<(), Bad> {
        let conn = header.u32("conn")?;
        if self.connections.contains_key(&conn) {
            return Ok(());
        }
        let name = header.string("topic")?;
        let type_name = Header::parse(data, data_at)?.string("type")?;
        self.connections.insert(conn, self.topics.len());
        self.topics.push(Topic::declared(name, type_name, Some(Encoding::Ros1)));
        Ok(())
    }

    fn topic(&self, conn: u32, at: u64) -> Result<usize, Bad> {
        self.connections
            .get(&conn)
            .copied()
            .ok_or_else(|| Bad::at(at, format!("unknown connection {conn}")))
    }
}

/// Opens a bag: by its index when it has one, else by one scan.
pub fn open(src: &mut dyn ReadAt, file: &str, progress: Progress) -> Result<Index, RecordingError> {
    let magic = read(src, 0, 13, "magic").map_err(|b| b.in_file(file))?;
    if magic != MAGIC {
        return Err(Bad::at(0, "not a ROS 1 bag v2.0").in_file(file));
    }
    let first = record(src, 13, true).map_err(|b| b.in_file(file))?;
    let header = Header::parse(&first.header, first.header_at).map_err(|b| b.in_file(file))?;
    if header.op().map_err(|b| b.in_file(file))? != BAG_HEADER {
        return Err(Bad::at(13, "no bag header record").in_file(file));
    }
    let index_pos = header.u64("index_pos").map_err(|b| b.in_file(file))?;
    let connections = header.u32("conn_count").map_err(|b| b.in_file(file))?;
    let chunks = header.u32("chunk_count").map_err(|b| b.in_file(file))?;
    if index_pos >= first.next && index_pos < src.size() {
        match indexed(src, index_pos, connections, chunks) {
            Ok(index) => return Ok(index),
            // A damaged index: the scan still finds every intact chunk.
            Err(bad) => {
                let mut index = scan(src, file, first.next, progress);
                let problem = format!("index unreadable, scanned instead: {}", bad.problem);
                index.problems.insert(0, Bad { offset: bad.offset, problem }.in_file(file));
                return Ok(index);
            }
        }
    }
    Ok(scan(src, file, first.next, progress))
}

fn indexed(
    src: &mut dyn ReadAt,
    index_pos: u64,
    connections: u32,
    chunks: u32,
) -> Result<Index, Bad> {
    let mut registry = Registry::default();
    let mut pos = index_pos;
    for _ in 0..connections {
        let r = record(src, pos, true)?;
        let header = Header::parse(&r.header, r.header_at)?;
        if header.op()? != CONNECTION {
            return Err(Bad::at(pos, "expected a connection record in the index"));
        }
        registry.connection(&header, &r.data, r.data_at)?;
        pos = r.next;
    }
    let mut index = Index::default();
    for n in 0..chunks as usize {
        let info = record(src, pos, true)?;
        pos = info.next;
        let chunk_pos = Header::parse(&info.header, info.header_at)?.u64("chunk_pos")?;
        let per_connection = info.data.len() / 8;
        // The chunk record, then one index data record per connection in it.
        let chunk = record(src, chunk_pos, false)?;
        index.chunks.push(chunk_ref(&chunk, chunk_pos)?);
        let mut at = chunk.next;
        for _ in 0..per_connection {
            let r = record(src, at, true)?;
            at = r.next;
            let header = Header::parse(&r.header, r.header_at)?;
            if header.op()? != INDEX_DATA {
                return Err(Bad::at(r.header_at, "expected index data after the chunk"));
            }
            let topic = registry.topic(header.u32("conn")?, r.header_at)?;
            let mut c = Cursor::new(&r.data, r.data_at);
            while c.remaining() > 0 {
                let sec = u64::from(c.u32("time")?);
                let nsec = u64::from(c.u32("time")?);
                let offset = u64::from(c.u32("offset")?);
                let time_ns = sec * 1_000_000_000 + nsec;
                index.entries.push(Entry { topic, time_ns, loc: Loc::Chunk { chunk: n, offset } });
            }
        }
    }
    index.topics = registry.topics;
    Ok(index)
}

fn chunk_ref(chunk: &Record, start: u64) -> Result<ChunkRef, Bad> {
    let header = Header::parse(&chunk.header, chunk.header_at)?;
    if header.op()? != CHUNK {
        return Err(Bad::at(start, "no chunk record where the index points"));
    }
    let name = header.string("compression")?;
    Ok(ChunkRef {
        start,
        data: chunk.data_at - start,
        data_len: chunk.next - chunk.data_at,
        uncompressed_len: u64::from(header.u32("size")?),
        compression: Compression::parse(&name).ok_or(name),
        crc: 0,
    })
}

/// Decompresses a chunk.
pub fn load_chunk(src: &mut dyn ReadAt, chunk: &ChunkRef) -> Result<Vec<u8>, Bad> {
    let r = record(src, chunk.start, true)?;
    decompress(&r, chunk.start)
}

fn decompress(r: &Record, start: u64) -> Result<Vec<u8>, Bad> {
    let header = Header::parse(&r.header, r.header_at)?;
    let name = header.string("compression")?;
    let kind = Compression::parse(&name)
        .ok_or_else(|| Bad::at(start, format!("unknown chunk compression '{name}'")))?;
    let size = u64::from(header.u32("size")?);
    if size > (r.data.len() as u64).saturating_mul(1024).max(1 << 20) {
        return Err(Bad::at(
            r.data_at,
            format!("chunk size {size} implausible for {} bytes", r.data.len()),
        ));
    }
    compression::decompress(kind, &r.data, size as usize).map_err(|e| Bad::at(r.data_at, e))
}

/// The data of the message record at `offset` in a chunk's records.
pub fn message_at(records: &[u8], offset: u64) -> Result<&[u8], Bad> {
    let start = usize::try_from(offset).ok().filter(|&o| o <= records.len());
    let start =
        start.ok_or_else(|| Bad::new(format!("message offset {offset} beyond its chunk")))?;
    let mut c = Cursor::new(&records[start..], offset);
    let header = Header::parse(c.prefixed("message header")?, offset + 4)?;
    if header.op()? != MESSAGE {
        return Err(Bad::new(format!("no message record at chunk offset {offset}")));
    }
    c.prefixed("message data")
}

/// One pass over every record from `pos`; problems are kept and the scan goes on where
/// lengths allow.
fn scan(src: &mut dyn ReadAt, file: &str, mut pos: u64, progress: Progress) -> Index {
    let size = src.size();
    let mut registry = Registry::default();
    let mut index = Index::default();
    while pos < size {
        progress(pos, size);
        let r = match record(src, pos, true) {
            Ok(r) => r,
            Err(b) => {
                index.problems.push(
                    Bad { offset: b.offset, problem: format!("truncated: {}", b.problem) }
                        .in_file(file),
                );
                break;
            }
        };
        let outcome = (|| {
            let header = Header::parse(&r.header, r.header_at)?;
            match header.op()? {
                CONNECTION => registry.connection(&header, &r.data, r.data_at),
                CHUNK => {
                    let records = decompress(&r, pos)?;
                    let n = index.chunks.len();
                    index.chunks.push(chunk_ref(&r, pos)?);
                    scan_chunk(&mut registry, &mut index, &records, n)
                }
                _ => Ok(()),
            }
        })();
        if let Err(bad) = outcome {
            index.problems.push(bad.in_file(file));
        }
        pos = r.next;
    }
    progress(size, size);
    index.topics = registry.topics;
    index
}

fn scan_chunk(
    registry: &mut Registry,
    index: &mut Index,
    records: &[u8],
    n: usize,
) -> Result<(), Bad> {
    let mut c = Cursor::new(records, 0);
    while c.remaining() > 0 {
        let offset = c.offset();
        let header_at = offset + 4;
        let header = Header::parse(c.prefixed("record header")?, header_at)?;
        let data_at = c.offset() + 4;
        let data = c.prefixed("record data")?;
        match header.op()? {
            CONNECTION => registry.connection(&header, data, data_at)?,
            MESSAGE => {
                let topic = registry.topic(header.u32("conn")?, header_at)?;
                let time_ns = header.time("time")?;
                index.entries.push(Entry { topic, time_ns, loc: Loc::Chunk { chunk: n, offset } });
            }
            _ => {}
        }
    }
    Ok(())
}
