//! The scans to calibrate from: [`Recording::choose`] pairs the topics' messages by the
//! sensors' own stamps (`header.stamp`), picks the instants ([`instants::pick`]), decodes the
//! chosen messages and compares the reference's consecutive scans ([`instants::motion`]);
//! [`nominals`] resolves each topic's frame in a transform tree.
//!
//! Stamps are inside the messages, and reading every message's would read most of the file, so
//! each topic's latency (log time minus stamp) is taken as the median over a few messages
//! spread over the recording ([`LATENCY_SAMPLES`]); its log times less that latency estimate
//! its stamps, and the instants are picked on those. The chosen messages' own stamps then give
//! the offsets reported; where one is beyond the tolerance, its neighbours are tried, and the
//! instant is dropped when none is within it. A zero stamp falls back to the log time.

use super::instants::{self, InstantSettings, Motion, Pick};
use super::tf::{Tree, TreeError};
use super::{PointCloud, Recording, RecordingError, pointcloud2};
use crate::se3::Pose;

/// Messages per topic whose stamps estimate its latency.
pub const LATENCY_SAMPLES: usize = 5;

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
    /// The instants: the reference's message and stamp, each other topic's message and the
    /// offset of its stamp from the reference's (ns).
    pub picks: Vec<Pick>,
    /// Topic by topic (in `topics`' order), instant by instant.
    pub scans: Vec<ChosenScan>,
    /// The reference's consecutive scans compared.
    pub motion: Motion,
}

impl Recording {
    /// `header.stamp` of message `message` of `topic` (ns), or its log time when the stamp is 0.
    fn stamp(&mut self, topic: usize, message: usize) -> Result<i64, RecordingError> {
        self.load(topic)?;
        let log = self.entries[topic].get(message).map_or(0, |e| e.time_ns as i64);
        let encoding = self.encoding(topic, message)?;
        let data = self.message(topic, message)?;
        let stamp = pointcloud2::stamp(&data, encoding)
            .map_err(|e| self.error(topic, message, super::Bad::new(e)))?;
        Ok(if stamp == 0 { log } else { stamp })
    }

    /// `topic`'s latency: the median of log time minus stamp over a few messages (ns).
    fn latency(&mut self, topic: usize) -> Result<i64, RecordingError> {
        let times = self.times(topic)?;
        let n = times.len();
        let k = LATENCY_SAMPLES.min(n);
        let mut lags = Vec::with_capacity(k);
        for s in 0..k {
            let m = if k == 1 { 0 } else { s * (n - 1) / (k - 1) };
            lags.push(times[m] as i64 - self.stamp(topic, m)?);
        }
        lags.sort_unstable();
        Ok(lags.get(k / 2).copied().unwrap_or(0))
    }

    /// Picks instants where every topic in `topics` has a scan stamped near `reference`'s, and
    /// decodes them. Fails on the first message that cannot be decoded (named).
    pub fn choose(
        &mut self,
        topics: &[usize],
        reference: usize,
        settings: &InstantSettings,
    ) -> Result<Chosen, RecordingError> {
        let others: Vec<usize> = topics.iter().copied().filter(|&t| t != reference).collect();
        let mut estimated = Vec::with_capacity(topics.len());
        for &t in std::iter::once(&reference).chain(&others) {
            let lag = self.latency(t)?;
            let times = self.times(t)?;
            estimated.push(times.iter().map(|&x| (x as i64 - lag).max(0) as u64).collect());
        }
        let estimated: Vec<Vec<u64>> = estimated;
        let mut picks = Vec::new();
        let mut clouds: Vec<Vec<(usize, PointCloud)>> = vec![Vec::new(); topics.len()];
        'instant: for mut pick in instants::pick(&estimated[0], &estimated[1..], settings) {
            let cloud = self.point_cloud(reference, pick.reference)?;
            let at = if cloud.stamp_ns == 0 { pick.reference_ns as i64 } else { cloud.stamp_ns };
            let mut found = vec![(pick.reference, cloud)];
            for (i, &topic) in others.iter().enumerate() {
                let Some(m) = self.nearest_stamp(topic, pick.others[i].0, at, settings)? else {
                    continue 'instant;
                };
                pick.others[i] = m;
                found.push((m.0, self.point_cloud(topic, m.0)?));
            }
            pick.reference_ns = at.max(0) as u64;
            for (slot, f) in clouds.iter_mut().zip(found) {
                slot.push(f);
            }
            picks.push(pick);
        }
        let mut scans = Vec::new();
        for &topic in topics {
            let slot = if topic == reference {
                0
            } else {
                1 + others.iter().position(|&o| o == topic).unwrap_or(0)
            };
            for (k, (message, cloud)) in std::mem::take(&mut clouds[slot]).into_iter().enumerate() {
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
        let motion = instants::motion(&reference_scans);
        Ok(Chosen { topics: topics.to_vec(), reference, picks, scans, motion })
    }

    /// Of `topic`'s message `m` and its neighbours, the one stamped nearest `at` within the
    /// tolerance, with its offset (ns); `None` when none is.
    fn nearest_stamp(
        &mut self,
        topic: usize,
        m: usize,
        at: i64,
        settings: &InstantSettings,
    ) -> Result<Option<(usize, i64)>, RecordingError> {
        self.load(topic)?;
        let n = self.entries[topic].len();
        let mut best: Option<(usize, i64)> = None;
        for j in [m, m.wrapping_sub(1), m + 1] {
            if j >= n {
                continue;
            }
            let offset = self.stamp(topic, j)? - at;
            if offset.unsigned_abs() <= settings.tolerance_ns
                && best.is_none_or(|(_, d)| offset.unsigned_abs() < d.unsigned_abs())
            {
                best = Some((j, offset));
            }
            if j == m && best.is_some() {
                break; // the estimate's own message is within the tolerance
            }
        }
        Ok(best)
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
