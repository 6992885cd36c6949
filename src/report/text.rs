//! Results for people: the CLI's text, angles in deg. Programs get [`super::Report`] as JSON.

use std::fmt::Write;

use crate::calib::region::RoiSource;
use crate::calib::{Calibration, Level, Note, Reason, Verdict};
use crate::se3::xyz_rpy;

/// The verdict, first: the level, then per sensor its level and the reasons that set it
/// (`good` reasons only where nothing else is said).
pub fn verdict(v: &Verdict) -> String {
    let mut out = format!("verdict: {}\n", v.level.name().to_uppercase());
    let weighty = |r: &&Reason| r.level > Level::Good;
    for s in &v.sensors {
        let _ = writeln!(out, "  {}: {}", s.sensor, s.level.name());
        let shown: Vec<&Reason> = s.reasons.iter().filter(weighty).collect();
        let shown = if shown.is_empty() { s.reasons.iter().take(2).collect() } else { shown };
        for r in shown {
            let _ = writeln!(out, "    - {}", r.kind);
        }
    }
    for r in &v.reasons {
        let _ = writeln!(out, "  - {}", r.kind);
    }
    out
}

/// The human summary of one calibration, its verdict first.
pub fn summary(c: &Calibration) -> String {
    let mut out = verdict(&c.verdict);
    out.push('\n');
    let state = if c.converged { "converged" } else { "not converged" };
    let _ = writeln!(
        out,
        "method {}, reference {}, {} iterations, {state}",
        c.method.name(),
        c.reference,
        c.iterations
    );
    let (lo, hi) = (c.roi.min, c.roi.max);
    let _ = writeln!(
        out,
        "region x {:.1}..{:.1}, y {:.1}..{:.1}, z {:.1}..{:.1} m: {}",
        lo[0],
        hi[0],
        lo[1],
        hi[1],
        lo[2],
        hi[2],
        match c.roi_source {
            RoiSource::Given => "as given".to_string(),
            RoiSource::Targets { found } => format!(
                "around {found} object{} of the target's shape found standing in the reference's scans",
                if found == 1 { "" } else { "s" }
            ),
            RoiSource::Overlap => {
                "where the clouds overlap (no ROI given, no target found)".to_string()
            }
        }
    );
    for s in &c.sensors {
        let (cx, cr) = xyz_rpy(&s.correction);
        let (ex, er) = xyz_rpy(&s.extrinsic);
        let _ = writeln!(out, "\n{}", s.name);
        let _ = writeln!(out, "  correction  xyz {} m   rpy {} deg", m3(cx), deg3(cr));
        let _ = writeln!(out, "  extrinsic   xyz {} m   rpy {} deg", m3(ex), deg3(er));
        // One frame has no spread to show.
        if s.spread.frames > 1 {
            let _ = writeln!(
                out,
                "  spread      xyz {} m   rpy {} deg   ({} frames)",
                m3(s.spread.xyz),
                deg3(s.spread.rpy),
                s.spread.frames
            );
        }
        if let Some(p) = &s.precision {
            let _ = writeln!(
                out,
                "  precision   xyz {} m   rot {} deg   (1 sigma: what the scans tell apart)",
                m3(p.position),
                deg3(p.rotation)
            );
        }
    }
    for fit in &c.reconstruction.fits {
        let [x, y, z] = fit.centre;
        let _ = writeln!(
            out,
            "\ntarget at {x:.3}, {y:.3}, {z:.3} m ({:.0} % of the weight): rms {:.4} m, {} {:.4} m",
            fit.weight * 100.0,
            fit.rms,
            match fit.shape {
                "sphere" => "diameter",
                "mesh" => "across",
                _ => "edge",
            },
            fit.size
        );
    }
    notes(&mut out, "skipped", &c.skipped);
    selection(&mut out, c);
    notes(&mut out, "plane adjustment", &c.plane_adjustment);
    warnings(&mut out, "", c);
    out
}

/// One table comparing several calibrations of the same frames, each method's verdict first.
pub fn comparison(results: &[&Calibration]) -> String {
    let mut out = String::new();
    for c in results {
        let _ = writeln!(out, "{}: verdict {}", c.method.name(), c.verdict.level.name());
        for s in &c.verdict.sensors {
            for r in s.reasons.iter().filter(|r| r.level > Level::Good) {
                let _ = writeln!(out, "  {}: {}", s.sensor, r.kind);
            }
        }
    }
    out.push('\n');
    let _ = writeln!(
        out,
        "{:<6} {:<10} {:>26} {:>26} {:>26} {:>26} {:>6}",
        "method",
        "sensor",
        "extrinsic xyz (m)",
        "extrinsic rpy (deg)",
        "spread xyz (m)",
        "spread rpy (deg)",
        "frames"
    );
    for c in results {
        for s in &c.sensors {
            let (xyz, rpy) = xyz_rpy(&s.extrinsic);
            let _ = writeln!(
                out,
                "{:<6} {:<10} {:>26} {:>26} {:>26} {:>26} {:>6}",
                c.method.name(),
                s.name,
                m3(xyz),
                deg3(rpy),
                m3(s.spread.xyz),
                deg3(s.spread.rpy),
                s.spread.frames
            );
        }
    }
    for c in results {
        let label = format!("{}: skipped", c.method.name());
        notes(&mut out, &label, &c.skipped);
        warnings(&mut out, &format!("{}: ", c.method.name()), c);
    }
    out
}

/// Each sensor's hypotheses: the stage, how much of the scans land, how far from the nominal,
/// the chosen marked.
fn selection(out: &mut String, c: &Calibration) {
    if c.selection.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\nselection (share of the points landing on the other sensors' surfaces, less {} times \
         the share standing where they saw through; how far its ground lies from theirs):",
        crate::calib::select::CONTRADICTION_WEIGHT
    );
    for s in &c.selection {
        let _ = writeln!(out, "  {}", s.sensor);
        for (i, h) in s.hypotheses.iter().enumerate() {
            let mark = if i == s.chosen { "*" } else { " " };
            let stage = stage_name(&s.hypotheses, i);
            let ground = h.ground.map_or(String::new(), |g| {
                format!("; grounds {:.1} mm / {:.3} deg apart", 1e3 * g.height, g.tilt.to_degrees())
            });
            let w = crate::calib::select::CONTRADICTION_WEIGHT;
            let _ = writeln!(
                out,
                "  {mark} {stage:<20} {:>5.1} % ({:>4.1} - {w} x {:>4.1})   {:>7.3} deg {:>7.3} m \
                 from the nominal{ground}",
                100.0 * h.score.value(),
                100.0 * h.score.landing(),
                100.0 * h.score.contradiction(),
                h.correction.rotation.angle().to_degrees(),
                h.correction.translation.vector.norm()
            );
        }
    }
}

/// Hypothesis `i`'s stage as the table names it; a levelling with the root it levelled, since
/// every root is levelled.
fn stage_name(hypotheses: &[crate::calib::Hypothesis], i: usize) -> String {
    use crate::calib::Source;
    let h = &hypotheses[i];
    match (h.source, h.parent) {
        (Source::Global { rank }, _) => format!("global #{}", rank + 1),
        (Source::Levelled, Some(p)) => format!("levelled {}", stage_name(hypotheses, p)),
        (other, _) => other.name().to_string(),
    }
}

/// The levelling's warnings (a nominal further off than the bird's-eye search reaches).
fn warnings(out: &mut String, prefix: &str, c: &Calibration) {
    for l in &c.levelling {
        if let Some(w) = &l.warning {
            let _ = writeln!(out, "\n{prefix}warning: {}: {w}", l.sensor);
        }
    }
}

fn notes(out: &mut String, title: &str, notes: &[Note]) {
    if notes.is_empty() {
        return;
    }
    let _ = writeln!(out, "\n{title}:");
    for n in notes {
        let frame = n.frame.as_deref().unwrap_or("all");
        let _ = writeln!(out, "  {}/{frame}: {}", n.sensor, n.kind);
    }
}

fn m3(v: [f64; 3]) -> String {
    format!("{:8.4} {:8.4} {:8.4}", v[0], v[1], v[2])
}

fn deg3(v: [f64; 3]) -> String {
    format!("{:8.3} {:8.3} {:8.3}", v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees())
}
