//! Evidence the registrations did not optimise: where two sensors see the same patch of ground,
//! do their grounds meet? Per square patch of the reference's ground, each sensor's ground points
//! there get a plane of their own, and the two are compared at the patch's centre: a height
//! difference per patch. Patches, not one plane per sensor: a road is crowned by 1-2 %, so two
//! sensors seeing different stretches of it see different planes even when they agree. The
//! differences over the patches, fitted by a plane of their own, give the two grounds' offset
//! and relative tilt: one patch's tilt rests on a ring or two and says little.

use nalgebra::{Matrix3, Point3, Vector3};

use super::score::Scenes;
use crate::plane::{GroundFrame, Plane};
use crate::se3::Pose;

/// Edge (m) of a ground patch.
const PATCH: f64 = 2.0;
/// Ground points lie within this (m) of the reference's ground plane...
const BAND: f64 = 0.3;
/// ...with their normal within this of its normal (cos 20 deg).
const LEVEL: f64 = 0.94;
/// A sensor's part of a patch needs this many points, spread this far (m) both ways.
const MIN_POINTS: usize = 8;
const MIN_SPREAD: f64 = 0.3;

/// How well one sensor's ground meets the others' where they see the same patches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GroundAgreement {
    /// Patches both sensors see.
    pub patches: usize,
    /// The offset between the two grounds (m), at the patches' centroid.
    pub height: f64,
    /// The angle between the two grounds (rad).
    pub tilt: f64,
}

impl Scenes {
    /// Sensor `s`'s ground against every other sensor's, patch by patch on `ground` (the
    /// reference's, vehicle frame), each sensor at `poses` (`T_vehicle_sensor`); `None` when no
    /// patch is seen by `s` and another.
    pub fn ground_agreement(
        &self,
        s: usize,
        poses: &[Pose],
        ground: &Plane,
    ) -> Option<GroundAgreement> {
        let frame = GroundFrame::new(*ground);
        // Per (sensor, frame name, patch): the points (in-plane u, v, height).
        let patches = |sensor: usize| {
            let mut out: std::collections::BTreeMap<(String, i64, i64), Vec<Vector3<f64>>> =
                Default::default();
            for (name, surface) in self.frames_of(sensor) {
                for (i, p) in surface.points.iter().enumerate() {
                    let Some(n) = surface.normals[i] else { continue };
                    let p: Point3<f64> = poses[sensor] * Point3::from(p.map(f64::from));
                    let n = poses[sensor].rotation * n;
                    let height = ground.distance(&p.coords);
                    if height.abs() > BAND || n.dot(&ground.normal).abs() < LEVEL {
                        continue;
                    }
                    let uv = frame.along(&p.coords);
                    let cell = ((uv.x / PATCH).floor() as i64, (uv.y / PATCH).floor() as i64);
                    let at = Vector3::new(uv.x, uv.y, height);
                    out.entry((name.to_string(), cell.0, cell.1)).or_default().push(at);
                }
            }
            out
        };
        let mine = patches(s);
        let mut differences = Vec::new();
        for o in (0..poses.len()).filter(|&o| o != s) {
            let theirs = patches(o);
            for (key, points) in &mine {
                let Some(other) = theirs.get(key) else { continue };
                let centre =
                    Vector3::new((key.1 as f64 + 0.5) * PATCH, (key.2 as f64 + 0.5) * PATCH, 0.0);
                let (Some(a), Some(b)) = (fit(points, &centre), fit(other, &centre)) else {
                    continue;
                };
                differences.push(Vector3::new(centre.x, centre.y, a - b));
            }
        }
        let (height, tilt) = offset_and_tilt(&differences)?;
        Some(GroundAgreement { patches: differences.len(), height, tilt })
    }
}

/// The plane `d = a + b u + c v` through the per-patch differences `(u, v, d)`, robustly (a
/// second fit without the patches beyond three scaled median deviations): its value at the
/// patches' centroid (m, absolute) and its slope as an angle (rad). A single patch gives its
/// difference and no tilt.
fn offset_and_tilt(differences: &[Vector3<f64>]) -> Option<(f64, f64)> {
    let fit = |points: &[&Vector3<f64>]| -> Option<(Vector3<f64>, Vector3<f64>)> {
        let n = points.len() as f64;
        let centre = points.iter().fold(Vector3::zeros(), |c, p| c + **p) / n;
        if points.len() < 3 {
            return Some((centre, Vector3::zeros()));
        }
        let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
        for p in points {
            let row = Vector3::new(1.0, p.x - centre.x, p.y - centre.y);
            a += row * row.transpose();
            b += row * p.z;
        }
        // Patches in one row leave the slope across it free: no tilt is claimed there.
        let c = a.try_inverse().map_or(Vector3::new(centre.z, 0.0, 0.0), |inv| inv * b);
        Some((centre, c))
    };
    let all: Vec<&Vector3<f64>> = differences.iter().collect();
    let (centre, c) = fit(&all)?;
    let residual =
        |p: &Vector3<f64>| p.z - c[0] - c[1] * (p.x - centre.x) - c[2] * (p.y - centre.y);
    let mut deviations: Vec<f64> = all.iter().map(|p| residual(p).abs()).collect();
    let limit = 3.0 * 1.4826 * median(&mut deviations);
    let kept: Vec<&Vector3<f64>> =
        all.iter().copied().filter(|p| residual(p).abs() <= limit.max(1e-6)).collect();
    let (_, c) = if kept.len() >= 3 { fit(&kept)? } else { (centre, c) };
    Some((c[0].abs(), c[1].hypot(c[2]).atan()))
}

/// The plane `h = c0 + c1 (u - u0) + c2 (v - v0)` through `points` (u, v, h) about `centre`:
/// its height at the centre; `None` for too few points or too little spread.
fn fit(points: &[Vector3<f64>], centre: &Vector3<f64>) -> Option<f64> {
    if points.len() < MIN_POINTS {
        return None;
    }
    let spread = |k: usize| {
        let (lo, hi) =
            points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p[k]), hi.max(p[k])));
        hi - lo
    };
    if spread(0) < MIN_SPREAD || spread(1) < MIN_SPREAD {
        return None;
    }
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for p in points {
        let row = Vector3::new(1.0, p.x - centre.x, p.y - centre.y);
        a += row * row.transpose();
        b += row * p.z;
    }
    let c = a.try_inverse()? * b;
    Some(c[0])
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}
