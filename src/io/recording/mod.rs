//! ROS recordings: MCAP, ROS 1 bags (v2.0) and rosbag2's SQLite `.db3`, read through
//! [`ReadAt`] so only the summary, the index and the chunks holding the chosen messages are
//! ever read; `sensor_msgs/PointCloud2` and Livox's `CustomMsg` into [`Cloud`](crate::Cloud)s and
//! `tf2_msgs/TFMessage` into a transform [`Tree`]; the instants to calibrate from
//! ([`instants`]); nominal extrinsics from `/tf_static` or a URDF ([`urdf`]).
//!
//! Every failure is a [`RecordingError`] naming the file, the topic, the message's index in
//! its topic and what is wrong. Damage that leaves the rest readable (a truncated tail, a
//! corrupt chunk) is kept in [`Recording::problems`] and the rest stays usable.

mod bag;
mod bytes;
mod choose;
mod compression;
mod db3;
mod error;
mod folder;
mod index;
pub mod instants;
mod livox;
mod mcap;
mod pointcloud2;
mod rig;
mod source;
mod tf;
pub mod urdf;
mod wire;

pub use choose::{Chosen, ChosenScan, nominals};
pub use compression::Compression;
pub use error::RecordingError;
pub use folder::storage_file;
pub use index::{Container, Encoding, Kind, Topic};
pub use livox::decode as decode_livox;
pub use pointcloud2::{PointCloud, decode as decode_point_cloud};
pub use rig::{RecordingRig, RigError, RigRequest};
#[cfg(not(target_arch = "wasm32"))]
pub use source::FileSource;
pub use source::ReadAt;
pub use tf::{Transform, Tree, TreeError, decode as decode_tf};

use error::Bad;
use index::{ChunkRef, Entry, Loc, Span};

/// An open recording: its topics and where each message lies. Reading a message reads (and
/// decompresses) only its chunk; the last chunk is kept, so messages read in file order
/// decompress each chunk once. An MCAP whose summary counts its messages is opened from the
/// summary alone; a topic's message indexes are read when the topic is first used.
pub struct Recording {
    file: String,
    container: Container,
    source: Box<dyn ReadAt>,
    topics: Vec<Topic>,
    /// Per topic, its messages in time order (stable: file order among equal times).
    entries: Vec<Vec<Entry>>,
    /// Per topic, its message index records not read yet.
    deferred: Vec<Option<Vec<Span>>>,
    chunks: Vec<ChunkRef>,
    cache: Option<(usize, Vec<u8>)>,
    problems: Vec<RecordingError>,
}

impl Recording {
    /// Opens a recording, telling the container by its first bytes. `file` labels errors.
    /// `progress(done, total)` is called (bytes) while a file without an index is scanned.
    pub fn open(
        mut source: Box<dyn ReadAt>,
        file: &str,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RecordingError> {
        let mut head = vec![0; source.size().min(16) as usize];
        source.read_at(0, &mut head).map_err(|e| Bad::at(0, e.to_string()).in_file(file))?;
        let (container, index) = if head.starts_with(mcap::MAGIC) {
            (Container::Mcap, mcap::open(source.as_mut(), file, progress)?)
        } else if head.starts_with(bag::MAGIC) {
            (Container::Bag, bag::open(source.as_mut(), file, progress)?)
        } else if head.starts_with(db3::MAGIC) {
            (Container::Db3, db3::open(source.as_mut(), file, progress)?)
        } else {
            let problem = "not a recording: expected MCAP, a ROS 1 bag v2.0 or a rosbag2 .db3";
            return Err(Bad::at(0, problem).in_file(file));
        };
        let mut entries = vec![Vec::new(); index.topics.len()];
        for e in index.entries {
            if let Some(list) = entries.get_mut(e.topic) {
                list.push(e);
            }
        }
        let mut deferred = index.deferred;
        deferred.resize(index.topics.len(), None);
        let mut recording = Self {
            file: file.to_string(),
            container,
            source,
            topics: index.topics,
            entries: Vec::new(),
            deferred,
            chunks: index.chunks,
            cache: None,
            problems: index.problems,
        };
        for (topic, list) in entries.into_iter().enumerate() {
            if recording.deferred[topic].is_none() {
                recording.set_entries(topic, list);
            } else {
                recording.entries.push(Vec::new()); // counted by the summary, read when used
            }
        }
        Ok(recording)
    }

    /// `topic`'s messages, put in time order; its count and times from them.
    fn set_entries(&mut self, topic: usize, mut list: Vec<Entry>) {
        list.sort_by_key(|e| e.time_ns);
        let t = &mut self.topics[topic];
        t.count = list.len();
        t.first_ns = list.first().map_or(0, |e| e.time_ns);
        t.last_ns = list.last().map_or(0, |e| e.time_ns);
        match self.entries.get_mut(topic) {
            Some(slot) => *slot = list,
            None => self.entries.push(list),
        }
    }

    /// Reads `topic`'s message indexes when they were left for its first use.
    fn load(&mut self, topic: usize) -> Result<(), RecordingError> {
        let Some(spans) = self.deferred.get_mut(topic).and_then(Option::take) else {
            return Ok(());
        };
        let mut list = Vec::new();
        for span in &spans {
            match mcap::message_index(self.source.as_mut(), span, topic) {
                Ok(entries) => list.extend(entries),
                Err(bad) => {
                    self.deferred[topic] = Some(spans);
                    let name = self.topics[topic].name.clone();
                    return Err(RecordingError { topic: Some(name), ..bad.in_file(&self.file) });
                }
            }
        }
        self.set_entries(topic, list);
        Ok(())
    }

    /// Opens a file on disk.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn open_path(
        path: &std::path::Path,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Self, RecordingError> {
        let label = path.display().to_string();
        let source = FileSource::open(path).map_err(|e| Bad::new(e.to_string()).in_file(&label))?;
        Self::open(Box::new(source), &label, progress)
    }

    pub fn file(&self) -> &str {
        &self.file
    }

    pub fn container(&self) -> Container {
        self.container
    }

    pub fn topics(&self) -> &[Topic] {
        &self.topics
    }

    /// The index of the topic named `name`.
    pub fn topic(&self, name: &str) -> Option<usize> {
        self.topics.iter().position(|t| t.name == name)
    }

    /// Damage found while opening that left the rest readable.
    pub fn problems(&self) -> &[RecordingError] {
        &self.problems
    }

    /// Recording times (ns) of `topic`'s messages, in order.
    pub fn times(&mut self, topic: usize) -> Result<Vec<u64>, RecordingError> {
        self.load(topic)?;
        Ok(self.entries.get(topic).map_or(Vec::new(), |l| l.iter().map(|e| e.time_ns).collect()))
    }

    fn error(&self, topic: usize, message: usize, bad: Bad) -> RecordingError {
        RecordingError {
            topic: self.topics.get(topic).map(|t| t.name.clone()),
            message: Some(message),
            ..bad.in_file(&self.file)
        }
    }

    /// The serialised bytes of message `message` of `topic`.
    pub fn message(&mut self, topic: usize, message: usize) -> Result<Vec<u8>, RecordingError> {
        self.load(topic)?;
        let entry = self.entries.get(topic).and_then(|l| l.get(message)).copied();
        let entry = entry.ok_or_else(|| self.error(topic, message, Bad::new("no such message")))?;
        self.read_entry(&entry).map_err(|bad| self.error(topic, message, bad))
    }

    fn read_entry(&mut self, entry: &Entry) -> Result<Vec<u8>, Bad> {
        match entry.loc {
            Loc::File(at) => mcap::loose_message(self.source.as_mut(), at),
            Loc::Cell { page, cell } => {
                db3::message(self.source.as_mut(), &self.chunks, page, cell)
            }
            Loc::Chunk { chunk, offset } => {
                if self.cache.as_ref().is_none_or(|(n, _)| *n != chunk) {
                    let c = self.chunks.get(chunk).ok_or_else(|| Bad::new("no such chunk"))?;
                    let data = match self.container {
                        Container::Bag => bag::load_chunk(self.source.as_mut(), c)?,
                        _ => mcap::load_chunk(self.source.as_mut(), c)?,
                    };
                    self.cache = Some((chunk, data));
                }
                let records = self.cache.as_ref().map_or(&[][..], |(_, d)| d.as_slice());
                match self.container {
                    Container::Bag => bag::message_at(records, offset).map(<[u8]>::to_vec),
                    _ => mcap::message_at(records, offset, 0).map(<[u8]>::to_vec),
                }
            }
        }
    }

    fn encoding(&self, topic: usize, message: usize) -> Result<Encoding, RecordingError> {
        let t = self.topics.get(topic);
        t.and_then(|t| t.encoding).ok_or_else(|| {
            self.error(topic, message, Bad::new("messages neither CDR nor ROS 1 encoded"))
        })
    }

    /// Message `message` of `topic` decoded as a point cloud: a Livox `CustomMsg` on a topic
    /// of that type, else a PointCloud2.
    pub fn point_cloud(
        &mut self,
        topic: usize,
        message: usize,
    ) -> Result<PointCloud, RecordingError> {
        let encoding = self.encoding(topic, message)?;
        let data = self.message(topic, message)?;
        let decoded = match self.topics.get(topic).map(|t| t.kind) {
            Some(Kind::LivoxCustom) => livox::decode(&data, encoding),
            _ => pointcloud2::decode(&data, encoding),
        };
        decoded.map_err(|e| self.error(topic, message, Bad::new(e)))
    }

    /// Every transform on `/tf_static` (and on `/tf` too with `dynamic`), in time order per
    /// topic; a message that cannot be read is reported and skipped.
    pub fn transforms(&mut self, dynamic: bool) -> (Vec<Transform>, Vec<RecordingError>) {
        let (mut out, mut problems) = (Vec::new(), Vec::new());
        let wanted: Vec<usize> = (0..self.topics.len())
            .filter(|&i| {
                let t = &self.topics[i];
                t.kind == Kind::TfMessage
                    && (t.name == "/tf_static" || (dynamic && t.name == "/tf"))
            })
            .collect();
        for topic in wanted {
            if let Err(e) = self.load(topic) {
                problems.push(e);
            }
            for m in 0..self.entries[topic].len() {
                let decoded = self.encoding(topic, m).and_then(|enc| {
                    let data = self.message(topic, m)?;
                    tf::decode(&data, enc).map_err(|e| self.error(topic, m, Bad::new(e)))
                });
                match decoded {
                    Ok(t) => out.extend(t),
                    Err(e) => problems.push(e),
                }
            }
        }
        (out, problems)
    }
}
