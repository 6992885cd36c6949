//! What the user supplies: scans labelled (sensor, frame), a nominal extrinsic per sensor, the
//! region of interest and the reference sensor; and the checks every calibration starts with.

use super::CalibError;
use crate::cloud::Aabb;
pub use crate::cloud::Scan;
use crate::se3::Pose;

/// Everything about the rig the user supplies.
#[derive(Clone, Debug)]
pub struct Rig {
    pub scans: Vec<Scan>,
    /// Nominal `T_vehicle_sensor` per sensor.
    pub nominal: Vec<(String, Pose)>,
    /// Region of interest in the vehicle frame (m), bounds inclusive; `None`: where the
    /// sensors' clouds overlap (`region`).
    pub roi: Option<Aabb>,
    /// The sensor the others are calibrated to; default: the sensor with the most points
    /// (`reference_name`).
    pub reference: Option<String>,
}

impl Rig {
    /// Sensor names in order of first appearance among the scans: the order of
    /// `Calibration::sensors` and `Progress::corrections`.
    pub fn sensors(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for scan in &self.scans {
            if !names.contains(&scan.sensor) {
                names.push(scan.sensor.clone());
            }
        }
        names
    }

    /// The nominal `T_vehicle_sensor` of `sensor` (identity if it has none).
    pub fn nominal_of(&self, sensor: &str) -> Pose {
        self.nominal.iter().find(|(n, _)| n == sensor).map_or_else(Pose::identity, |(_, p)| *p)
    }

    /// The reference's name: the rig's, else the sensor with the most points over all its
    /// scans (the first such in `sensors` order; empty without scans). The densest sensor is
    /// the one that sees most of the scene and so the one the others overlap; the first named
    /// could be a side unit that sees the ground only. The page's panel applies the same rule
    /// (`www/src/state/state.js`, `mostPoints`) before any worker runs.
    pub fn reference_name(&self) -> String {
        if let Some(name) = &self.reference {
            return name.clone();
        }
        let count = |name: &str| -> usize {
            self.scans.iter().filter(|v| v.sensor == name).map(|v| v.points.len()).sum()
        };
        let mut best: Option<(String, usize)> = None;
        for name in self.sensors() {
            let n = count(&name);
            if best.as_ref().is_none_or(|(_, most)| n > *most) {
                best = Some((name, n));
            }
        }
        best.map(|(name, _)| name).unwrap_or_default()
    }

    /// The sensors in result order and the reference's index among them, after checking the
    /// ROI, the nominals, the points and the reference.
    pub(super) fn checked(&self) -> Result<(Vec<String>, usize), CalibError> {
        if self.roi.is_some_and(|roi| !roi.is_valid()) {
            return Err(CalibError::InvalidRoi);
        }
        let sensors = self.sensors();
        for name in &sensors {
            let (_, pose) = self
                .nominal
                .iter()
                .find(|(n, _)| n == name)
                .ok_or_else(|| CalibError::UnknownSensor(name.clone()))?;
            if !pose.to_homogeneous().iter().all(|x| x.is_finite()) {
                return Err(CalibError::NonFiniteNominal(name.clone()));
            }
        }
        if sensors.len() < 2 {
            return Err(CalibError::TooFewSensors(sensors.len()));
        }
        let reference = self.reference_name();
        let Some(r) = sensors.iter().position(|n| *n == reference) else {
            return Err(CalibError::UnknownReference(reference));
        };
        for scan in &self.scans {
            if let Some(index) = scan.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
                return Err(CalibError::NonFinitePoint {
                    sensor: scan.sensor.clone(),
                    frame: scan.frame.clone(),
                    index,
                });
            }
        }
        Ok((sensors, r))
    }
}

/// Sensor `s`'s seed: `seed` plus the rank of its name among the sensors', so that the same
/// scans give the same result whatever order the files came in.
pub(super) fn sensor_seed(seed: u64, sensors: &[String], s: usize) -> u64 {
    seed.wrapping_add(sensors.iter().filter(|n| **n < sensors[s]).count() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig(counts: &[(&str, usize)], reference: Option<&str>) -> Rig {
        let scans = counts
            .iter()
            .flat_map(|(sensor, n)| {
                // Two frames each, so that the count is over all of a sensor's scans.
                ["1", "2"].map(|frame| Scan {
                    sensor: sensor.to_string(),
                    frame: frame.into(),
                    points: vec![[1.0, 0.0, 0.0]; *n],
                    source: None,
                })
            })
            .collect();
        Rig { scans, nominal: Vec::new(), roi: None, reference: reference.map(str::to_string) }
    }

    #[test]
    fn the_reference_is_the_one_named_else_the_sensor_with_the_most_points() {
        assert_eq!(rig(&[("down", 10), ("up", 30), ("side", 20)], None).reference_name(), "up");
        assert_eq!(rig(&[("b", 10), ("a", 10)], None).reference_name(), "b", "a tie: the first");
        assert_eq!(rig(&[("down", 10), ("up", 30)], Some("down")).reference_name(), "down");
        assert_eq!(rig(&[], None).reference_name(), "");
    }
}
