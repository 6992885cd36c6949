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
use super::index::{ChunkRef, Encoding, Entry, Index, Loc, Progress, Span, Topic};
use super::source::{ReadAt, read};

pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

const SCHEMA: u8 = 0x03;
const CHANNEL: u8 = 0x04;
const MESSAGE: u8 = 0x05;
const CHUNK: u8 = 0x06;
const MESSAGE_INDEX: u8 = 0x07;
const CHUNK_INDEX: u8 = 0x08;
const STATISTICS: u8 = 0x0B;
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

/// The index from the summary, with each topic's message indexes left for when it is used
/// ([`message_index`]) when the summary's statistics count every channel's messages, else read
/// now; `None` when the file has not enough of them (no footer, no summary, loose messages,
/// chunks without message indexes).
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
    let mut counts = None;
    for record in records(&data, start) {
        let (op, body, at) = record?;
        match op {
            SCHEMA | CHANNEL => registry.record(op, body, at)?,
            CHUNK_INDEX => chunk_indexes.push(chunk_index(body, at)?),
            STATISTICS => counts = Some(statistics(body, at)?),
            _ => {}
        }
    }
    let total = counts.as_ref().map(|(total, _)| *total);
    let in_chunks: bool = chunk_indexes.iter().all(|c| c.index_len > 0);
    if !in_chunks || (chunk_indexes.is_empty() && total != Some(0)) {
        return Ok(None);
    }
    let mut index = Index { topics: registry.topics.clone(), ..Index::default() };
    if let Some((_, counts)) = counts
        && registry.channels.keys().all(|c| counts.contains_key(c))
        && chunk_indexes.iter().all(|c| !c.offsets.is_empty())
    {
        defer(&mut index, &registry, chunk_indexes, &counts)?;
        return Ok(Some(index));
    }
    for (n, ChunkIndex { chunk, index_len, .. }) in chunk_indexes.into_iter().enumerate() {
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

/// A Statistics record's message count and its messages per channel.
fn statistics(body: &[u8], at: u64) -> Result<(u64, HashMap<u16, u64>), Bad> {
    let mut c = Cursor::new(body, at);
    let total = c.u64("message count")?;
    c.bytes(2 + 4 + 4 + 4 + 4 + 8 + 8, "statistics counts and times")?;
    let map_at = c.offset() + 4;
    let map = c.prefixed("channel message counts")?;
    let mut m = Cursor::new(map, map_at);
    let mut counts = HashMap::new();
    while m.remaining() > 0 {
        counts.insert(m.u16("channel id")?, m.u64("message count")?);
    }
    Ok((total, counts))
}

/// What the summary says of one chunk.
struct ChunkIndex {
    chunk: ChunkRef,
    /// Log times of its first and last message (ns).
    times: (u64, u64),
    /// Per channel, the file offset of its message index record.
    offsets: Vec<(u16, u64)>,
    /// Length of all its message index records.
    index_len: u64,
}

/// A chunk index: the chunk (its record's place and sizes) and its message indexes.
fn chunk_index(body: &[u8], at: u64) -> Result<ChunkIndex, Bad> {
    let mut c = Cursor::new(body, at);
    let times = (c.u64("start time")?, c.u64("end time")?);
    let start = c.u64("chunk start")?;
    let length = c.u64("chunk length")?;
    let map_at = c.offset() + 4;
    let mut m = Cursor::new(c.prefixed("message index offsets")?, map_at);
    let mut offsets = Vec::new();
    while m.remaining() > 0 {
        offsets.push((m.u16("channel id")?, m.u64("message index offset")?));
    }
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
    Ok(ChunkIndex { chunk, times, offsets, index_len })
}

/// Leaves each topic's message indexes for later: the statistics count its messages, its
/// chunks bound its times, and the chunk indexes say where its records lie.
fn defer(
    index: &mut Index,
    registry: &Registry,
    chunks: Vec<ChunkIndex>,
    counts: &HashMap<u16, u64>,
) -> Result<(), Bad> {
    let n = registry.topics.len();
    let mut spans = vec![Vec::new(); n];
    let mut times = vec![(u64::MAX, 0); n];
    for (k, ci) in chunks.into_iter().enumerate() {
        let begin = ci.chunk.start + chunk_end(&ci.chunk);
        let end = begin + ci.index_len;
        let mut offsets = ci.offsets;
        offsets.sort_by_key(|&(_, at)| at);
        for (i, &(channel, at)) in offsets.iter().enumerate() {
            let next = offsets.get(i + 1).map_or(end, |&(_, a)| a);
            if at < begin || next > end || at >= next {
                let problem = format!("message index of channel {channel} outside its chunk's");
                return Err(Bad::at(at, problem));
            }
            let topic = registry.topic(channel, at)?;
            spans[topic].push(Span { chunk: k, at, len: next - at });
            times[topic] = (times[topic].0.min(ci.times.0), times[topic].1.max(ci.times.1));
        }
        index.chunks.push(ci.chunk);
    }
    for (channel, &topic) in &registry.channels {
        let t = &mut index.topics[topic];
        t.count = usize::try_from(counts[channel]).unwrap_or(usize::MAX);
        (t.first_ns, t.last_ns) = if t.count > 0 { times[topic] } else { (0, 0) };
    }
    index.deferred = spans.into_iter().map(Some).collect();
    Ok(())
}

/// The entries of `topic` in one chunk: its message index record at `span`.
pub fn message_index(src: &mut dyn ReadAt, span: &Span, topic: usize) -> Result<Vec<Entry>, Bad> {
    let bytes = read(src, span.at, span.len, "message index")?;
    let mut entries = Vec::new();
    for record in records(&bytes, span.at) {
        let (op, body, at) = record?;
        if op != MESSAGE_INDEX {
            continue;
        }
        let mut c = Cursor::new(body, at);
        c.u16("channel id")?;
        let pairs = c.prefixed("message index records")?;
        let mut p = Cursor::new(pairs, at + 2 + 4);
        while p.remaining() > 0 {
            let time_ns = p.u64("log time")?;
            let offset = p.u64("message offset")?;
            entries.push(Entry { topic, time_ns, loc: Loc::Chunk { chunk: span.chunk, offset } });
        }
    }
    Ok(entries)
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
