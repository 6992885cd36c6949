//! The scans to calibrate from: [`Recording::choose`] picks the instants ([`select::pick`]),
//! decodes the chosen messages and compares the reference's consecutive scans
//! ([`select::motion`]); [`nominals`] resolves each topic's frame in a transform tree.

use super::select::{self, Motion, Pick, Settings};
use super::tf::{Tree, TreeError};
use super::{PointCloud, Recording, RecordingError};
use crate::se3::Pose;

/// One decoded scan of the chosen instants.
#[derive(Clone, Debug, PartialEq)]
pub struct ChosenScan {
    /// The topic's name (the sensor's name in a rig).
    pub topic: String,
    /// The instant's number, from 1 (a frame's name in a rig).
    pub frame: String,
    /// The message's index in its topic.
    pub message: usize,
    pub cloud: PointCloud,
}

/// What [`Recording::choose`] chose.
#[derive(Clone, Debug, PartialEq)]
pub struct Chosen {
    /// Indices of the chosen topics, as given; `reference` among them.
    pub topics: Vec<usize>,
    pub reference: usize,
    /// The instants, with each other topic's offset from the reference (ns).
    pub picks: Vec<Pick>,
    /// Topic by topic (in `topics`' order), instant by instant.
    pub scans: Vec<ChosenScan>,
    /// The reference's consecutive scans compared.
    pub motion: Motion,
}

impl Recording {
    /// Picks instants where every topic in `topics` has a message near `reference`'s, and
    /// decodes them. Fails on the first message that cannot be decoded (named).
    pub fn choose(
        &mut self,
        topics: &[usize],
        reference: usize,
        settings: &Settings,
    ) -> Result<Chosen, RecordingError> {
        let others: Vec<usize> = topics.iter().copied().filter(|&t| t != reference).collect();
        let times: Vec<Vec<u64>> = others.iter().map(|&t| self.times(t)).collect();
        let picks = select::pick(&self.times(reference), &times, settings);
        let mut scans = Vec::new();
        for &topic in topics {
            for (k, pick) in picks.iter().enumerate() {
                let message = match others.iter().position(|&o| o == topic) {
                    Some(i) => pick.others[i].0,
                    None => pick.reference,
                };
                let cloud = self.point_cloud(topic, message)?;
                let name = self.topics[topic].name.clone();
                scans.push(ChosenScan { topic: name, frame: (k + 1).to_string(), message, cloud });
            }
        }
        let name = &self.topics[reference].name;
        let reference_scans: Vec<&[[f32; 3]]> = scans
            .iter()
            .filter(|s| &s.topic == name)
            .map(|s| s.cloud.cloud.points.as_slice())
            .collect();
        let motion = select::motion(&reference_scans);
        Ok(Chosen { topics: topics.to_vec(), reference, picks, scans, motion })
    }
}

/// `(sensor, T_base_frame)` for each `(sensor, frame_id)` through `tree`.
pub fn nominals(
    tree: &Tree,
    base: &str,
    frames: &[(String, String)],
) -> Result<Vec<(String, Pose)>, TreeError> {
    frames.iter().map(|(sensor, frame)| Ok((sensor.clone(), tree.resolve(base, frame)?))).collect()
}
