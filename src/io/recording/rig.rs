//! A rig from a recording, the way the CLI's `calibrate --bag` and the page build it: the
//! chosen point-cloud topics are the sensors, the chosen instants the frames, and each topic's
//! frame id resolved through `/tf_static` (or a URDF) to the base frame its nominal.

use super::select::{Motion, Pick, Settings as Select};
use super::tf::{Tree, TreeError};
use super::urdf::Urdf;
use super::{Recording, RecordingError, nominals};
use crate::calib::Scan;
use crate::se3::Pose;

/// What to take from a recording.
#[derive(Clone, Debug)]
pub struct RigRequest<'a> {
    /// The point-cloud topics to calibrate; `None`: every one with messages.
    pub topics: Option<Vec<String>>,
    /// The reference topic; `None`: the first.
    pub reference: Option<String>,
    /// The frame the nominals are expressed in, when the tree has it; else the tree's root.
    pub base_frame: String,
    pub select: Select,
    /// Nominals from this URDF instead of `/tf_static`.
    pub urdf: Option<&'a Urdf>,
}

impl Default for RigRequest<'_> {
    fn default() -> Self {
        Self {
            topics: None,
            reference: None,
            base_frame: "base_link".into(),
            select: Select::default(),
            urdf: None,
        }
    }
}

/// The rig a recording makes.
#[derive(Clone, Debug)]
pub struct RecordingRig {
    /// Sensor = topic, frame = instant ("1", "2", ...).
    pub scans: Vec<Scan>,
    /// `T_base_frame` per topic; identity for every topic when there is no tree.
    pub nominal: Vec<(String, Pose)>,
    pub reference: String,
    /// The base frame the nominals are in.
    pub base: String,
    /// Per topic, its frame id.
    pub frames: Vec<(String, String)>,
    /// The instants, with each other topic's offset from the reference (ns).
    pub picks: Vec<Pick>,
    pub motion: Motion,
    /// No `/tf_static` and no URDF: the nominals are identity.
    pub identity_nominals: bool,
    /// Transforms that could not be read (the rest were used).
    pub problems: Vec<RecordingError>,
    /// Topics left out when none were named: their frame is not in the tree.
    pub left_out: Vec<(String, TreeError)>,
}

/// Why a recording makes no rig.
#[derive(Debug)]
pub enum RigError {
    NoTopic(String),
    /// Fewer than two point-cloud topics.
    TooFewTopics(usize),
    ReferenceNotChosen(String),
    /// No instant where every topic has a scan within the tolerance of the reference's.
    NoInstant {
        reference: String,
        tolerance_ns: u64,
    },
    Recording(RecordingError),
    Tree(TreeError),
}

impl std::fmt::Display for RigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RigError::NoTopic(t) => write!(f, "no topic {t}"),
            RigError::TooFewTopics(n) => {
                write!(f, "{n} point-cloud topics; calibration needs two or more")
            }
            RigError::ReferenceNotChosen(t) => {
                write!(f, "the reference {t} is not among the topics")
            }
            RigError::NoInstant { reference, tolerance_ns } => write!(
                f,
                "no instant where every topic has a scan within {} ms of {reference}'s",
                *tolerance_ns as f64 * 1e-6
            ),
            RigError::Recording(e) => write!(f, "{e}"),
            RigError::Tree(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RigError {}

impl Recording {
    /// The rig `req` asks for.
    pub fn rig(&mut self, req: &RigRequest) -> Result<RecordingRig, RigError> {
        let (tree, problems) = match req.urdf {
            Some(urdf) => (urdf.tree(), Vec::new()),
            None => {
                let (transforms, problems) = self.transforms(false);
                (Tree::new(transforms), problems)
            }
        };
        let identity_nominals = tree.edges.is_empty();
        let mut left_out = Vec::new();
        let names: Vec<String> = match &req.topics {
            Some(list) => list.clone(),
            None => {
                let clouds: Vec<usize> = (0..self.topics().len())
                    .filter(|&t| self.topics()[t].kind.is_point_cloud())
                    .filter(|&t| self.topics()[t].count > 0)
                    .collect();
                // Topics the user did not name are left out when the tree cannot place them
                // (a recording's other point clouds: a depth camera, a map); named ones must
                // resolve. A topic's frame is its first message's.
                let base = (!identity_nominals).then(|| tree.base(&req.base_frame)).transpose();
                let base = base.map_err(RigError::Tree)?;
                let mut kept = Vec::new();
                for t in clouds {
                    let name = self.topics()[t].name.clone();
                    let Some(base) = &base else {
                        kept.push(name);
                        continue;
                    };
                    let frame = self.point_cloud(t, 0).map_err(RigError::Recording)?.frame_id;
                    match tree.resolve(base, &frame) {
                        Ok(_) => kept.push(name),
                        Err(e) => left_out.push((name, e)),
                    }
                }
                kept
            }
        };
        let topics = names
            .iter()
            .map(|n| self.topic(n).ok_or_else(|| RigError::NoTopic(n.clone())))
            .collect::<Result<Vec<_>, _>>()?;
        if topics.len() < 2 {
            return Err(RigError::TooFewTopics(topics.len()));
        }
        let reference = req.reference.clone().unwrap_or_else(|| names[0].clone());
        let r = names
            .iter()
            .position(|n| *n == reference)
            .map(|i| topics[i])
            .ok_or_else(|| RigError::ReferenceNotChosen(reference.clone()))?;
        let chosen = self.choose(&topics, r, &req.select).map_err(RigError::Recording)?;
        if chosen.picks.is_empty() {
            let tolerance_ns = req.select.tolerance_ns;
            return Err(RigError::NoInstant { reference, tolerance_ns });
        }
        let mut frames: Vec<(String, String)> = Vec::new();
        for s in &chosen.scans {
            if !frames.iter().any(|(t, _)| *t == s.topic) {
                frames.push((s.topic.clone(), s.cloud.frame_id.clone()));
            }
        }
        let scans = chosen.scans;
        let (nominal, base) = if identity_nominals {
            let identity = frames.iter().map(|(t, _)| (t.clone(), Pose::identity())).collect();
            (identity, req.base_frame.clone())
        } else {
            let base = tree.base(&req.base_frame).map_err(RigError::Tree)?;
            (nominals(&tree, &base, &frames).map_err(RigError::Tree)?, base)
        };
        let label = self.file().to_string();
        let scans = scans
            .into_iter()
            .map(|s| Scan {
                source: Some(format!("{label} {} message {}", s.topic, s.message)),
                sensor: s.topic,
                frame: s.frame,
                points: s.cloud.cloud.points,
            })
            .collect();
        Ok(RecordingRig {
            scans,
            nominal,
            reference,
            base,
            frames,
            picks: chosen.picks,
            motion: chosen.motion,
            identity_nominals,
            problems,
            left_out,
        })
    }
}
