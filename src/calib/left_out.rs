//! Sensors a method calibrates without: at their starts none of their points lie in the region
//! (the ROI given, or the one found where the clouds overlap). The others are calibrated, and
//! each is put back in its place, failed, its nominal kept, with the reason.

use std::borrow::Cow;

use super::Rig;
use super::global::GlobalAlignment;
use super::result::{Calibration, SensorResult, Spread};
use super::verdict::{Level, Reason, ReasonKind, SensorVerdict};
use crate::se3::Pose;

/// The sensors left out (indices among the rig's, rising), each with its global alignment.
#[derive(Default)]
pub(super) struct LeftOut(Vec<(usize, Option<GlobalAlignment>)>);

impl LeftOut {
    /// Whether sensor `name` of `rig` may be left out: never the reference, and two sensors
    /// stay.
    pub fn may_leave(&self, rig: &Rig, name: &str) -> bool {
        name != rig.reference_name() && rig.sensors().len() - self.0.len() > 2
    }

    /// Leaves sensor `name` of `rig` out, keeping its alignment among `alignments`.
    pub fn leave(&mut self, rig: &Rig, name: &str, alignments: &[GlobalAlignment]) {
        let s = rig.sensors().iter().position(|n| n == name).expect("a sensor of the rig");
        self.0.push((s, alignments.get(s).cloned()));
        self.0.sort_by_key(|(s, _)| *s);
    }

    /// `rig` less the sensors left out, and the global stage's alignments less theirs.
    pub fn rig<'a>(
        &self,
        rig: &'a Rig,
        alignments: &[GlobalAlignment],
    ) -> (Cow<'a, Rig>, Vec<GlobalAlignment>) {
        if self.0.is_empty() {
            return (Cow::Borrowed(rig), alignments.to_vec());
        }
        let sensors = rig.sensors();
        let out = |name: &str| self.0.iter().any(|(s, _)| sensors[*s] == name);
        let without = Rig {
            scans: rig.scans.iter().filter(|v| !out(&v.sensor)).cloned().collect(),
            nominal: rig.nominal.clone(),
            roi: rig.roi,
            reference: Some(rig.reference_name()),
        };
        let kept = alignments.iter().enumerate().filter(|(s, _)| !out(&sensors[*s]));
        (Cow::Owned(without), kept.map(|(_, a)| a.clone()).collect())
    }

    /// `corrections` of the sensors calibrated, with identity put in for each sensor left
    /// out: one per sensor of the rig, as progress reports them.
    pub fn corrections(&self, mut corrections: Vec<Pose>) -> Vec<Pose> {
        for (s, _) in &self.0 {
            corrections.insert((*s).min(corrections.len()), Pose::identity());
        }
        corrections
    }

    /// `c`, calibrated without the sensors left out, with each of them back in its place: its
    /// nominal kept, and failed.
    pub fn put_back(&self, rig: &Rig, mut c: Calibration) -> Calibration {
        let sensors = rig.sensors();
        let reference = c.sensors.iter().find(|s| s.name == c.reference).map(|s| s.extrinsic);
        for (s, alignment) in &self.0 {
            let name = sensors[*s].clone();
            let nominal = rig.nominal_of(&name);
            let relative = reference.map_or(nominal, |r| r.inverse() * nominal);
            let result = SensorResult {
                name: name.clone(),
                correction: Pose::identity(),
                extrinsic: nominal,
                relative,
                spread: Spread::default(),
                precision: None,
            };
            c.sensors.insert((*s).min(c.sensors.len()), result);
            let kind = ReasonKind::OutsideRegion { given: rig.roi.is_some() };
            let reason = Reason { level: Level::Failed, kind };
            let verdict = SensorVerdict {
                sensor: name,
                level: Level::Failed,
                reasons: vec![reason],
                evidence: None,
            };
            c.verdict.sensors.insert((*s).min(c.verdict.sensors.len()), verdict);
            if let Some(a) = alignment.as_ref().filter(|_| !c.global.is_empty()) {
                c.global.insert((*s).min(c.global.len()), a.clone());
            }
        }
        if !self.0.is_empty() {
            c.verdict.level = Level::Failed;
        }
        c
    }
}
