//! What went wrong in a recording, and where: the file, the topic, the message's index within
//! its topic, the byte offset, and the problem.

use std::fmt;

/// A recording (or one message in it) that could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordingError {
    pub file: String,
    pub topic: Option<String>,
    /// 0-based index of the message within its topic.
    pub message: Option<usize>,
    /// Byte offset in the file where the problem was found.
    pub offset: Option<u64>,
    pub problem: String,
}

impl fmt::Display for RecordingError {
    /// `run.mcap, topic /lidar/top, message 3, byte 8812: point_step 22 < field x's end 24`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.file)?;
        if let Some(topic) = &self.topic {
            write!(f, ", topic {topic}")?;
        }
        if let Some(m) = self.message {
            write!(f, ", message {m}")?;
        }
        if let Some(o) = self.offset {
            write!(f, ", byte {o}")?;
        }
        write!(f, ": {}", self.problem)
    }
}

impl std::error::Error for RecordingError {}

/// A problem found by a decoder before the file and topic are attached (decoders see bytes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Bad {
    pub offset: Option<u64>,
    pub problem: String,
}

impl Bad {
    pub fn at(offset: u64, problem: impl Into<String>) -> Self {
        Self { offset: Some(offset), problem: problem.into() }
    }

    pub fn new(problem: impl Into<String>) -> Self {
        Self { offset: None, problem: problem.into() }
    }

    pub fn in_file(self, file: &str) -> RecordingError {
        RecordingError {
            file: file.to_string(),
            topic: None,
            message: None,
            offset: self.offset,
            problem: self.problem,
        }
    }
}

impl fmt::Display for Bad {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset {
            Some(o) => write!(f, "byte {o}: {}", self.problem),
            None => f.write_str(&self.problem),
        }
    }
}
