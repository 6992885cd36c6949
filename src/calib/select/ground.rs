//! Evidence the registrations did not optimise: where two sensors see the same patch of ground,
//! do their grounds meet? Per square patch of the reference's ground, each sensor's ground points
//! there and the other's are fitted by one plane, the terrain, with one sensor's raised by an
//! offset: a height difference per patch. Patches, not one plane per sensor: a road is crowned by 1-2 %, so two
//! sensors seeing different stretches of it see different planes even when they agree. The
//! differences over the patches, fitted by a plane of their own, give the two grounds' offset
//! and relative tilt: one patch's tilt rests on a ring or two and says little.

use nalgebra::{Matrix3, Matrix4, Point3, Vector3, Vector4};

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
                let Some((d, variance)) = offset(points, other, &centre) else { continue };
                differences.push((Vector3::new(centre.x, centre.y, d), 1.0 / variance));
            }
        }
        let (height, tilt) = offset_and_tilt(&differences)?;
        Some(GroundAgreement { patches: differences.len(), height, tilt })
    }
}

/// The plane `d = a + b u + c v` through the per-patch differences `(u, v, d)`, each weighted
/// by its inverse variance, robustly (a second fit without the patches beyond three scaled
/// median deviations, in units of their own errors): its value at the patches' weighted
/// centroid (m, absolute) and its slope as an angle (rad). A single patch gives its difference
/// and no tilt.
fn offset_and_tilt(differences: &[(Vector3<f64>, f64)]) -> Option<(f64, f64)> {
    let fit = |points: &[&(Vector3<f64>, f64)]| -> Option<(Vector3<f64>, Vector3<f64>)> {
        let total: f64 = points.iter().map(|(_, w)| w).sum();
        if points.is_empty() || total <= 0.0 {
            return None;
        }
        let centre = points.iter().fold(Vector3::zeros(), |c, (p, w)| c + p * *w) / total;
        if points.len() < 3 {
            return Some((centre, Vector3::new(centre.z, 0.0, 0.0)));
        }
        let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
        for (p, w) in points {
            let row = Vector3::new(1.0, p.x - centre.x, p.y - centre.y);
            a += *w * row * row.transpose();
            b += *w * row * p.z;
        }
        // Patches in one row leave the slope across it free: no tilt is claimed there.
        let c = a.try_inverse().map_or(Vector3::new(centre.z, 0.0, 0.0), |inv| inv * b);
        Some((centre, c))
    };
    let all: Vec<&(Vector3<f64>, f64)> = differences.iter().collect();
    let (centre, c) = fit(&all)?;
    let residual = |(p, w): &(Vector3<f64>, f64)| {
        (p.z - c[0] - c[1] * (p.x - centre.x) - c[2] * (p.y - centre.y)).abs() * w.sqrt()
    };
    let mut deviations: Vec<f64> = all.iter().map(|d| residual(d)).collect();
    let limit = 3.0 * 1.4826 * median(&mut deviations);
    let kept: Vec<&(Vector3<f64>, f64)> =
        all.iter().copied().filter(|d| residual(d) <= limit.max(1e-9)).collect();
    let (_, c) = if kept.len() >= 3 { fit(&kept)? } else { (centre, c) };
    Some((c[0].abs(), c[1].hypot(c[2]).atan()))
}

/// How far `mine` lies above `theirs` in one patch (points as (u, v, h)): one plane
/// `h = c0 + c1 (u - u0) + c2 (v - v0)` through both, the terrain, with `mine` raised by the
/// offset. Each sensor's own plane, taken to the patch's centre, would rest on the one or two
/// rings it has there, and its slope across them would carry the range noise metres out
/// (the `stacked` twin at its truth: 24-54 mm apart); the shared slope comes from both. `None`
/// for too few points of either, or too little spread of both together. With the offset its
/// variance: where each sensor holds one arc, the offset trades against the slope across the
/// arcs and the patch weighs little.
fn offset(
    mine: &[Vector3<f64>],
    theirs: &[Vector3<f64>],
    centre: &Vector3<f64>,
) -> Option<(f64, f64)> {
    if mine.len() < MIN_POINTS || theirs.len() < MIN_POINTS {
        return None;
    }
    let spread = |k: usize| {
        let (lo, hi) = (mine.iter().chain(theirs))
            .fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p[k]), hi.max(p[k])));
        hi - lo
    };
    if spread(0) < MIN_SPREAD || spread(1) < MIN_SPREAD {
        return None;
    }
    let (mut a, mut b) = (Matrix4::zeros(), Vector4::zeros());
    for (points, raised) in [(mine, 1.0), (theirs, 0.0)] {
        for p in points {
            let row = Vector4::new(raised, 1.0, p.x - centre.x, p.y - centre.y);
            a += row * row.transpose();
            b += row * p.z;
        }
    }
    let inverse = a.try_inverse()?;
    let c = inverse * b;
    let mut squares = 0.0;
    for (points, raised) in [(mine, 1.0), (theirs, 0.0)] {
        for p in points {
            let row = Vector4::new(raised, 1.0, p.x - centre.x, p.y - centre.y);
            squares += (p.z - row.dot(&c)).powi(2);
        }
    }
    let n = (mine.len() + theirs.len()) as f64;
    // A floor of a tenth of a millimetre: points exactly on a plane would weigh infinitely.
    let variance = (squares / (n - 4.0)).max(1e-8) * inverse[(0, 0)];
    Some((c[0], variance))
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two sensors each see arcs of a patch of road crowned by 2 %, 5 mm apart in height,
    /// with 1 cm of noise. Where their arcs cross, the offset comes out within its error and
    /// that error is small; where each holds one arc a metre from the other's, the offset
    /// trades against the slope across the arcs, and its error says so.
    #[test]
    fn arcs_of_one_patch_give_their_offset_and_how_well() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let road = |u: f64, v: f64| 0.02 * u - 0.01 * v;
        let mut arc = |v0: f64, bend: f64, raised: f64| -> Vec<Vector3<f64>> {
            (0..40)
                .map(|k| {
                    let u = -1.0 + k as f64 * 0.05;
                    let v = v0 + bend * u * u;
                    Vector3::new(u, v, road(u, v) + raised + 0.01 * rng.random_range(-1.0..1.0))
                })
                .collect()
        };
        let (mine, theirs) = (arc(0.0, 0.4, 0.005), arc(0.4, -0.4, 0.0));
        let (d, variance) = offset(&mine, &theirs, &Vector3::zeros()).unwrap();
        let crossing = variance.sqrt();
        assert!(crossing < 0.002 && (d - 0.005).abs() < 3.0 * crossing, "{d} +- {crossing}");
        let (apart, theirs) = (arc(0.4, 0.3, 0.005), arc(-0.7, 0.3, 0.0));
        let (d, variance) = offset(&apart, &theirs, &Vector3::zeros()).unwrap();
        let error = variance.sqrt();
        assert!(error > 2.0 * crossing && (d - 0.005).abs() < 3.0 * error, "{d} +- {error}");
        // Too few points of one sensor: no difference.
        assert_eq!(offset(&mine[..5], &theirs, &Vector3::zeros()), None);
    }
}
