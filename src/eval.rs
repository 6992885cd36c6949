//! The paper's metrics (section V): how far an estimated extrinsic is from the truth, as a
//! transform and as the displacement it causes on scan points, plus the statistics that
//! summarise many trials. Pure functions and accumulators; no I/O.
//!
//! Extrinsics are `T_vehicle_sensor` (sensor points into the vehicle frame). Units: m, rad.

use nalgebra::{Point3, Vector3};

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use crate::calib::{Calibration, Precision, Rig};
use crate::cloud::is_valid_point;
use crate::se3::{Pose, rpy};
use crate::twin::{OrientedBox, Twin};

/// A trial counts as miscalibrated when the mean distance error (L2, m) over the validation
/// cube exceeds this: 5 cm, ten times the simulated range noise and a tenth of the cube's edge,
/// the size at which a fused scan visibly doubles the cube.
pub const MISCALIBRATION_THRESHOLD: f64 = 0.05;

/// Validation-cube points are those whose true position lies within this (m) of the cube, and
/// at least this high above the ground so the ground around it does not count.
pub const VALIDATION_MARGIN: f64 = 0.05;

/// Per-axis magnitude of `dT = T_est^-1 * T_true` (paper Table II).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformError {
    /// |roll|, |pitch|, |yaw| of `dT` (rad), by [`rpy`] (`R = Rz Ry Rx`).
    pub rpy: [f64; 3],
    /// |x|, |y|, |z| of `dT`'s translation (m).
    pub xyz: [f64; 3],
}

/// The transform error of an estimated extrinsic against the true one.
pub fn transform_error(estimate: &Pose, truth: &Pose) -> TransformError {
    let d = estimate.inverse() * truth;
    let t = d.translation.vector;
    TransformError { rpy: rpy(&d.rotation).map(f64::abs), xyz: [t.x.abs(), t.y.abs(), t.z.abs()] }
}

/// Paper eq. 5 over a set of points: each sensor point `p` goes to the vehicle frame once by
/// the estimate and once by the truth; the error is the mean of `|T_est p - T_true p|`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceError {
    /// Mean |dx|, |dy|, |dz| (m, vehicle frame).
    pub axes: [f64; 3],
    /// Mean Euclidean distance (m).
    pub norm: f64,
    /// Points averaged.
    pub points: usize,
}

/// [`DistanceError`] over the valid points of a scan (misses and non-finite points skipped)
/// whose TRUE vehicle-frame position satisfies `keep`; `None` when no point is kept.
pub fn distance_error(
    points: &[[f32; 3]],
    estimate: &Pose,
    truth: &Pose,
    keep: impl Fn(&Point3<f64>) -> bool,
) -> Option<DistanceError> {
    let (mut axes, mut norm, mut n) = ([0.0; 3], 0.0, 0usize);
    for p in points.iter().filter(|p| is_valid_point(p)) {
        let p = Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let true_point = truth * p;
        if !keep(&true_point) {
            continue;
        }
        let d = estimate * p - true_point;
        for (a, di) in axes.iter_mut().zip(d.iter()) {
            *a += di.abs();
        }
        norm += d.norm();
        n += 1;
    }
    (n > 0).then(|| DistanceError {
        axes: axes.map(|a| a / n as f64),
        norm: norm / n as f64,
        points: n,
    })
}

/// The `keep` rule for the validation cube: on the cube (within [`VALIDATION_MARGIN`]) and off
/// the ground.
pub fn on_box(cube: &OrientedBox) -> impl Fn(&Point3<f64>) -> bool + '_ {
    move |p| p.z > VALIDATION_MARGIN && cube.contains(p.coords, VALIDATION_MARGIN)
}

/// Paper's miscalibration test on a trial's mean validation-cube error (m). NaN (no error could
/// be measured) counts as miscalibrated.
pub fn is_miscalibrated(validation_norm: f64) -> bool {
    validation_norm.is_nan() || validation_norm > MISCALIBRATION_THRESHOLD
}

/// Least-squares line `y = slope x + intercept` over streamed samples, mergeable so trials can
/// be accumulated apart and combined. Sums are taken about a fixed shift (the first sample)
/// so millions of samples around 20 m do not cancel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinearFit {
    n: f64,
    shift: Option<(f64, f64)>,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
}

impl LinearFit {
    pub fn add(&mut self, x: f64, y: f64) {
        let (x0, y0) = *self.shift.get_or_insert((x, y));
        let (dx, dy) = (x - x0, y - y0);
        self.n += 1.0;
        self.sx += dx;
        self.sy += dy;
        self.sxx += dx * dx;
        self.sxy += dx * dy;
    }

    /// Adds every sample of `other` (re-expressed about this fit's shift).
    pub fn merge(&mut self, other: &LinearFit) {
        let Some((ox, oy)) = other.shift else { return };
        let (x0, y0) = *self.shift.get_or_insert((ox, oy));
        // other's sums are about (ox, oy); shift them by (a, b) = (ox - x0, oy - y0).
        let (a, b, n) = (ox - x0, oy - y0, other.n);
        self.sxx += other.sxx + 2.0 * a * other.sx + n * a * a;
        self.sxy += other.sxy + a * other.sy + b * other.sx + n * a * b;
        self.sx += other.sx + n * a;
        self.sy += other.sy + n * b;
        self.n += n;
    }

    /// Samples added.
    pub fn count(&self) -> usize {
        self.n as usize
    }

    /// `(slope, intercept)`; `None` with fewer than two distinct x.
    pub fn line(&self) -> Option<(f64, f64)> {
        let (x0, y0) = self.shift?;
        let var = self.sxx - self.sx * self.sx / self.n;
        if var.is_nan() || var <= 1e-12 * self.n {
            return None;
        }
        let slope = (self.sxy - self.sx * self.sy / self.n) / var;
        let (mx, my) = (x0 + self.sx / self.n, y0 + self.sy / self.n);
        Some((slope, my - slope * mx))
    }
}

/// The paper's global error: the distance error of every whole-scan point against its range
/// from the sensor (m), as a linear fit and as means per range bin (for plotting).
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalError {
    /// Width of a range bin (m).
    pub bin: f64,
    /// Sum of errors and count per bin; bin `i` covers `[i bin, (i + 1) bin)`.
    pub sums: Vec<(f64, u64)>,
    pub fit: LinearFit,
}

impl GlobalError {
    pub fn new(bin: f64) -> Self {
        Self { bin, sums: Vec::new(), fit: LinearFit::default() }
    }

    /// Adds the valid points of one scan (sensor frame) under an estimated and a true extrinsic.
    /// Range, not vehicle x, is the abscissa: scans cover 360 deg, and a rotation error grows
    /// with the lever arm from the sensor whichever way the point lies.
    pub fn add_scan(&mut self, points: &[[f32; 3]], estimate: &Pose, truth: &Pose) {
        for p in points.iter().filter(|p| is_valid_point(p)) {
            let p = Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let range = p.coords.norm();
            self.add(range, (estimate * p - truth * p).norm());
        }
    }

    pub fn add(&mut self, range: f64, error: f64) {
        let i = (range / self.bin) as usize;
        if self.sums.len() <= i {
            self.sums.resize(i + 1, (0.0, 0));
        }
        self.sums[i].0 += error;
        self.sums[i].1 += 1;
        self.fit.add(range, error);
    }

    pub fn merge(&mut self, other: &GlobalError) {
        if self.sums.len() < other.sums.len() {
            self.sums.resize(other.sums.len(), (0.0, 0));
        }
        for (s, o) in self.sums.iter_mut().zip(&other.sums) {
            s.0 += o.0;
            s.1 += o.1;
        }
        self.fit.merge(&other.fit);
    }

    /// `(bin centre, mean error)` of every non-empty bin.
    pub fn profile(&self) -> Vec<(f64, f64)> {
        let centre = |i: usize| (i as f64 + 0.5) * self.bin;
        let bins = self.sums.iter().enumerate().filter(|(_, (_, n))| *n > 0);
        bins.map(|(i, (s, n))| (centre(i), s / *n as f64)).collect()
    }
}

/// What one non-reference sensor's calibration got wrong, and what it claimed.
#[derive(Clone, Copy, Debug)]
pub struct SensorError {
    /// `C_est^-1 C_true` of its correction.
    pub error: Pose,
    /// Its rotation error about the vehicle axes, `log(R_est R_true^T)` (rad).
    pub rotation: Vector3<f64>,
    /// Its position error, estimate - truth (m).
    pub position: Vector3<f64>,
    /// The one-sigma precision the calibration claimed, if it did.
    pub precision: Option<Precision>,
}

impl SensorError {
    /// Rotation (deg) and translation (m) of the error.
    pub fn deg_m(&self) -> (f64, f64) {
        (self.error.rotation.angle().to_degrees(), self.error.translation.vector.norm())
    }
}

/// The error of `calibration` on each non-reference sensor of `twin`, in the twin's order;
/// `None` for a sensor the calibration has no result for.
pub fn sensor_errors(twin: &Twin, calibration: &Calibration) -> Vec<Option<SensorError>> {
    (1..twin.truth.len())
        .map(|i| {
            let (name, truth) = &twin.truth[i];
            let estimate = calibration.sensors.iter().find(|s| &s.name == name)?;
            Some(SensorError {
                error: estimate.correction.inverse() * twin.correction(i),
                rotation: (estimate.extrinsic.rotation * truth.rotation.inverse()).scaled_axis(),
                position: estimate.extrinsic.translation.vector - truth.translation.vector,
                precision: estimate.precision,
            })
        })
        .collect()
}

/// The precision claimed against the errors: per axis (rotation about the vehicle's x, y, z in
/// rad; position x, y, z in m) the RMS error and the RMS one-sigma claim, over the errors that
/// carry a claim; and how many do.
pub fn precision_rms<'a>(
    errors: impl IntoIterator<Item = &'a SensorError>,
) -> (usize, [(f64, f64); 6]) {
    let claimed: Vec<(&SensorError, Precision)> =
        errors.into_iter().filter_map(|e| Some((e, e.precision?))).collect();
    let n = claimed.len().max(1) as f64;
    let rms = |f: &dyn Fn(&(&SensorError, Precision)) -> f64| {
        (claimed.iter().map(|c| f(c).powi(2)).sum::<f64>() / n).sqrt()
    };
    let axes = std::array::from_fn(|i| match i {
        0..3 => (rms(&|c| c.0.rotation[i]), rms(&|c| c.1.rotation[i])),
        _ => (rms(&|c| c.0.position[i - 3]), rms(&|c| c.1.position[i - 3])),
    });
    (claimed.len(), axes)
}

/// How often the one-sigma precision claimed covers the error: per axis (as in
/// [`precision_rms`]) the share of the errors that carry a claim whose error is within it; and
/// how many carry one. An honest one-sigma covers about 68 % of normal errors.
pub fn precision_coverage<'a>(
    errors: impl IntoIterator<Item = &'a SensorError>,
) -> (usize, [f64; 6]) {
    let claimed: Vec<(&SensorError, Precision)> =
        errors.into_iter().filter_map(|e| Some((e, e.precision?))).collect();
    let n = claimed.len().max(1) as f64;
    let axes = std::array::from_fn(|i| {
        let within = |(e, p): &&(&SensorError, Precision)| match i {
            0..3 => e.rotation[i].abs() <= p.rotation[i],
            _ => e.position[i - 3].abs() <= p.position[i - 3],
        };
        claimed.iter().filter(within).count() as f64 / n
    });
    (claimed.len(), axes)
}

/// Summary statistics of a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub count: usize,
    pub mean: f64,
    /// Sample standard deviation (divides by n - 1; 0 for one value).
    pub std: f64,
    pub min: f64,
    /// Quartiles by linear interpolation between order statistics (numpy's default).
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
    pub max: f64,
}

/// Statistics of the finite values; `None` when there are none.
pub fn stats(values: &[f64]) -> Option<Stats> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let ss: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
    let std = if n > 1 { (ss / (n - 1) as f64).sqrt() } else { 0.0 };
    let quantile = |q: f64| {
        let h = q * (n - 1) as f64;
        let (lo, frac) = (h.floor() as usize, h.fract());
        v[lo] + frac * (v[(lo + 1).min(n - 1)] - v[lo])
    };
    Some(Stats {
        count: n,
        mean,
        std,
        min: v[0],
        q1: quantile(0.25),
        median: quantile(0.5),
        q3: quantile(0.75),
        max: v[n - 1],
    })
}

/// Moves every non-zero coordinate of `rig`'s scans by `ulps` units in the last place of its
/// f32, up or down as a generator seeded with `seed` draws: a change far below any LiDAR's
/// noise (a ulp is 1 µm at 10 m) that shows how far a calibration rests on digits its data do
/// not hold (`study --jitter`, docs/accuracy.md). Zero stays zero (the readers' "no return").
pub fn jitter(rig: &mut Rig, ulps: u32, seed: u64) {
    let mut rng = Pcg64::seed_from_u64(seed);
    for c in rig.scans.iter_mut().flat_map(|s| s.points.iter_mut()).flatten() {
        let up = rng.random::<bool>();
        // Away from or towards zero: the bits of an f32's magnitude count its ulps.
        let (sign, magnitude) = (c.to_bits() & 1 << 31, c.to_bits() & !(1 << 31));
        let magnitude =
            if up { magnitude.saturating_add(ulps) } else { magnitude.saturating_sub(ulps) };
        let moved = f32::from_bits(sign | magnitude);
        if *c != 0.0 && moved != 0.0 && moved.is_finite() {
            *c = moved;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::se3::pose_from_xyz_rpy;

    /// Coverage counts, per axis, the errors within their own claim; errors without a claim
    /// are left out.
    #[test]
    fn coverage_counts_the_errors_within_their_claim() {
        let error = |rotation: [f64; 3], position: [f64; 3], claim: Option<f64>| SensorError {
            error: Pose::identity(),
            rotation: rotation.into(),
            position: position.into(),
            precision: claim.map(|c| Precision { rotation: [c; 3], position: [c; 3] }),
        };
        let errors = [
            error([0.5, 2.0, 0.0], [0.1, 1.5, -3.0], Some(1.0)),
            error([-1.5, 0.2, 0.9], [-0.1, 0.5, 1.0], Some(1.0)),
            error([9.0; 3], [9.0; 3], None),
        ];
        let (claimed, axes) = precision_coverage(&errors);
        assert_eq!(claimed, 2);
        assert_eq!(axes, [0.5, 0.5, 1.0, 1.0, 0.5, 0.5]);
    }

    /// Each non-zero coordinate moves by exactly `ulps` ulps, up or down; zero stays; the same
    /// seed moves them the same way.
    #[test]
    fn jitter_moves_each_coordinate_by_its_ulps() {
        let scan = |points: Vec<[f32; 3]>| crate::calib::Scan {
            sensor: "a".into(),
            frame: "1".into(),
            points,
            source: None,
        };
        let points: Vec<[f32; 3]> = (0..200).map(|i| [i as f32 * 0.37 - 30.0, 0.0, 1e-3]).collect();
        let rig =
            Rig { scans: vec![scan(points)], nominal: Vec::new(), roi: None, reference: None };
        let (mut a, mut b) = (rig.clone(), rig.clone());
        jitter(&mut a, 16, 7);
        jitter(&mut b, 16, 7);
        assert_eq!(a.scans[0].points, b.scans[0].points);
        let pairs = rig.scans[0].points.iter().flatten().zip(a.scans[0].points.iter().flatten());
        let (mut up, mut down) = (0, 0);
        for (&before, &after) in pairs {
            if before == 0.0 {
                assert_eq!(after, 0.0);
                continue;
            }
            let steps = (after.abs().to_bits() as i64) - (before.abs().to_bits() as i64);
            assert_eq!(steps.abs(), 16, "{before} -> {after}");
            assert_eq!(before.signum(), after.signum());
            if steps > 0 { up += 1 } else { down += 1 }
        }
        assert!(up > 100 && down > 100, "{up} up, {down} down");
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn transform_error_of_a_pure_translation_and_a_pure_yaw() {
        let truth = pose_from_xyz_rpy([2.0, 0.5, 1.6], [0.3, 0.0, 0.0]);
        // Estimate = truth moved 1 cm along the SENSOR's y: dT = est^-1 truth = -1 cm on y.
        let est = truth * pose_from_xyz_rpy([0.0, 0.01, 0.0], [0.0; 3]);
        let e = transform_error(&est, &truth);
        assert!(close(e.xyz[0], 0.0) && close(e.xyz[1], 0.01) && close(e.xyz[2], 0.0));
        assert!(e.rpy.iter().all(|a| close(*a, 0.0)));
        // Estimate = truth turned by +0.02 rad of yaw about the sensor origin.
        let est = truth * pose_from_xyz_rpy([0.0; 3], [0.0, 0.0, 0.02]);
        let e = transform_error(&est, &truth);
        assert!(close(e.rpy[2], 0.02) && close(e.rpy[0], 0.0) && close(e.rpy[1], 0.0));
        assert!(e.xyz.iter().all(|t| close(*t, 0.0)));
    }

    #[test]
    fn distance_error_by_hand() {
        let truth = Pose::identity();
        // A yaw of 0.1 rad: the point (10, 0, 0) moves to 10 (cos 0.1, sin 0.1, 0).
        let est = pose_from_xyz_rpy([0.0, 0.0, 0.5], [0.0, 0.0, 0.1]);
        let points = [[10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [f32::NAN, 1.0, 1.0], [0.0, 0.0, 2.0]];
        let e = distance_error(&points, &est, &truth, |_| true).unwrap();
        // Misses and NaN are skipped: (10,0,0) errs by (10(c-1), 10 s, 0.5), (0,0,2) by (0,0,0.5).
        let (c, s) = (0.1f64.cos(), 0.1f64.sin());
        assert_eq!(e.points, 2);
        assert!(close(e.axes[0], 10.0 * (1.0 - c) / 2.0));
        assert!(close(e.axes[1], 10.0 * s / 2.0));
        assert!(close(e.axes[2], 0.5));
        let first = (100.0 * (1.0 - c).powi(2) + 100.0 * s * s + 0.25).sqrt();
        assert!(close(e.norm, (first + 0.5) / 2.0));
        // The filter sees the TRUE position.
        let high = distance_error(&points, &est, &truth, |p| p.z > 1.0).unwrap();
        assert_eq!((high.points, high.axes), (1, [0.0, 0.0, 0.5]));
        assert!(distance_error(&points, &est, &truth, |_| false).is_none());
    }

    #[test]
    fn validation_cube_keeps_cube_points_only() {
        let cube = OrientedBox::cube_on_ground(10.0, 0.0, 0.5, 0.0);
        let keep = on_box(&cube);
        assert!(keep(&Point3::new(10.25, 0.1, 0.3)));
        assert!(!keep(&Point3::new(10.25, 0.1, 0.0)), "ground at the cube's foot");
        assert!(!keep(&Point3::new(10.4, 0.1, 0.3)), "beyond the margin");
        assert!(is_miscalibrated(0.06) && !is_miscalibrated(0.05) && is_miscalibrated(f64::NAN));
    }

    #[test]
    fn linear_fit_recovers_a_line_and_merges() {
        let mut a = LinearFit::default();
        let mut b = LinearFit::default();
        // y = 0.002 x + 0.01 exactly, split over two accumulators with different shifts.
        for i in 0..50 {
            let x = 1.0 + i as f64;
            let fit = if i % 3 == 0 { &mut a } else { &mut b };
            fit.add(x, 0.002 * x + 0.01);
        }
        a.merge(&b);
        let (slope, intercept) = a.line().unwrap();
        assert!((slope - 0.002).abs() < 1e-12 && (intercept - 0.01).abs() < 1e-12);
        assert_eq!(a.count(), 50);
        // By hand: (0,0), (1,1), (2,1) -> slope 1/2, intercept 1/6.
        let mut f = LinearFit::default();
        for (x, y) in [(0.0, 0.0), (1.0, 1.0), (2.0, 1.0)] {
            f.add(x, y);
        }
        let (slope, intercept) = f.line().unwrap();
        assert!(close(slope, 0.5) && close(intercept, 1.0 / 6.0));
        let mut one_x = LinearFit::default();
        one_x.add(3.0, 1.0);
        one_x.add(3.0, 2.0);
        assert!(one_x.line().is_none() && LinearFit::default().line().is_none());
        let mut empty = LinearFit::default();
        empty.merge(&f);
        assert_eq!(empty.line(), f.line());
    }

    #[test]
    fn global_error_bins_by_range() {
        let mut g = GlobalError::new(1.0);
        let est = pose_from_xyz_rpy([0.0, 0.0, 0.01], [0.0; 3]);
        g.add_scan(&[[3.2, 0.0, 0.0], [0.0, 4.5, 0.0], [0.0; 3]], &est, &Pose::identity());
        let mut h = GlobalError::new(1.0);
        h.add(3.9, 0.03);
        g.merge(&h);
        let profile = g.profile();
        assert_eq!(profile.len(), 2);
        assert!(close(profile[0].0, 3.5) && close(profile[0].1, 0.02));
        assert!(close(profile[1].0, 4.5) && close(profile[1].1, 0.01));
        assert_eq!(g.fit.count(), 3);
    }

    #[test]
    fn stats_by_hand() {
        let s = stats(&[4.0, 1.0, f64::NAN, 3.0, 2.0]).unwrap();
        assert_eq!(s.count, 4);
        assert!(close(s.mean, 2.5));
        // Sample variance: (2.25 + 0.25 + 0.25 + 2.25) / 3 = 5/3.
        assert!(close(s.std, (5.0f64 / 3.0).sqrt()));
        // numpy: percentile([1,2,3,4], [25, 50, 75]) = 1.75, 2.5, 3.25.
        assert!(close(s.q1, 1.75) && close(s.median, 2.5) && close(s.q3, 3.25));
        assert_eq!((s.min, s.max), (1.0, 4.0));
        let one = stats(&[7.0]).unwrap();
        assert_eq!((one.std, one.q1, one.q3), (0.0, 7.0, 7.0));
        assert!(stats(&[f64::INFINITY]).is_none() && stats(&[]).is_none());
    }
}
