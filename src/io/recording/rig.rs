//! A rig from a recording, the way the CLI's `calibrate --bag` and the page build it: the
//! chosen point-cloud topics are the sensors, the chosen instants the frames, and each topic's
//! frame id resolved through `/tf_static` (or a URDF) to the base frame its nominal. A sensor is
//! named by its topic's frame id, the name the tf tree, the URDF and every export give it (a
//! topic's name where its frame id is empty or another chosen topic's too).

use super::instants::{InstantSettings, Motion, Pick};
use super::tf::{Tree, TreeError};
use super::urdf::Urdf;
use super::{Recording, RecordingError, nominals};
use crate::cloud::Scan;
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
    pub instants: InstantSettings,
    /// Nominals from this URDF instead of `/tf_static`.
    pub urdf: Option<&'a Urdf>,
}

impl Default for RigRequest<'_> {
    fn default() -> Self {
        Self {
            topics: None,
            reference: None,
            base_frame: "base_link".into(),
            instants: InstantSettings::default(),
            urdf: None,
        }
    }
}

/// The rig a recording makes.
#[derive(Clone, Debug)]
pub struct RecordingRig {
    /// Sensor = the topic's frame id (`sensor_names`), frame = instant ("1", "2", ...).
    pub scans: Vec<Scan>,
    /// `T_base_frame` per sensor; identity for every sensor when there is no tree.
    pub nominal: Vec<(String, Pose)>,
    /// The reference topic's sensor name.
    pub reference: String,
    /// The base frame the nominals are in.
    pub base: String,
    /// Per topic, its frame id.
    pub frames: Vec<(String, String)>,
    /// Per topic, its sensor's name.
    pub sensors: Vec<(String, String)>,
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
        let chosen = self.choose(&topics, r, &req.instants).map_err(RigError::Recording)?;
        if chosen.picks.is_empty() {
            let tolerance_ns = req.instants.tolerance_ns;
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
        let sensors = sensor_names(&frames);
        let name_of = |topic: &str| {
            sensors.iter().find(|(t, _)| t == topic).map_or(topic.to_string(), |(_, n)| n.clone())
        };
        let scans = scans
            .into_iter()
            .map(|s| Scan {
                source: Some(format!("{label} {} message {}", s.topic, s.message)),
                sensor: name_of(&s.topic),
                frame: s.frame,
                points: s.cloud.cloud.points,
            })
            .collect();
        let nominal = nominal.into_iter().map(|(topic, pose)| (name_of(&topic), pose)).collect();
        Ok(RecordingRig {
            scans,
            nominal,
            reference: name_of(&reference),
            base,
            frames,
            sensors,
            picks: chosen.picks,
            motion: chosen.motion,
            identity_nominals,
            problems,
            left_out,
        })
    }
}

/// Each topic's sensor name from its frame id (`(topic, frame_id)` in, `(topic, name)` out): the
/// frame id without tf1's leading `/`, or the topic's own name where that is empty or shared
/// with another topic (two topics of one LiDAR).
pub fn sensor_names(frames: &[(String, String)]) -> Vec<(String, String)> {
    let id = |frame: &str| frame.trim_start_matches('/').to_string();
    frames
        .iter()
        .map(|(topic, frame)| {
            let shared = frames.iter().filter(|(_, f)| id(f) == id(frame)).count() > 1;
            let name = if id(frame).is_empty() || shared { topic.clone() } else { id(frame) };
            (topic.clone(), name)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::sensor_names;

    #[test]
    fn sensors_are_named_by_frame_id_unless_empty_or_shared() {
        let pairs = |list: &[(&str, &str)]| -> Vec<(String, String)> {
            list.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect()
        };
        let frames = pairs(&[
            ("/lidar_1/points", "lidar_1"),
            ("/lidar_2/points", "/lidar_2"),
            ("/raw", "velodyne"),
            ("/filtered", "velodyne"),
            ("/bare", ""),
        ]);
        let want = pairs(&[
            ("/lidar_1/points", "lidar_1"),
            ("/lidar_2/points", "lidar_2"),
            ("/raw", "/raw"),
            ("/filtered", "/filtered"),
            ("/bare", "/bare"),
        ]);
        assert_eq!(sensor_names(&frames), want);
    }
}
