//! Loops close: where two sensors other than the reference overlap, registering one onto the
//! other alone, started from the result, leaves it where the result put it. The pipeline
//! registers each sensor to the reference (and the joint mixture), never one of the others to
//! another, so the pair is evidence the calibration did not fit: on a rig of five LiDARs around
//! a car, a sensor placed wrongly against the reference shows as a gap against its neighbours.

use std::f64::consts::SQRT_2;

use nalgebra::{Point3, Vector3};

use super::average::average;
use super::pairs::{PairIcp, align, fixed_cloud};
use crate::cloud::transformed;
use crate::icp;
use crate::se3::Pose;

/// Two sensors registered to each other alone, from the result: how far that moved the second.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopGap {
    /// The sensors' indices; `b` was registered onto `a`.
    pub a: usize,
    pub b: usize,
    /// Frames registered and averaged.
    pub frames: usize,
    /// The rotation (rad, about the vehicle's x, y, z) and the shift of `b`'s position (m,
    /// along the vehicle's x, y, z) the pair's registration applied.
    pub rotation: [f64; 3],
    pub position: [f64; 3],
    /// The pair's placement lands the two sensors' scans on each other better than the
    /// result's, by more than the selection's paired test allows for chance. A slide along a
    /// direction the pair's overlap leaves free (two narrow fields of view, a wall seen by
    /// both) moves far and lands no better.
    pub better: bool,
}

impl LoopGap {
    pub fn angle(&self) -> f64 {
        Vector3::from(self.rotation).norm()
    }

    pub fn distance(&self) -> f64 {
        Vector3::from(self.position).norm()
    }
}

/// Every pair of sensors but the reference `r` whose scans overlap (`overlap(a, b)`, a share of
/// `a`'s points, at least `min_overlap`), registered frame by frame with the frame pairs' own
/// ICP: `clouds` pre-aligned, `placed[s]` each sensor's result applied to its pre-aligned
/// clouds, `origins[s]` its position at the result (vehicle frame), `pairs[s]` its `(reference
/// view, view)` per frame; `better(a, b, motion)`: whether `b` moved by `motion` (vehicle
/// frame) lands better on `a`. A pair whose registration fails on every frame is left out.
#[allow(clippy::too_many_arguments)]
pub(super) fn gaps(
    clouds: &[&[[f32; 3]]],
    pairs: &[Vec<(usize, usize)>],
    r: usize,
    placed: &[Pose],
    origins: &[Vector3<f64>],
    icp: &PairIcp,
    overlap: impl Fn(usize, usize) -> f64,
    min_overlap: f64,
    better: impl Fn(usize, usize, &Pose) -> bool,
) -> Vec<LoopGap> {
    let sensors = placed.len();
    let mut gaps = Vec::new();
    // Each view's ICP fixed cloud, built when a pair first needs it: a sensor with several
    // neighbours is the target of each.
    let mut targets: Vec<Option<Option<icp::FixedCloud>>> = clouds.iter().map(|_| None).collect();
    for a in (0..sensors).filter(|&a| a != r) {
        for b in (a + 1..sensors).filter(|&b| b != r) {
            if overlap(a, b).max(overlap(b, a)) < min_overlap {
                continue;
            }
            let mut moves = Vec::new();
            for &(frame, view_a) in &pairs[a] {
                let Some(&(_, view_b)) = pairs[b].iter().find(|(f, _)| *f == frame) else {
                    continue;
                };
                let onto = targets[view_a].get_or_insert_with(|| {
                    fixed_cloud(&transformed(clouds[view_a], &placed[a]), icp, false).ok()
                });
                let Some(onto) = onto else { continue };
                let source = transformed(clouds[view_b], &placed[b]);
                if let Ok(m) = align(onto, &source, &Pose::identity(), icp) {
                    moves.push(m);
                }
            }
            let Some((mean, _)) = average(&moves) else { continue };
            let rotation = mean.rotation.scaled_axis();
            let position = mean * Point3::from(origins[b]) - Point3::from(origins[b]);
            gaps.push(LoopGap {
                a,
                b,
                frames: moves.len(),
                rotation: rotation.into(),
                position: position.into(),
                better: better(a, b, &mean),
            });
        }
    }
    gaps
}

/// Whether `gap` lands the pair better and is beyond both what two independent registrations
/// agree within (`agree`: an angle and a distance) and `sigmas` times the two sensors'
/// combined one-sigma precision on some axis (rotation per axis, position per axis; none
/// known counts as zero).
pub fn is_open(
    gap: &LoopGap,
    precision: [Option<&super::Precision>; 2],
    agree: (f64, f64),
    sigmas: f64,
) -> bool {
    let combined = |axis: usize, of: fn(&super::Precision) -> [f64; 3]| {
        let sq = |p: Option<&super::Precision>| p.map_or(0.0, |p| of(p)[axis].powi(2));
        sigmas * (sq(precision[0]) + sq(precision[1])).sqrt()
    };
    let beyond = |values: [f64; 3], of: fn(&super::Precision) -> [f64; 3]| {
        (0..3).any(|i| values[i].abs() > combined(i, of))
    };
    gap.better
        && ((gap.angle() > agree.0 && beyond(gap.rotation, |p| p.rotation))
            || (gap.distance() > agree.1 && beyond(gap.position, |p| p.position)))
}

/// Widens each sensor's precision to cover the loops it is in: a pair's gap, where its placement
/// lands the scans better than the result's, is one draw of the difference between two
/// sensors' errors, so per axis the two one-sigmas together must reach it. Each is raised to at
/// least the gap over root two; loops that close or slide (landing no better) change nothing,
/// so a rig whose loops close keeps the precision its scans give (Hesai's QTs claimed 0.07 deg /
/// 1 cm where their loops open by 0.8 deg / 5-16 cm).
pub(super) fn widen(precision: &mut [Option<super::Precision>], gaps: &[LoopGap]) {
    for gap in gaps.iter().filter(|g| g.better) {
        for s in [gap.a, gap.b] {
            let p = precision[s].get_or_insert_with(Default::default);
            for i in 0..3 {
                p.rotation[i] = p.rotation[i].max(gap.rotation[i].abs() / SQRT_2);
                p.position[i] = p.position[i].max(gap.position[i].abs() / SQRT_2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::{PairSettings, Precision};
    use crate::se3::pose_from_xyz_rpy;
    use crate::twin::Model;

    /// The twin's five LiDARs around a car, placed by their true mounts, one frame: the loops
    /// close at the truth, and a sensor placed 1 deg / 5 cm off shows as that gap against each
    /// neighbour it overlaps.
    #[test]
    fn a_misplaced_sensor_opens_its_loops_and_the_truth_closes_them() {
        let model = Model::by_name("surround").unwrap();
        let mounts = model.mounts();
        let scans = model.simulate(1, 7);
        let clouds: Vec<Vec<[f32; 3]>> = (scans.iter().zip(&mounts))
            .map(|(scan, (_, mount))| {
                let hits = scan.cloud.points.iter().filter(|p| **p != [0.0; 3]);
                let hits: Vec<[f32; 3]> = hits.copied().collect();
                transformed(&hits, mount)
            })
            .collect();
        let clouds: Vec<&[[f32; 3]]> = clouds.iter().map(Vec::as_slice).collect();
        let n = clouds.len();
        let pairs: Vec<Vec<(usize, usize)>> = (0..n).map(|s| vec![(0, s)]).collect();
        let origins: Vec<Vector3<f64>> = mounts.iter().map(|(_, m)| m.translation.vector).collect();
        let icp = PairIcp { settings: PairSettings::default(), ground: None };
        let run = |placed: &[Pose]| {
            let all = |_: usize, _: usize| 1.0;
            gaps(&clouds, &pairs, 0, placed, &origins, &icp, all, 0.05, |_, _, _| true)
        };
        let truth = run(&vec![Pose::identity(); n]);
        assert_eq!(truth.len(), (n - 1) * (n - 2) / 2);
        let limit = (0.05f64.to_radians(), 0.01);
        for g in &truth {
            // A pair alone slides a little along what its overlap leaves loose (up to 2.3 cm
            // here): why an open loop must also land better and pass both precisions.
            assert!(g.angle() < 0.1f64.to_radians() && g.distance() < 0.03, "{g:?}");
            println!(
                "truth {}-{}: {:.4} deg {:.2} cm",
                g.a,
                g.b,
                g.angle().to_degrees(),
                g.distance() * 1e2
            );
        }
        // Sensor 2 placed off: about its own position, 1 deg of yaw and 5 cm along y.
        let off = pose_from_xyz_rpy([0.0, 0.05, 0.0], [0.0, 0.0, 1f64.to_radians()]);
        let about = |p: &Pose, o: &Vector3<f64>| {
            let to = nalgebra::Translation3::from(*o);
            to * p * to.inverse()
        };
        let mut placed = vec![Pose::identity(); n];
        placed[2] = about(&off, &origins[2]);
        let off_gaps = run(&placed);
        let mut seen = 0;
        for (g, t) in off_gaps.iter().zip(&truth) {
            println!(
                "off {}-{}: {:.4} deg {:.2} cm",
                g.a,
                g.b,
                g.angle().to_degrees(),
                g.distance() * 1e2
            );
            if g.a != 2 && g.b != 2 {
                assert_eq!(g, t, "a pair without sensor 2 sees the same scans");
                continue;
            }
            // Registered onto the other, sensor 2 comes back (or the other follows it).
            if t.angle() < limit.0 && t.distance() < limit.1 {
                assert!((g.angle().to_degrees() - 1.0).abs() < 0.1, "{g:?}");
                assert!((g.distance() - 0.05).abs() < 0.01, "{g:?}");
                seen += 1;
            }
        }
        assert!(seen >= 1, "no neighbour of sensor 2 resolved the loop: {truth:?}");
    }

    fn gap(rotation: [f64; 3], position: [f64; 3]) -> LoopGap {
        LoopGap { a: 1, b: 2, frames: 1, rotation, position, better: true }
    }

    /// A gap that lands better widens both sensors' precision to it over root two, axis by
    /// axis, keeping what is wider already; a slide (landing no better) widens nothing.
    #[test]
    fn a_gap_that_lands_better_widens_both_precisions() {
        let p = Precision { rotation: [1e-3; 3], position: [0.01; 3] };
        let mut precision = vec![None, Some(p), Some(p)];
        let slide = LoopGap { better: false, ..gap([0.0; 3], [0.5, 0.0, 0.0]) };
        widen(&mut precision, &[slide]);
        assert_eq!(precision, vec![None, Some(p), Some(p)]);
        widen(&mut precision, &[gap([0.0, 0.0, -0.01], [0.0, 0.05, 0.001])]);
        for s in [1, 2] {
            let w = precision[s].unwrap();
            assert_eq!(w.rotation[..2], [1e-3; 2]);
            assert!((w.rotation[2] - 0.01 / SQRT_2).abs() < 1e-12);
            assert_eq!([w.position[0], w.position[2]], [0.01; 2]);
            assert!((w.position[1] - 0.05 / SQRT_2).abs() < 1e-12);
        }
        assert_eq!(precision[0], None, "the reference is in no loop");
    }

    #[test]
    fn open_beyond_agreement_and_precision_both() {
        let agree = (0.2f64.to_radians(), 0.02);
        let p = Precision { rotation: [1e-3; 3], position: [0.01; 3] };
        // 5 cm along x: beyond 2 cm and beyond 3 x sqrt(2) x 1 cm.
        assert!(is_open(&gap([0.0; 3], [0.05, 0.0, 0.0]), [Some(&p), Some(&p)], agree, 3.0));
        // 3 cm: beyond 2 cm, within 4.2 cm.
        assert!(!is_open(&gap([0.0; 3], [0.03, 0.0, 0.0]), [Some(&p), Some(&p)], agree, 3.0));
        // Without a precision only the agreement counts.
        assert!(is_open(&gap([0.0; 3], [0.03, 0.0, 0.0]), [None, None], agree, 3.0));
        assert!(!is_open(&gap([0.003, 0.0, 0.0], [0.0; 3]), [None, None], agree, 3.0));
        assert!(is_open(&gap([0.0, 0.0, 0.01], [0.0; 3]), [Some(&p), None], agree, 3.0));
        // A slide that lands no better is no gap.
        let slide = LoopGap { better: false, ..gap([0.0; 3], [0.5, 0.0, 0.0]) };
        assert!(!is_open(&slide, [None, None], agree, 3.0));
    }
}
