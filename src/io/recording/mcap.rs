//! MCAP (<https://mcap.dev/spec>): records `opcode u8, length u64, content`, little endian,
//! between two magics; messages in chunks (zstd, lz4 or stored) or loose; an optional summary
//! section (schemas, channels, chunk indexes, statistics) located by the footer.
//!
//! Our own reader rather than the `mcap` crate: that crate decompresses only through its
//! `zstd` (C libzstd) and `lz4` (C liblz4) features, which do not build for
//! wasm32-unknown-unknown, and its reader wants the whole file as one slice; the page reads
//! 5 GB files by `File.slice`. The format is small: this file reads what calibration needs.
//!
//! Opening reads the footer, the summary and each chunk's message indexes (small, uncompressed,
//! after the chunk); only when those are missing is the file scanned record by record.

use std::collections::HashMap;

use super::bytes::{Cursor, crc32};
use super::compression::{self, Compression};
use super::error::{Bad, RecordingError};
use super::index::{ChunkRef, Encoding, Entry, Index, Loc, Progress, Topic};
use super::source::{ReadAt, read};

pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

const SCHEMA: u8 = 0x03;
const CHANNEL: u8 = 0x04;
const MESSAGE: u8 = 0x05;
const CHUNK: u8 = 0x06;
const MESSAGE_INDEX: u8 = 0x07;
const CHUNK_INDEX: u8 = 0x08;
const FOOTER: u8 = 0x02;
const DATA_END: u8 = 0x0F;
/// Footer record: opcode, length, summary_start, summary_offset_start, summary_crc.
const FOOTER_LEN: u64 = 1 + 8 + 8 + 8 + 4;

/// Schemas and channels as they are met; channel ids map to topics.
#[derive(Default)]
struct Registry {
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, usize>,
    topics: Vec<Topic>,
}

impl Registry {
    fn record(&mut self, op: u8, body: &[u8], base: u64) -> Result<(), Bad> {
        let mut c = Cursor::new(body, base);
        match op {
            SCHEMA => {
                let id = c.u16("schema id")?;
                let name = c.string("schema name")?;
                self.schemas.insert(id, name);
            }
            CHANNEL => {
                let id = c.u16("channel id")?;
                let schema = c.u16("channel schema id")?;
                let name = c.string("channel topic")?;
                let encoding = match c.string("message encoding")?.as_str() {
                    "cdr" => Some(Encoding::Cdr),
                    "ros1" => Some(Encoding::Ros1),
                    _ => None,
                };
                if self.channels.contains_key(&id) {
                    return Ok(()); // repeated in the summary and in chunks
                }
                let type_name = self.schemas.get(&schema).cloned().unwrap_or_default();
                self.channels.insert(id, self.topics.len());
                self.topics.push(Topic::declared(name, type_name, encoding));
            }
            _ => {}
        }
        Ok(())
    }

    fn topic(&self, channel: u16, at: u64) -> Result<usize, Bad> {
        self.channels
            .get(&channel)
            .copied()
            .ok_or_else(|| Bad::at(at, format!("unknown channel {channel}")))
    }
}

/// Iterates `opcode, body, body offset` over the records in `data`.
fn records(data: &[u8], base: u64) -> impl Iterator<Item = Result<(u8, &[u8], u64), Bad>> {
    let mut c = Cursor::new(data, base);
    std::iter::from_fn(move || {
        if c.remaining() == 0 {
            return None;
        }
        let at = c.offset();
        let item = (|| {
            let op = c.u8("record opcode")?;
            let len = c.u64("record length")?;
            let body_at = c.offset();
            let body = c.bytes(usize::try_from(len).unwrap_or(usize::MAX), "record")?;
            Ok((op, body, body_at))
        })();
        if item.is_err() {
            c = Cursor::new(&[], at); // stop after the first bad record
        }
        Some(item)
    })
}

/// Opens an MCAP file: by its summary when it has one, else by one scan.
pub fn open(src: &mut dyn ReadAt, file: &str, progress: Progress) -> Result<Index, RecordingError> {
    let head = read(src, 0, 8, "magic").map_err(|b| b.in_file(file))?;
    if head != MAGIC {
        return Err(Bad::at(0, "not an MCAP file").in_file(file));
    }
    match summary(src).map_err(|b| b.in_file(file))? {
        Some(index) => Ok(index),
        None => Ok(scan(src, file, progress)),
    }
}

/// The index from the summary and the message indexes; `None` when the file has not enough
/// of them (no footer, no summary, loose messages, chunks without message indexes).
fn summary(src: &mut dyn ReadAt) -> Result<Option<Index>, Bad> {
    let size = src.size();
    if size < 8 + FOOTER_LEN + 8 || read(src, size - 8, 8, "magic")? != MAGIC {
        return Ok(None);
    }
    let footer_at = size - 8 - FOOTER_LEN;
    let footer = read(src, footer_at, FOOTER_LEN, "footer")?;
    let mut c = Cursor::new(&footer, footer_at);
    if c.u8("footer opcode")? != FOOTER {
        return Ok(None);
    }
    c.u64("footer length")?;
    let start = c.u64("summary start")?;
    if start == 0 {
        return Ok(None);
    }
    if start < 8 || start > footer_at {
        return Err(Bad::at(footer_at, format!("summary start {start} outside the file")));
    }
    let data = read(src, start, footer_at - start, "summary")?;
    let mut registry = Registry::default();
    let mut chunk_indexes = Vec::new();
    let mut total = None;
    for record in records(&data, start) {
        let (op, body, at) = record?;
        match op {
            SCHEMA | CHANNEL => registry.record(op, body, at)?,
            CHUNK_INDEX => chunk_indexes.push(chunk_index(body, at)?),
            0x0B => total = Some(Cursor::new(body, at).u64("message count")?),
            _ => {}
        }
    }
    let in_chunks: bool = chunk_indexes.iter().all(|(_, index_len)| *index_len > 0);
    if !in_chunks || (chunk_indexes.is_empty() && total != Some(0)) {
        return Ok(None);
    }
    let mut index = Index { topics: registry.topics.clone(), ..Index::default() };
    for (n, (chunk, index_len)) in chunk_indexes.into_iter().enumerate() {
        let indexes_at = chunk.start + chunk_end(&chunk);
        let bytes = read(src, indexes_at, index_len, "message index")?;
        for record in records(&bytes, indexes_at) {
            let (op, body, at) = record?;
            if op != MESSAGE_INDEX {
                continue;
            }
            let mut c = Cursor::new(body, at);
            let topic = registry.topic(c.u16("channel id")?, at)?;
            let pairs = c.prefixed("message index records")?;
            let mut p = Cursor::new(pairs, at + 2 + 4);
            while p.remaining() > 0 {
                let time_ns = p.u64("log time")?;
                let offset = p.u64("message offset")?;
                index.entries.push(Entry { topic, time_ns, loc: Loc::Chunk { chunk: n, offset } });
            }
        }
        index.chunks.push(chunk);
    }
    Ok(Some(index))
}

/// A chunk index: the chunk (its record's place and sizes) and its message indexes' length.
fn chunk_index(body: &[u8], at: u64) -> Result<(ChunkRef, u64), Bad> {
    let mut c = Cursor::new(body, at);
    c.u64("start time")?;
    c.u64("end time")?;
    let start = c.u64("chunk start")?;
    let length = c.u64("chunk length")?;
    c.prefixed("message index offsets")?;
    let index_len = c.u64("message index length")?;
    let compression = c.string("compression")?;
    let data_len = c.u64("compressed size")?;
    let uncompressed_len = c.u64("uncompressed size")?;
    // The records sit at the end of the chunk record, whose length counts opcode and length
    // field; `data` is relative to `start`.
    let data = length.checked_sub(data_len).ok_or_else(|| {
        Bad::at(at, format!("chunk length {length} shorter than its data {data_len}"))
    })?;
    let chunk = ChunkRef {
        start,
        data,
        data_len,
        uncompressed_len,
        compression: Compression::parse(&compression).ok_or(compression),
        crc: 0,
    };
    Ok((chunk, index_len))
}

/// Length of the chunk record (opcode and length included) from its index entry.
fn chunk_end(chunk: &ChunkRef) -> u64 {
    chunk.data + chunk.data_len
}

/// Decompresses chunk `chunk` (read afresh from its record, so its CRC is checked too).
pub fn load_chunk(src: &mut dyn ReadAt, chunk: &ChunkRef) -> Result<Vec<u8>, Bad> {
    let head = read(src, chunk.start, 9, "chunk record")?;
    let mut c = Cursor::new(&head, chunk.start);
    if c.u8("opcode")? != CHUNK {
        return Err(Bad::at(chunk.start, "no chunk record where the index points"));
    }
    let len = c.u64("chunk length")?;
    let body = read(src, chunk.start + 9, len, "chunk")?;
    parse_chunk(&body, chunk.start + 9)
}

/// A chunk record's body (at file offset `at`) decompressed, its CRC checked.
fn parse_chunk(body: &[u8], at: u64) -> Result<Vec<u8>, Bad> {
    let mut c = Cursor::new(body, at);
    c.u64("start time")?;
    c.u64("end time")?;
    let size = c.u64("uncompressed size")?;
    let crc = c.u32("uncompressed crc")?;
    let name = c.string("compression")?;
    let records_at = c.offset();
    let records_len = c.u64("records length")?;
    let data = c.bytes(usize::try_from(records_len).unwrap_or(usize::MAX), "records")?;
    let kind = Compression::parse(&name)
        .ok_or_else(|| Bad::at(records_at, format!("unknown chunk compression '{name}'")))?;
    // Zero-filled sizes beyond the file bound what we allocate: stored bytes can expand at most
    // ~255x under lz4 and less under zstd; refuse the implausible before allocating.
    if size > (data.len() as u64).saturating_mul(1024).max(1 << 20) {
        return Err(Bad::at(
            records_at,
            format!("uncompressed size {size} implausible for {} bytes", data.len()),
        ));
    }
    let out =
        compression::decompress(kind, data, size as usize).map_err(|e| Bad::at(records_at, e))?;
    if crc != 0 && crc32(&out) != crc {
        return Err(Bad::at(records_at, "chunk CRC mismatch"));
    }
    Ok(out)
}

/// The data of the message record at `offset` in `records` (a chunk's, or the file's bytes
/// from the record on).
pub fn message_at(records: &[u8], offset: u64, base: u64) -> Result<&[u8], Bad> {
    let start = usize::try_from(offset).ok().filter(|&o| o <= records.len());
    let start = start.ok_or_else(|| Bad::at(base + offset, "message offset beyond its chunk"))?;
    let mut c = Cursor::new(&records[start..], base + offset);
    if c.u8("opcode")? != MESSAGE {
        return Err(Bad::at(base + offset, "no message record where the index points"));
    }
    let len = c.u64("message length")?;
    let mut body =
        Cursor::new(c.bytes(usize::try_from(len).unwrap_or(usize::MAX), "message")?, c.offset());
    body.bytes(2 + 4 + 8 + 8, "message header")?;
    body.bytes(body.remaining(), "message data")
}

/// Reads the loose message record at file offset `at`.
pub fn loose_message(src: &mut dyn ReadAt, at: u64) -> Result<Vec<u8>, Bad> {
    let head = read(src, at, 9, "message record")?;
    let len = u64::from_le_bytes(head[1..9].try_into().unwrap_or([0; 8]));
    let mut whole = head;
    whole.extend(read(src, at + 9, len, "message")?);
    Ok(message_at(&whole, 0, at)?.to_vec())
}

/// One pass over every record; problems are kept and the scan goes on where lengths allow.
fn scan(src: &mut dyn ReadAt, file: &str, progress: Progress) -> Index {
    let size = src.size();
    let mut registry = Registry::default();
    let mut index = Index::default();
    let mut pos = 8u64;
    while pos < size {
        progress(pos, size);
        let head = match read(src, pos, 9, "record header") {
            Ok(h) => h,
            Err(b) => {
                index
                    .problems
                    .push(Bad::at(pos, format!("truncated: {}", b.problem)).in_file(file));
                break;
            }
        };
        let op = head[0];
        let len = u64::from_le_bytes(head[1..9].try_into().unwrap_or([0; 8]));
        if op == FOOTER || op == DATA_END {
            break;
        }
        let body = match read(src, pos + 9, len, "record") {
            Ok(b) => b,
            Err(b) => {
                index
                    .problems
                    .push(Bad::at(pos, format!("truncated: {}", b.problem)).in_file(file));
                break;
            }
        };
        let outcome = match op {
            SCHEMA | CHANNEL => registry.record(op, &body, pos + 9),
            MESSAGE => message_entry(&registry, &body, pos + 9, Loc::File(pos))
                .map(|e| index.entries.push(e)),
            CHUNK => scan_chunk(&mut registry, &mut index, &body, pos),
            _ => Ok(()),
        };
        if let Err(bad) = outcome {
            index.problems.push(bad.in_file(file));
        }
        pos += 9 + len;
    }
    progress(size, size);
    index.topics = registry.topics;
    index
}

/// The entry of a message record's body.
fn message_entry(registry: &Registry, body: &[u8], at: u64, loc: Loc) -> Result<Entry, Bad> {
    let mut c = Cursor::new(body, at);
    let topic = registry.topic(c.u16("channel id")?, at)?;
    c.u32("sequence")?;
    let time_ns = c.u64("log time")?;
    Ok(Entry { topic, time_ns, loc })
}

/// Decompresses a chunk met in a scan and indexes its records.
fn scan_chunk(
    registry: &mut Registry,
    index: &mut Index,
    body: &[u8],
    start: u64,
) -> Result<(), Bad> {
    let data = parse_chunk(body, start + 9)?;
    let n = index.chunks.len();
    let mut c = Cursor::new(body, start + 9);
    c.bytes(8 + 8 + 8 + 4, "chunk header")?;
    let name = c.string("compression")?;
    let data_len = c.u64("records length")?;
    index.chunks.push(ChunkRef {
        start,
        data: c.offset() - start,
        data_len,
        uncompressed_len: data.len() as u64,
        compression: Compression::parse(&name).ok_or(name),
        crc: 0,
    });
    for record in records(&data, 0) {
        let (op, rec, at) = record?;
        match op {
            SCHEMA | CHANNEL => registry.record(op, rec, at)?,
            MESSAGE => {
                let offset = at - 9;
                index.entries.push(message_entry(
                    registry,
                    rec,
                    at,
                    Loc::Chunk { chunk: n, offset },
                )?);
            }
            _ => {}
        }
    }
    Ok(())
}
