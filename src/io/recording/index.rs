//! What a container reader learns when a recording is opened: its topics, where each message
//! lies (in a chunk or directly in the file) and the chunks. Shared by every container.

use super::compression::Compression;
use super::error::RecordingError;

/// The container a recording came in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// MCAP (ROS 2's default since Iron; also Foxglove's).
    Mcap,
    /// ROS 1 `.bag` v2.0.
    Bag,
    /// rosbag2's SQLite `.db3`.
    Db3,
}

/// How a topic's messages are serialised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 2's CDR, with its 4-byte encapsulation header.
    Cdr,
    /// ROS 1's serialisation.
    Ros1,
}

/// The message types this crate decodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    PointCloud2,
    /// Livox's `CustomMsg` point cloud (`livox_ros_driver` in ROS 1, `livox_ros_driver2`).
    LivoxCustom,
    TfMessage,
    Other,
}

impl Kind {
    /// From ROS 1 (`sensor_msgs/PointCloud2`) or ROS 2 (`sensor_msgs/msg/PointCloud2`) names.
    pub fn of(type_name: &str) -> Self {
        match type_name {
            "sensor_msgs/PointCloud2" | "sensor_msgs/msg/PointCloud2" => Self::PointCloud2,
            "livox_ros_driver/CustomMsg"
            | "livox_ros_driver/msg/CustomMsg"
            | "livox_ros_driver2/CustomMsg"
            | "livox_ros_driver2/msg/CustomMsg" => Self::LivoxCustom,
            "tf2_msgs/TFMessage" | "tf2_msgs/msg/TFMessage" => Self::TfMessage,
            _ => Self::Other,
        }
    }

    /// A point cloud that [`Recording::point_cloud`](super::Recording::point_cloud) decodes.
    pub fn is_point_cloud(self) -> bool {
        matches!(self, Self::PointCloud2 | Self::LivoxCustom)
    }
}

/// One topic of a recording.
#[derive(Clone, Debug, PartialEq)]
pub struct Topic {
    pub name: String,
    /// The message type as the recording names it (`sensor_msgs/msg/PointCloud2`).
    pub type_name: String,
    pub kind: Kind,
    /// `None` when the serialisation is neither CDR nor ROS 1 (e.g. JSON, protobuf).
    pub encoding: Option<Encoding>,
    /// Messages found (indexed or scanned).
    pub count: usize,
    /// Recording (log) time of the first and last message (ns since the epoch); 0 when none.
    pub first_ns: u64,
    pub last_ns: u64,
}

impl Topic {
    /// A topic as a container's header declares it; its messages are counted afterwards.
    pub(super) fn declared(name: String, type_name: String, encoding: Option<Encoding>) -> Self {
        let kind = Kind::of(&type_name);
        Self { name, type_name, kind, encoding, count: 0, first_ns: 0, last_ns: 0 }
    }

    /// Messages per second between the first and the last; 0 with fewer than two.
    pub fn rate_hz(&self) -> f64 {
        if self.count < 2 || self.last_ns <= self.first_ns {
            return 0.0;
        }
        (self.count - 1) as f64 / ((self.last_ns - self.first_ns) as f64 * 1e-9)
    }
}

/// Where one message's record starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loc {
    /// Offset of the record inside chunk `chunk`'s uncompressed records.
    Chunk { chunk: usize, offset: u64 },
    /// Offset of the record in the file (MCAP messages outside chunks).
    File(u64),
    /// A cell of rosbag2's `messages` table: its leaf page and the cell's byte in it.
    Cell { page: u64, cell: usize },
}

/// One message: its topic (index into the topics), recording time and place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    pub topic: usize,
    pub time_ns: u64,
    pub loc: Loc,
}

/// A compressed (or stored) block of records.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChunkRef {
    /// File offset of the chunk's record (its opcode or header).
    pub start: u64,
    /// File offset and length of its (compressed) records.
    pub data: u64,
    pub data_len: u64,
    pub uncompressed_len: u64,
    pub compression: Result<Compression, String>,
    /// MCAP's CRC-32 of the uncompressed records; 0: none.
    pub crc: u32,
}

/// One topic's message index record of one chunk, not read yet: the chunk and where the
/// record lies in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    pub chunk: usize,
    pub at: u64,
    pub len: u64,
}

/// What opening a recording yields.
#[derive(Debug, Default)]
pub struct Index {
    pub topics: Vec<Topic>,
    pub entries: Vec<Entry>,
    pub chunks: Vec<ChunkRef>,
    /// Per topic, its message index records left for when the topic is used (MCAP whose
    /// summary counts the messages: opening reads the summary alone); empty: all in `entries`.
    pub deferred: Vec<Option<Vec<Span>>>,
    /// Problems that left the rest readable (a truncated tail, a corrupt chunk skipped).
    pub problems: Vec<RecordingError>,
}

/// Progress of a scan: bytes done out of the file's size.
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);
