//! rosbag2's SQLite `.db3` (placeholder until the reader lands).

use super::error::{Bad, RecordingError};
use super::index::{ChunkRef, Index, Progress};
use super::source::ReadAt;

pub const MAGIC: &[u8; 16] = b"SQLite format 3\0";

pub fn open(_src: &mut dyn ReadAt, file: &str, _progress: Progress) -> Result<Index, RecordingError> {
    Err(Bad::new("rosbag2 .db3 not supported yet").in_file(file))
}

pub fn message(_src: &mut dyn ReadAt, _chunks: &[ChunkRef], _row: i64) -> Result<Vec<u8>, Bad> {
    Err(Bad::new("rosbag2 .db3 not supported yet"))
}
