//! Evidence the registrations did not optimise: where two sensors see the same patch of ground,
//! do their grounds meet? Per square patch of the reference's ground, each sensor's ground points
//! there and the other's are fitted by one plane, the terrain, with one sensor's raised by an
//! offset: a height difference per patch. Patches, not one plane per sensor: a road is crowned
//! by 1-2 %, so two sensors seeing different stretches of it see different planes even when
//! they agree. The
//! differences over the patches, fitted by a plane of their own, give the two grounds' offset
//! and relative tilt: one patch's tilt rests on a ring or two and says little.

use nalgebra::{Matrix3, Matrix4, Point3, Vector2, Vector3, Vector4};

use super::score::Scenes;
use crate::calib::verdict::MIN_GROUND_PATCHES;
use crate::plane::{GroundFrame, Plane};
use crate::se3::Pose;

/// Edge (m) of a ground patch.
const PATCH: f64 = 2.0;
/// Ground points lie within this (m) of the reference's ground plane...
const BAND: f64 = 0.3;
/// ...with their normal within this of its normal (cos 20 deg).
const LEVEL: f64 = 0.94;
/// Prior one-sigma of the terrain's slope within a patch against the reference's ground (rad).
const SLOPE_SIGMA: f64 = 0.02;
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
    /// One sigma of each, from the patches' scatter about the fitted plane of differences.
    pub height_sigma: f64,
    pub tilt_sigma: f64,
    /// The axis (unit, vehicle frame, in the ground plane) about which its ground is tilted
    /// against the others'; zero without a tilt.
    pub axis: [f64; 3],
}

impl GroundAgreement {
    /// The grounds lie apart beyond `(angle, distance)` (rad, m) by more than `z` of their
    /// sigmas, on enough patches to judge by.
    pub fn beyond(&self, (angle, distance): (f64, f64), z: f64) -> bool {
        self.patches >= MIN_GROUND_PATCHES
            && (self.tilt - z * self.tilt_sigma > angle
                || self.height - z * self.height_sigma > distance)
    }
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
            let mut out: std::collections::BTreeMap<(&str, i64, i64), Vec<Vector3<f64>>> =
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
                    out.entry((name, cell.0, cell.1)).or_default().push(at);
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
                let Some((d, variance)) = offset(points, other, &centre, SLOPE_SIGMA) else {
                    continue;
                };
                differences.push((Vector3::new(centre.x, centre.y, d), 1.0 / variance));
            }
        }
        let ([height, tilt, height_sigma, tilt_sigma], slope) = offset_and_tilt(&differences)?;
        // A rotation w tilts the heights along u by -w.v and along v by w.u (u x v = normal).
        let axis = (frame.u * slope.y - frame.v * slope.x).try_normalize(1e-12);
        let axis = axis.map_or([0.0; 3], Into::into);
        let patches = differences.len();
        Some(GroundAgreement { patches, height, tilt, height_sigma, tilt_sigma, axis })
    }
}

/// The plane `d = a + b u + c v` through the per-patch differences `(u, v, d)`, each weighted
/// by its inverse variance, robustly (a second fit without the patches beyond three scaled
/// median deviations, in units of their own errors): its value at the patches' weighted
/// centroid (m, absolute), its slope as an angle (rad), and one sigma of each, the patches'
/// weights scaled by their scatter about the plane (terrain and quantisation the patches'
/// own fits do not see). A single patch gives its difference and no tilt. With them the slope
/// (along u, v).
fn offset_and_tilt(differences: &[(Vector3<f64>, f64)]) -> Option<([f64; 4], Vector2<f64>)> {
    // The plane's centre, coefficients and normal matrix's inverse. Fewer than three patches,
    // or patches in one row (which leave the slope across it free), claim no tilt: the
    // weighted mean alone.
    let fit =
        |points: &[&(Vector3<f64>, f64)]| -> Option<(Vector3<f64>, Vector3<f64>, Matrix3<f64>)> {
            let total: f64 = points.iter().map(|(_, w)| w).sum();
            if points.is_empty() || total <= 0.0 {
                return None;
            }
            let centre = points.iter().fold(Vector3::zeros(), |c, (p, w)| c + p * *w) / total;
            let mean = || {
                let inverse = Matrix3::from_diagonal(&Vector3::new(1.0 / total, 0.0, 0.0));
                (centre, Vector3::new(centre.z, 0.0, 0.0), inverse)
            };
            if points.len() < 3 {
                return Some(mean());
            }
            let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
            for (p, w) in points {
                let row = Vector3::new(1.0, p.x - centre.x, p.y - centre.y);
                a += *w * row * row.transpose();
                b += *w * row * p.z;
            }
            Some(a.try_inverse().map_or_else(mean, |inverse| (centre, inverse * b, inverse)))
        };
    let all: Vec<&(Vector3<f64>, f64)> = differences.iter().collect();
    let (centre, c, _) = fit(&all)?;
    let residual = |(p, w): &(Vector3<f64>, f64), c: &Vector3<f64>, centre: &Vector3<f64>| {
        (p.z - c[0] - c[1] * (p.x - centre.x) - c[2] * (p.y - centre.y)).abs() * w.sqrt()
    };
    let mut deviations: Vec<f64> = all.iter().map(|d| residual(d, &c, &centre)).collect();
    let limit = 3.0 * 1.4826 * median(&mut deviations);
    let kept: Vec<&(Vector3<f64>, f64)> =
        all.iter().copied().filter(|d| residual(d, &c, &centre) <= limit.max(1e-9)).collect();
    let used = if kept.len() >= 3 { kept } else { all };
    let (centre, c, inverse) = fit(&used)?;
    // The weights' scale from the scatter: the reduced chi-square, where the plane leaves
    // degrees of freedom.
    let scale = if used.len() > 3 {
        used.iter().map(|d| residual(d, &c, &centre).powi(2)).sum::<f64>() / (used.len() - 3) as f64
    } else {
        1.0
    };
    let slope = Vector2::new(c[1], c[2]);
    let tilt_sigma = match slope.try_normalize(1e-12) {
        Some(g) => {
            let s = inverse.fixed_view::<2, 2>(1, 1);
            (scale * (g.transpose() * s * g)[(0, 0)]).max(0.0).sqrt()
        }
        // No slope: its error is the larger of the two directions'.
        None => (scale * inverse[(1, 1)].max(inverse[(2, 2)])).max(0.0).sqrt(),
    };
    let height_sigma = (scale * inverse[(0, 0)]).max(0.0).sqrt();
    Some(([c[0].abs(), slope.norm().atan(), height_sigma, tilt_sigma], slope))
}

/// How far `mine` lies above `theirs` in one patch (points as (u, v, h)): one plane
/// `h = c0 + c1 (u - u0) + c2 (v - v0)` through both, the terrain, with `mine` raised by the
/// offset. Each sensor's own plane, taken to the patch's centre, would rest on the one or two
/// rings it has there, and its slope across them would carry the range noise metres out
/// (the `stacked` twin at its truth: 24-54 mm apart); the shared slope comes from both. `None`
/// for too few points of either, or too little spread of both together. With the offset its
/// variance: where each sensor holds one arc, the offset trades against the slope across the
/// arcs, as far as the slope's prior (`slope_sigma` per axis, rad) lets it, and the patch
/// weighs little.
fn offset(
    mine: &[Vector3<f64>],
    theirs: &[Vector3<f64>],
    centre: &Vector3<f64>,
    slope_sigma: f64,
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
    // Each point's row of the design (raised, 1, u, v) and its height.
    let rows: Vec<(Vector4<f64>, f64)> = [(mine, 1.0), (theirs, 0.0)]
        .into_iter()
        .flat_map(|(points, raised)| {
            points
                .iter()
                .map(move |p| (Vector4::new(raised, 1.0, p.x - centre.x, p.y - centre.y), p.z))
        })
        .collect();
    let (mut a, mut b) = (Matrix4::zeros(), Vector4::zeros());
    for (row, h) in &rows {
        a += row * row.transpose();
        b += row * *h;
    }
    let n = rows.len() as f64;
    // The terrain's slope is a nuisance with a prior: ground within a patch lies near the
    // reference's ground plane (a road's crown), `slope_sigma` per axis. Where each sensor sees
    // the patch along one scan ring, nearly parallel arcs, the data leave the slope across
    // them free, and fitted freely it takes the offset's place. The prior weighs as two
    // observations of a zero slope in units of the heights' noise, taken before the fit (the
    // scatter about each sensor's own mean) so that the slope cannot shrink it.
    let scatter = |points: &[Vector3<f64>]| {
        let mean = points.iter().map(|p| p.z).sum::<f64>() / points.len() as f64;
        points.iter().map(|p| (p.z - mean).powi(2)).sum::<f64>()
    };
    let noise = (scatter(mine) + scatter(theirs)) / (n - 2.0);
    let weight = noise / (slope_sigma * slope_sigma);
    a[(2, 2)] += weight;
    a[(3, 3)] += weight;
    let inverse = a.try_inverse()?;
    let c = inverse * b;
    let squares: f64 = rows.iter().map(|(row, h)| (h - row.dot(&c)).powi(2)).sum();
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

    /// One patch of the `stacked` twin (seed 8) at the truth, a flat ground: each sensor sees it
    /// along one scan ring, two nearly parallel arcs half a metre apart, heights within 12 mm
    /// of zero. Fitting the terrain's slope freely, the arcs' slight bend lets a 10 deg slope
    /// take the offset's place: 113 mm, claimed to 8 mm. With the slope's prior the offset
    /// shrinks to a few centimetres at most, within its sigmas.
    #[test]
    fn two_rings_in_a_patch_leave_the_offset_to_the_heights() {
        let points = |list: &[[f64; 3]]| -> Vec<Vector3<f64>> {
            list.iter().map(|p| Vector3::from(*p)).collect()
        };
        let mine = points(&[
            [-9.27, 4.32, 0.0004],
            [-9.27, 4.38, -0.0045],
            [-9.14, 4.55, 0.0062],
            [-9.12, 4.72, -0.0035],
            [-9.09, 4.75, -0.0016],
            [-9.04, 4.77, 0.0062],
            [-9.05, 4.81, 0.0023],
            [-9.04, 4.88, -0.0025],
            [-8.98, 4.93, 0.0033],
            [-9.02, 5.02, -0.0113],
            [-8.97, 5.04, -0.0035],
            [-8.91, 5.05, 0.0023],
            [-8.92, 5.14, -0.0045],
            [-8.9, 5.13, -0.0016],
            [-8.86, 5.2, 0.0004],
        ]);
        let theirs = points(&[
            [-8.14, 5.28, -0.002],
            [-8.42, 4.72, 0.0026],
            [-8.48, 4.66, -0.0039],
            [-8.51, 4.58, -0.0015],
            [-8.62, 4.45, -0.0117],
            [-8.56, 4.38, 0.0078],
            [-8.63, 4.31, -0.0015],
            [-8.68, 4.21, -0.002],
            [-8.72, 4.16, -0.0059],
            [-8.69, 4.07, 0.0078],
        ]);
        let centre = Vector3::new(-9.0, 5.0, 0.0);
        let (free, variance) = offset(&mine, &theirs, &centre, f64::INFINITY).unwrap();
        assert!(free > 0.1 && free > 10.0 * variance.sqrt(), "{free} +- {}", variance.sqrt());
        let (d, variance) = offset(&mine, &theirs, &centre, SLOPE_SIGMA).unwrap();
        let sigma = variance.sqrt();
        assert!(d.abs() < 3.0 * sigma && d.abs() < 0.03, "{d} +- {sigma}");
    }

    /// Patch differences with a tilt of 0.1 deg, 5 mm apart at the centre, scattering 3 mm
    /// where each patch claims 1 mm: the offset and tilt come out within their sigmas, and the
    /// sigmas follow the scatter, not the patches' claims.
    #[test]
    fn the_grounds_offset_and_tilt_carry_the_patches_scatter() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let slope = 0.1f64.to_radians().tan();
        let mut differences = Vec::new();
        for i in -5..5 {
            for j in -3..3 {
                let (u, v) = (2.0 * i as f64 + 1.0, 2.0 * j as f64 + 1.0);
                let scatter = 0.003 * 3f64.sqrt() * rng.random_range(-1.0..1.0);
                differences.push((Vector3::new(u, v, 0.005 + slope * u + scatter), 1e6));
            }
        }
        let ([height, tilt, height_sigma, tilt_sigma], slope) =
            offset_and_tilt(&differences).unwrap();
        assert!(slope.y.abs() < 3.0 * tilt_sigma, "{slope}");
        // 60 patches of 3 mm: 0.39 mm on the offset; the claims alone would say 0.13 mm.
        assert!(height_sigma > 0.0003 && height_sigma < 0.0005, "{height_sigma}");
        assert!((height - 0.005).abs() < 3.0 * height_sigma, "{height} +- {height_sigma}");
        let tilt_deg = tilt.to_degrees();
        assert!((tilt_deg - 0.1).abs() < 3.0 * tilt_sigma.to_degrees(), "{tilt_deg}");
        assert!(tilt_sigma.to_degrees() < 0.02, "{}", tilt_sigma.to_degrees());
    }

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
        let (d, variance) = offset(&mine, &theirs, &Vector3::zeros(), SLOPE_SIGMA).unwrap();
        let crossing = variance.sqrt();
        assert!(crossing < 0.002 && (d - 0.005).abs() < 3.0 * crossing, "{d} +- {crossing}");
        let (apart, theirs) = (arc(0.4, 0.3, 0.005), arc(-0.7, 0.3, 0.0));
        let (d, variance) = offset(&apart, &theirs, &Vector3::zeros(), SLOPE_SIGMA).unwrap();
        let error = variance.sqrt();
        assert!(error > 2.0 * crossing && (d - 0.005).abs() < 3.0 * error, "{d} +- {error}");
        // Too few points of one sensor: no difference.
        assert_eq!(offset(&mine[..5], &theirs, &Vector3::zeros(), SLOPE_SIGMA), None);
    }
}
