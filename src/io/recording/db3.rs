//! rosbag2's SQLite `.db3`, read by a minimal read-only SQLite reader
//! (<https://www.sqlite.org/fileformat2.html>): table b-trees, records and overflow pages;
//! enough for rosbag2's two tables, `topics(id, name, type, serialization_format, ...)` and
//! `messages(id, topic_id, timestamp, data)`. Ours rather than a SQLite build so it runs in
//! wasm32 too and reads pages through [`ReadAt`] (the page streams big files); it ignores
//! indexes and a WAL (rosbag2 checkpoints it on close). `metadata.yaml` is not needed.
//!
//! Opening walks `messages`' b-tree reading each cell's `topic_id` and `timestamp` (the blob's
//! overflow pages are not read); a message's blob is read when it is asked for.

use std::collections::HashMap;

use super::error::{Bad, RecordingError};
use super::index::{ChunkRef, Encoding, Entry, Index, Loc, Progress, Topic};
use super::source::ReadAt;

pub const MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// A value of a record.
#[derive(Clone, Debug, PartialEq)]
enum Value {
    Null,
    Int(i64),
    Blob(Vec<u8>),
}

/// Called for each leaf cell: the database, the page number, the cell's byte in the page, the
/// page.
type Visit<'v, 'a> = dyn FnMut(&mut Db<'a>, u64, usize, &[u8]) -> Result<(), Bad> + 'v;

struct Db<'a> {
    src: &'a mut dyn ReadAt,
    page_size: u64,
    usable: u64,
    pages: u64,
}

fn varint(b: &[u8], at: &mut usize) -> Result<i64, Bad> {
    let mut v: u64 = 0;
    for i in 0..9 {
        let byte = *b.get(*at).ok_or_else(|| Bad::new("varint beyond its page"))?;
        *at += 1;
        if i == 8 {
            return Ok(((v << 8) | u64::from(byte)) as i64);
        }
        v = (v << 7) | u64::from(byte & 0x7F);
        if byte & 0x80 == 0 {
            break;
        }
    }
    Ok(v as i64)
}

impl<'a> Db<'a> {
    fn new(src: &'a mut dyn ReadAt) -> Result<Self, Bad> {
        let mut head = [0u8; 100];
        src.read_at(0, &mut head).map_err(|e| Bad::at(0, format!("database header: {e}")))?;
        let page_size = match u16::from_be_bytes([head[16], head[17]]) {
            1 => 65536,
            n if n >= 512 && n.is_power_of_two() => u64::from(n),
            n => return Err(Bad::at(16, format!("page size {n} is not a power of two from 512"))),
        };
        let usable = page_size - u64::from(head[20]);
        let pages = src.size() / page_size;
        Ok(Self { src, page_size, usable, pages })
    }

    fn page(&mut self, n: u64) -> Result<Vec<u8>, Bad> {
        if n == 0 || n > self.pages {
            return Err(Bad::new(format!("page {n} beyond the file's {} pages", self.pages)));
        }
        let at = (n - 1) * self.page_size;
        let mut buf = vec![0; self.page_size as usize];
        self.src.read_at(at, &mut buf).map_err(|e| Bad::at(at, format!("page {n}: {e}")))?;
        Ok(buf)
    }

    /// Calls `visit` for every leaf cell of the table b-tree rooted at `root`, in rowid order.
    fn walk(&mut self, root: u64, visit: &mut Visit<'_, 'a>) -> Result<(), Bad> {
        let mut stack = vec![root];
        let mut seen = 0u64;
        while let Some(n) = stack.pop() {
            seen += 1;
            if seen > self.pages {
                return Err(Bad::new("b-tree pages form a cycle"));
            }
            let page = self.page(n)?;
            let h = if n == 1 { 100 } else { 0 };
            let kind = *page.get(h).ok_or_else(|| Bad::new("empty page"))?;
            let cells = usize::from(u16::from_be_bytes([page[h + 3], page[h + 4]]));
            let header = if kind == 0x05 { 12 } else { 8 };
            let pointer = |i: usize| -> Result<usize, Bad> {
                let p = h + header + 2 * i;
                let b = page
                    .get(p..p + 2)
                    .ok_or_else(|| Bad::new(format!("page {n}: cell pointer beyond the page")))?;
                Ok(usize::from(u16::from_be_bytes([b[0], b[1]])))
            };
            match kind {
                0x05 => {
                    let right =
                        u32::from_be_bytes(page[h + 8..h + 12].try_into().unwrap_or([0; 4]));
                    // Children pushed in reverse so they pop in rowid order.
                    stack.push(u64::from(right));
                    for i in (0..cells).rev() {
                        let p = pointer(i)?;
                        let b = page
                            .get(p..p + 4)
                            .ok_or_else(|| Bad::new(format!("page {n}: cell beyond the page")))?;
                        stack.push(u64::from(u32::from_be_bytes(b.try_into().unwrap_or([0; 4]))));
                    }
                }
                0x0D => {
                    for i in 0..cells {
                        let p = pointer(i)?;
                        visit(self, n, p, &page)?;
                    }
                }
                k => {
                    return Err(Bad::new(format!(
                        "page {n}: type {k:#04x} is not a table b-tree page"
                    )));
                }
            }
        }
        Ok(())
    }

    /// The record of the leaf cell at byte `p` of `page`; with `blobs` false, blobs that spill
    /// onto overflow pages come back empty (their pages are not read).
    fn record(&mut self, page: &[u8], p: usize, blobs: bool) -> Result<Vec<Value>, Bad> {
        let mut at = p;
        let len = varint(page, &mut at)? as u64;
        varint(page, &mut at)?; // rowid
        let (u, x) = (self.usable, self.usable - 35);
        let inline = if len <= x {
            len
        } else {
            let m = ((u - 12) * 32 / 255) - 23;
            let k = m + (len - m) % (u - 4);
            if k <= x { k } else { m }
        };
        let end = at + inline as usize;
        let mut payload =
            page.get(at..end).ok_or_else(|| Bad::new("cell payload beyond its page"))?.to_vec();
        if inline < len {
            let b = page
                .get(end..end + 4)
                .ok_or_else(|| Bad::new("overflow pointer beyond its page"))?;
            let mut next = u64::from(u32::from_be_bytes(b.try_into().unwrap_or([0; 4])));
            // The header and the leading columns are inline (rosbag2's blob is the last column).
            while blobs && next != 0 && (payload.len() as u64) < len {
                if payload.len() as u64 > self.pages * self.usable {
                    return Err(Bad::new("overflow chain longer than the file"));
                }
                let o = self.page(next)?;
                next = u64::from(u32::from_be_bytes(o[..4].try_into().unwrap_or([0; 4])));
                let take = (len - payload.len() as u64).min(u - 4) as usize;
                payload.extend_from_slice(&o[4..4 + take]);
            }
        }
        values(&payload, len)
    }
}

/// The values of a record (`payload` may stop early: later values then read as empty blobs).
fn values(payload: &[u8], len: u64) -> Result<Vec<Value>, Bad> {
    let mut at = 0;
    let header = varint(payload, &mut at)? as usize;
    let mut types = Vec::new();
    while at < header.min(payload.len()) {
        types.push(varint(payload, &mut at)?);
    }
    let mut at = header;
    let mut out = Vec::with_capacity(types.len());
    for t in types {
        let size = match t {
            0 | 8 | 9 => 0,
            1..=4 => t as usize,
            5 => 6,
            6 | 7 => 8,
            t if t >= 12 => ((t - 12) / 2) as usize,
            t => return Err(Bad::new(format!("record serial type {t} reserved"))),
        };
        // A corrupt header can claim any size: sums are checked.
        let end =
            at.checked_add(size).ok_or_else(|| Bad::new("record value beyond its payload"))?;
        let bytes = payload.get(at..end);
        out.push(match (t, bytes) {
            (0, _) => Value::Null,
            (8, _) => Value::Int(0),
            (9, _) => Value::Int(1),
            (1..=6, Some(b)) => {
                let v = b.iter().fold(0i64, |v, &x| (v << 8) | i64::from(x));
                let shift = 64 - 8 * size as u32;
                Value::Int((v << shift) >> shift)
            }
            (_, Some(b)) => Value::Blob(b.to_vec()),
            (_, None) if end as u64 <= len => Value::Blob(Vec::new()),
            _ => return Err(Bad::new("record value beyond its payload")),
        });
        at = end;
    }
    Ok(out)
}

fn text(v: Option<&Value>) -> String {
    match v {
        Some(Value::Blob(b)) => String::from_utf8_lossy(b).into_owned(),
        _ => String::new(),
    }
}

/// The root pages of `topics` and `messages`, from the schema table on page 1.
fn roots(db: &mut Db) -> Result<(u64, u64), Bad> {
    let mut found = HashMap::new();
    db.walk(1, &mut |db, _, p, page| {
        let r = db.record(page, p, true)?;
        if let (Some(Value::Int(root)), "table") = (r.get(3), text(r.first()).as_str()) {
            found.insert(text(r.get(1)), *root as u64);
        }
        Ok(())
    })?;
    match (found.get("topics"), found.get("messages")) {
        (Some(&t), Some(&m)) => Ok((t, m)),
        _ => Err(Bad::new("no rosbag2 topics and messages tables")),
    }
}

pub fn open(src: &mut dyn ReadAt, file: &str, progress: Progress) -> Result<Index, RecordingError> {
    let size = src.size();
    let mut db = Db::new(src).map_err(|b| b.in_file(file))?;
    let (topics_root, messages_root) = roots(&mut db).map_err(|b| b.in_file(file))?;
    let mut index = Index::default();
    let mut ids = HashMap::new();
    db.walk(topics_root, &mut |db, _, p, page| {
        let r = db.record(page, p, true)?;
        let id = match r.first() {
            Some(Value::Int(i)) => *i,
            _ => rowid(page, p)?,
        };
        let type_name = text(r.get(2));
        let encoding = match text(r.get(3)).as_str() {
            "cdr" => Some(Encoding::Cdr),
            _ => None,
        };
        ids.insert(id, index.topics.len());
        index.topics.push(Topic::declared(text(r.get(1)), type_name, encoding));
        Ok(())
    })
    .map_err(|b| b.in_file(file))?;
    let page_size = db.page_size;
    let mut problems = Vec::new();
    let outcome = db.walk(messages_root, &mut |db, n, p, page| {
        progress(n * page_size, size);
        let r = db.record(page, p, false)?;
        let (Some(Value::Int(topic)), Some(Value::Int(time))) = (r.get(1), r.get(2)) else {
            return Err(Bad::new(format!("page {n}: message row without topic_id and timestamp")));
        };
        match ids.get(topic) {
            Some(&t) => index.entries.push(Entry {
                topic: t,
                time_ns: *time as u64,
                loc: Loc::Cell { page: n, cell: p },
            }),
            None => problems.push(
                Bad::new(format!("page {n}: message of unknown topic_id {topic}")).in_file(file),
            ),
        }
        Ok(())
    });
    // A damaged page ends the walk; what was indexed before stays usable.
    if let Err(bad) = outcome {
        problems.push(bad.in_file(file));
    }
    index.problems = problems;
    Ok(index)
}

fn rowid(page: &[u8], p: usize) -> Result<i64, Bad> {
    let mut at = p;
    varint(page, &mut at)?;
    varint(page, &mut at)
}

/// The `data` blob of the message in the cell at byte `cell` of page `page`.
pub fn message(
    src: &mut dyn ReadAt,
    _chunks: &[ChunkRef],
    page: u64,
    cell: usize,
) -> Result<Vec<u8>, Bad> {
    let mut db = Db::new(src)?;
    let bytes = db.page(page)?;
    match db.record(&bytes, cell, true)?.into_iter().nth(3) {
        Some(Value::Blob(b)) => Ok(b),
        _ => Err(Bad::new(format!("page {page}: message row without a data blob"))),
    }
}
