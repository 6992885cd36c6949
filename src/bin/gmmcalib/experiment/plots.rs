//! The experiment's figures, drawn with plotters' SVG backend: box plots of the per-axis
//! distance error over the validation cube (paper Fig. "mean position errors") and the global
//! error against range with fitted lines (paper Fig. "global"). Both on a log scale: the methods
//! differ by orders of magnitude.

use std::path::Path;

use gmmcalib::calib::Method;
use gmmcalib::eval;
use plotters::prelude::*;

use super::trials::{Trial, frame_values, global};

/// Smallest value shown on the log axes (m); zero errors are drawn here.
const FLOOR: f64 = 1e-5;
const SIZE: (u32, u32) = (1200, 480);

fn colour(i: usize) -> RGBColor {
    const PALETTE: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
    ];
    PALETTE[i % PALETTE.len()]
}

fn fail(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", path.display())
}

/// Log-axis range covering `values`, padded, at least one decade.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v.max(FLOOR)), hi.max(v)));
    if !lo.is_finite() {
        return FLOOR..1.0;
    }
    let hi = hi.max(lo * 10.0);
    lo / 2.0..hi * 2.0
}

/// One panel per axis (x, y, z), one box per method: quartiles, median, and Tukey whiskers
/// (the most extreme values within 1.5 IQR of the box).
pub fn distance_boxes(path: &Path, methods: &[Method], trials: &[Trial]) -> Result<(), String> {
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    let root = root
        .titled(
            "Distance error over the validation cube per axis (paper eq. 5)",
            ("sans-serif", 20),
        )
        .map_err(|e| fail(path, e))?;
    let values: Vec<[Vec<f64>; 3]> = (0..methods.len())
        .map(|m| std::array::from_fn(|axis| frame_values(trials, m, true, axis)))
        .collect();
    let range = log_range(values.iter().flatten().flatten().copied());
    let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
    for (axis, area) in root.split_evenly((1, 3)).iter().enumerate() {
        let mut chart = ChartBuilder::on(area)
            .caption(["x", "y", "z"][axis], ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..methods.len() as f64 - 0.5, range.clone().log_scale())
            .map_err(|e| fail(path, e))?;
        let label = |x: &f64| {
            let i = x.round();
            let name = names.get(i as usize).filter(|_| (x - i).abs() < 1e-6 && i >= 0.0);
            name.map_or_else(String::new, |n| n.to_string())
        };
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(methods.len() * 2 + 1)
            .x_label_formatter(&label)
            .y_desc("error (m)")
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(|e| fail(path, e))?;
        for (m, per_axis) in values.iter().enumerate() {
            let mut v: Vec<f64> = per_axis[axis].iter().map(|x| x.max(FLOOR)).collect();
            let Some(s) = eval::stats(&v) else { continue };
            v.sort_by(f64::total_cmp);
            let iqr = s.q3 - s.q1;
            let low = v.iter().copied().find(|x| *x >= s.q1 - 1.5 * iqr).unwrap_or(s.min);
            let high = v.iter().rev().copied().find(|x| *x <= s.q3 + 1.5 * iqr).unwrap_or(s.max);
            let (x, w, c) = (m as f64, 0.3, colour(m));
            let line =
                |a: (f64, f64), b: (f64, f64)| PathElement::new(vec![a, b], c.stroke_width(2));
            chart
                .draw_series([Rectangle::new([(x - w, s.q1), (x + w, s.q3)], c.mix(0.3).filled())])
                .map_err(|e| fail(path, e))?;
            chart
                .draw_series([
                    line((x - w, s.q1), (x + w, s.q1)),
                    line((x - w, s.q3), (x + w, s.q3)),
                    line((x - w, s.q1), (x - w, s.q3)),
                    line((x + w, s.q1), (x + w, s.q3)),
                    line((x - w, s.median), (x + w, s.median)),
                    line((x, s.q1), (x, low)),
                    line((x, s.q3), (x, high)),
                    line((x - w / 2.0, low), (x + w / 2.0, low)),
                    line((x - w / 2.0, high), (x + w / 2.0, high)),
                ])
                .map_err(|e| fail(path, e))?;
            let outliers = v.iter().filter(|y| **y < low || **y > high);
            chart
                .draw_series(outliers.map(|y| Circle::new((x, *y), 2, c.stroke_width(1))))
                .map_err(|e| fail(path, e))?;
        }
    }
    root.present().map_err(|e| fail(path, e))
}

/// Mean error per range bin (points and lines) and the least-squares line over all points
/// (dashed), per method.
pub fn global_error(path: &Path, methods: &[Method], trials: &[Trial]) -> Result<(), String> {
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(path, e))?;
    let globals: Vec<_> = (0..methods.len()).map(|m| global(trials, m)).collect();
    let profiles: Vec<Vec<(f64, f64)>> = globals.iter().map(|g| g.profile()).collect();
    let max_range = profiles.iter().flatten().map(|p| p.0).fold(1.0f64, f64::max) + 1.0;
    let range = log_range(profiles.iter().flatten().map(|p| p.1));
    let mut chart = ChartBuilder::on(&root)
        .caption("Global error of whole scans against range", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..max_range, range.clone().log_scale())
        .map_err(|e| fail(path, e))?;
    chart
        .configure_mesh()
        .x_desc("range from the sensor (m)")
        .y_desc("mean distance error (m)")
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()
        .map_err(|e| fail(path, e))?;
    for (m, (g, profile)) in globals.iter().zip(&profiles).enumerate() {
        let c = colour(m);
        let points: Vec<(f64, f64)> = profile.iter().map(|&(x, y)| (x, y.max(FLOOR))).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
            .map_err(|e| fail(path, e))?
            .label(methods[m].name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart
            .draw_series(points.iter().map(|p| Circle::new(*p, 3, c.filled())))
            .map_err(|e| fail(path, e))?;
        if let Some((slope, intercept)) = g.fit.line() {
            // The fitted line, where it is positive (a log axis cannot show the rest).
            let line: Vec<(f64, f64)> = (0..=100)
                .map(|i| max_range * i as f64 / 100.0)
                .map(|x| (x, slope * x + intercept))
                .filter(|(_, y)| *y >= range.start)
                .collect();
            chart
                .draw_series(DashedLineSeries::new(line, 6, 4, c.stroke_width(1)))
                .map_err(|e| fail(path, e))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| fail(path, e))?;
    root.present().map_err(|e| fail(path, e))
}
