//! Which messages to calibrate from: instants spread over the recording where every chosen
//! topic has a scan close to the reference's, and whether the rig moved between them.
//!
//! The calibration assumes that the scans of one instant see the same scene; pairing by the
//! sensors' stamps within a tolerance keeps that ([`Recording::choose`](super::Recording::choose)
//! gives [`pick`] stamps estimated from the log times, then checks the chosen messages' own),
//! and a moving rig (which breaks the assumption between instants only if the sensors are not
//! synchronised) is reported.

use std::collections::HashSet;

/// How instants are picked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstantSettings {
    /// Instants wanted; fewer when fewer qualify.
    pub frames: usize,
    /// Largest |offset| between a topic's message and the reference's (ns).
    pub tolerance_ns: u64,
}

impl Default for InstantSettings {
    fn default() -> Self {
        Self { frames: 10, tolerance_ns: 20_000_000 }
    }
}

/// One instant: the reference's message and, per other topic, its nearest message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pick {
    /// Index of the reference's message.
    pub reference: usize,
    pub reference_ns: u64,
    /// Per other topic (in the order given): its message index and its time minus the
    /// reference's (ns).
    pub others: Vec<(usize, i64)>,
}

/// Picks up to `settings.frames` instants from `reference`'s message times where every topic
/// in `others` has a message within the tolerance, spread evenly over those that qualify
/// (first and last included). Times must be sorted.
pub fn pick(reference: &[u64], others: &[Vec<u64>], settings: &InstantSettings) -> Vec<Pick> {
    let candidates: Vec<Pick> = reference
        .iter()
        .enumerate()
        .filter_map(|(i, &t)| {
            let others = others
                .iter()
                .map(|times| {
                    nearest(times, t).filter(|(_, d)| d.unsigned_abs() <= settings.tolerance_ns)
                })
                .collect::<Option<Vec<_>>>()?;
            Some(Pick { reference: i, reference_ns: t, others })
        })
        .collect();
    let (n, want) = (candidates.len(), settings.frames);
    if n <= want {
        return candidates;
    }
    let index = |k: usize| {
        if want == 1 { (n - 1) / 2 } else { (k * (n - 1) + (want - 1) / 2) / (want - 1) }
    };
    (0..want).map(|k| candidates[index(k)].clone()).collect()
}

/// The message of `times` nearest to `t` and its offset `time - t` (ns); the earlier on ties.
fn nearest(times: &[u64], t: u64) -> Option<(usize, i64)> {
    let i = times.partition_point(|&x| x < t);
    let offset = |j: usize| (j, times[j] as i64 - t as i64);
    match (i.checked_sub(1).map(offset), (i < times.len()).then(|| offset(i))) {
        (Some(a), Some(b)) => Some(if b.1.unsigned_abs() < a.1.unsigned_abs() { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// Voxel edge (m) for comparing consecutive scans: coarse enough that a static sensor's
/// repeated returns (range noise of a few cm) land in the same voxels.
pub const MOTION_VOXEL: f64 = 0.25;
/// A pair of scans sharing less than this fraction of occupied voxels means the rig moved.
pub const MOTION_OVERLAP: f64 = 0.5;

/// How the reference's scans changed from one instant to the next.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Per consecutive pair: the fraction of the later scan's points in voxels the earlier
    /// scan occupies (1: the same scene from the same place).
    pub overlap: Vec<f64>,
    /// Per consecutive pair: how far the centroid moved (m).
    pub centroid_shift: Vec<f64>,
    /// Some pair's overlap is below [`MOTION_OVERLAP`].
    pub moving: bool,
}

/// Compares consecutive scans of one sensor (a static rig sees the same scene).
pub fn motion(scans: &[&[[f32; 3]]]) -> Motion {
    let key = |p: &[f32; 3]| p.map(|c| (f64::from(c) / MOTION_VOXEL).floor() as i64);
    let (mut overlap, mut centroid_shift) = (Vec::new(), Vec::new());
    for pair in scans.windows(2) {
        let occupied: HashSet<[i64; 3]> = pair[0].iter().map(key).collect();
        let hits = pair[1].iter().filter(|p| occupied.contains(&key(p))).count();
        overlap.push(if pair[1].is_empty() { 0.0 } else { hits as f64 / pair[1].len() as f64 });
        let c = |s: &[[f32; 3]]| crate::cloud::centroid(s.iter()).unwrap_or([0.0; 3]);
        let (a, b) = (c(pair[0]), c(pair[1]));
        centroid_shift
            .push(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt());
    }
    let moving = overlap.iter().any(|&o| o < MOTION_OVERLAP);
    Motion { overlap, centroid_shift, moving }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_spread_instants_within_tolerance() {
        let reference: Vec<u64> = (0..21).map(|i| i * 100_000_000).collect();
        // The other topic is 5 ms late, and silent around 1 s.
        let other: Vec<u64> = reference
            .iter()
            .map(|t| t + 5_000_000)
            .filter(|t| !(900_000_000..1_200_000_000).contains(t))
            .collect();
        let picks =
            pick(&reference, &[other], &InstantSettings { frames: 4, tolerance_ns: 20_000_000 });
        let chosen: Vec<usize> = picks.iter().map(|p| p.reference).collect();
        // 18 qualify (9, 10 and 11 do not): candidates 0, 5.67, 11.33 and 17 rounded.
        assert_eq!(chosen, [0, 6, 14, 20]);
        assert!(picks.iter().all(|p| p.others[0].1 == 5_000_000));
        let none = pick(&reference, &[vec![50_000_000_000]], &InstantSettings::default());
        assert!(none.is_empty());
    }

    #[test]
    fn tells_a_moving_rig() {
        let scene: Vec<[f32; 3]> =
            (0..400).map(|i| [(i % 20) as f32 * 0.5, (i / 20) as f32 * 0.5, 0.0]).collect();
        let moved: Vec<[f32; 3]> = scene.iter().map(|p| [p[0] + 3.1, p[1] + 0.37, p[2]]).collect();
        assert!(!motion(&[&scene, &scene]).moving);
        let m = motion(&[&scene, &moved]);
        assert!(
            m.moving
                && (m.centroid_shift[0] - (3.1f64.powi(2) + 0.37f64.powi(2)).sqrt()).abs() < 1e-4
        );
    }
}
