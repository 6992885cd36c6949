//! The flat formats EM's state and statistics cross between workers in (the page's pool:
//! `Float64Array`s, which transfer without copies). Native code, tested natively; the wasm
//! layer only converts typed arrays.
//!
//! - E-step input: `[beta, K, cell, exact (0 or 1), means (3K), variances (K), priors (K), then
//!   per view its rotation (9, row-major) and translation (3)]`;
//! - E-step output: `[terms, then per view lambda (K), s1 (3K), s2 (K)]`;
//! - a shard's points: `x, y, z` of each view's centred points, one view after another, with
//!   the views' sizes beside them.

use std::fmt;

use nalgebra::{Matrix3, Vector3};

use super::model::{Mixture, ViewStats};
use super::{CentredViews, Em, Step};

/// Numbers per view in the E-step input: a rotation and a translation.
const TRANSFORM: usize = 12;
/// Numbers per component in a view's statistics: lambda, s1 (3), s2.
const STATS: usize = 5;

/// What is wrong with flat numbers that should hold EM's state or statistics.
#[derive(Clone, Debug, PartialEq)]
pub enum WireError {
    /// The E-step input is too short, or its beta or K is not plausible.
    MalformedInput,
    /// The mixture holds a non-finite mean, a non-positive variance or a negative prior.
    NonFiniteMixture,
    /// A view's rotation or translation holds a number that is not finite.
    NonFiniteTransform,
    /// The input has no transforms for the shard's views.
    MissingTransforms { first: usize },
    /// An output's length is not a whole number of views of K components.
    MalformedOutput { numbers: usize, components: usize },
    /// Statistics for this many views came back, where EM has `expected`.
    ViewCount { got: usize, expected: usize },
    /// The points are not the views' sizes times three.
    PointCount { numbers: usize, points: u64 },
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::MalformedInput => f.write_str("shard: malformed E-step input"),
            Self::NonFiniteMixture => f.write_str("shard: the mixture is not finite"),
            Self::NonFiniteTransform => f.write_str("shard: a view's transform is not finite"),
            Self::MissingTransforms { first } => {
                write!(f, "shard: no transforms for views {first}..")
            }
            Self::MalformedOutput { numbers, components } => write!(
                f,
                "mStep: {numbers} numbers is not a whole number of views of {components} components"
            ),
            Self::ViewCount { got, expected } => {
                write!(f, "mStep got statistics for {got} views, expected {expected}")
            }
            Self::PointCount { numbers, points } => {
                write!(f, "shard: {numbers} coordinates for {points} points")
            }
        }
    }
}

impl std::error::Error for WireError {}

/// A view's transform in the centred frame: rotation and translation.
pub type Transform = (Matrix3<f64>, Vector3<f64>);

/// `em`'s next E-step input.
pub fn e_step_input(em: &Em) -> Vec<f64> {
    let mixture = em.mixture();
    let k = mixture.len();
    let step = em.step();
    let mut flat = Vec::with_capacity(4 + 5 * k + TRANSFORM * em.transforms().len());
    flat.extend([step.beta, k as f64, step.cell, f64::from(u8::from(step.exact))]);
    flat.extend(mixture.means.iter().flat_map(|m| [m.x, m.y, m.z]));
    flat.extend(&mixture.variances);
    flat.extend(&mixture.priors);
    for (r, t) in em.transforms() {
        flat.extend(r.transpose().iter()); // column-major storage: row-major out
        flat.extend(t.iter());
    }
    flat
}

/// What a shard's E-step takes: [`Em::step`] and its views' transforms.
#[derive(Clone, Debug, PartialEq)]
pub struct EStepInput {
    pub mixture: Mixture,
    pub beta: f64,
    pub cell: f64,
    pub exact: bool,
    pub transforms: Vec<Transform>,
}

impl EStepInput {
    pub fn step(&self) -> Step<'_> {
        Step { mixture: &self.mixture, beta: self.beta, cell: self.cell, exact: self.exact }
    }
}

/// An E-step input for views `first..first + views`.
pub fn read_e_step_input(
    flat: &[f64],
    first: usize,
    views: usize,
) -> Result<EStepInput, WireError> {
    let (&beta, rest) = flat.split_first().ok_or(WireError::MalformedInput)?;
    let (&k, rest) = rest.split_first().ok_or(WireError::MalformedInput)?;
    let (&cell, rest) = rest.split_first().ok_or(WireError::MalformedInput)?;
    let (&exact, rest) = rest.split_first().ok_or(WireError::MalformedInput)?;
    let k = k as usize; // saturating; NaN -> 0
    let plausible = beta.is_finite()
        && beta > 0.0
        && cell.is_finite()
        && cell >= 0.0
        && (exact == 0.0 || exact == 1.0);
    if k == 0 || k > rest.len() / 5 || !plausible {
        return Err(WireError::MalformedInput);
    }
    let (mixture, transforms) = rest.split_at(5 * k);
    let mixture = Mixture {
        means: mixture[..3 * k].chunks_exact(3).map(|m| Vector3::new(m[0], m[1], m[2])).collect(),
        variances: mixture[3 * k..4 * k].to_vec(),
        priors: mixture[4 * k..].to_vec(),
    };
    let plausible = mixture.means.iter().all(|m| m.iter().all(|x| x.is_finite()))
        && mixture.variances.iter().all(|v| v.is_finite() && *v > 0.0)
        && mixture.priors.iter().all(|p| p.is_finite() && *p >= 0.0);
    if !plausible {
        return Err(WireError::NonFiniteMixture);
    }
    let transforms: Vec<Transform> = transforms
        .chunks_exact(TRANSFORM)
        .skip(first)
        .take(views)
        .map(|rt| (Matrix3::from_row_slice(&rt[..9]), Vector3::new(rt[9], rt[10], rt[11])))
        .collect();
    if transforms.len() != views {
        return Err(WireError::MissingTransforms { first });
    }
    if transforms.iter().any(|(r, t)| r.iter().chain(t.iter()).any(|x| !x.is_finite())) {
        return Err(WireError::NonFiniteTransform);
    }
    Ok(EStepInput { mixture, beta, cell, exact: exact == 1.0, transforms })
}

/// A shard's E-step output: the terms it evaluated, then its views' statistics.
pub fn e_step_output(terms: u64, stats: &[ViewStats]) -> Vec<f64> {
    let k = stats.first().map_or(0, |s| s.lambda.len());
    let mut flat = Vec::with_capacity(1 + STATS * k * stats.len());
    flat.push(terms as f64);
    for st in stats {
        flat.extend(&st.lambda);
        flat.extend(st.s1.iter().flat_map(|s| [s.x, s.y, s.z]));
        flat.extend(&st.s2);
    }
    flat
}

/// Every shard's output, in view order, as the terms evaluated and all views' statistics for
/// [`Em::m_step`] (K components, `views` views expected).
pub fn read_e_step_outputs<'a>(
    outputs: impl IntoIterator<Item = &'a [f64]>,
    k: usize,
    views: usize,
) -> Result<(u64, Vec<ViewStats>), WireError> {
    let mut stats = Vec::with_capacity(views);
    let mut terms = 0.0;
    for flat in outputs {
        let malformed = |numbers| WireError::MalformedOutput { numbers, components: k };
        let (head, rest) = flat.split_first().ok_or(malformed(0))?;
        if k == 0 || rest.len() % (STATS * k) != 0 {
            return Err(malformed(rest.len()));
        }
        terms += head;
        stats.extend(rest.chunks_exact(STATS * k).map(|view| read_stats(view, k)));
    }
    if stats.len() != views {
        return Err(WireError::ViewCount { got: stats.len(), expected: views });
    }
    Ok((terms as u64, stats))
}

fn read_stats(flat: &[f64], k: usize) -> ViewStats {
    ViewStats {
        lambda: flat[..k].to_vec(),
        s1: flat[k..4 * k].chunks_exact(3).map(|s| Vector3::new(s[0], s[1], s[2])).collect(),
        s2: flat[4 * k..5 * k].to_vec(),
    }
}

/// Views `first..first + count` of `points`, flat, with their sizes; `None` out of range.
pub fn shard_points(
    points: &CentredViews,
    first: usize,
    count: usize,
) -> Option<(Vec<f64>, Vec<u32>)> {
    let views = points.get(first..first.checked_add(count)?)?;
    let flat = views.iter().flatten().flat_map(|p| [p.x, p.y, p.z]).collect();
    Some((flat, views.iter().map(|v| v.len() as u32).collect()))
}

/// The views `shard_points` flattened, back.
pub fn read_shard_points(flat: &[f64], sizes: &[u32]) -> Result<CentredViews, WireError> {
    // u64: a sum of u32 sizes may not fit wasm32's usize.
    let points: u64 = sizes.iter().map(|&n| u64::from(n)).sum();
    if points * 3 != flat.len() as u64 {
        return Err(WireError::PointCount { numbers: flat.len(), points });
    }
    let mut rest = flat;
    Ok(sizes
        .iter()
        .map(|&n| {
            let (view, tail) = rest.split_at(3 * n as usize);
            rest = tail;
            view.chunks_exact(3).map(|p| Vector3::new(p[0], p[1], p[2])).collect()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jrmpc::{EmSettings, Shard};

    /// A shard fed through the flat formats computes exactly what it computes directly, and
    /// the M-step takes the round-tripped statistics unchanged.
    /// Three small views of `n` points each, and `k` means along them.
    fn small_rig(n: usize, k: usize) -> (Vec<Vec<[f32; 3]>>, Vec<[f64; 3]>) {
        let views = (0..3)
            .map(|v| {
                (0..n).map(|i| [i as f32 * 0.01, (i % 7) as f32 * 0.02, v as f32 * 0.1]).collect()
            })
            .collect();
        (views, (0..k).map(|i| [i as f64 * 0.02, 0.05, 0.1]).collect())
    }

    #[test]
    fn an_iteration_through_the_wire_is_the_iteration() {
        let (views, means) = small_rig(50, 20);
        let refs: Vec<&[[f32; 3]]> = views.iter().map(Vec::as_slice).collect();
        let (mut em, points) = Em::start(&refs, &means, &EmSettings::default()).unwrap();
        let (flat, sizes) = shard_points(&points, 1, 2).unwrap();
        assert_eq!(read_shard_points(&flat, &sizes).unwrap(), points[1..].to_vec());
        assert!(shard_points(&points, 2, 5).is_none());

        let input = e_step_input(&em);
        let read = read_e_step_input(&input, 0, 3).unwrap();
        assert_eq!((&read.mixture, read.beta, read.cell), (em.mixture(), em.beta(), 0.0));
        assert!(!read.exact);
        assert_eq!(read.transforms, em.transforms().to_vec());
        let mut shard = Shard::new(points.clone());
        let mut stats = em.empty_stats();
        let terms = shard.e_step(&read.step(), &read.transforms, &mut stats);
        let output = e_step_output(terms, &stats);
        let (back_terms, back) = read_e_step_outputs([output.as_slice()], 20, 3).unwrap();
        assert_eq!(back_terms, terms);
        for (a, b) in back.iter().zip(&stats) {
            assert_eq!((&a.lambda, &a.s1, &a.s2), (&b.lambda, &b.s1, &b.s2));
        }
        em.m_step(&back, back_terms);
        assert_eq!(em.iteration(), 1);

        assert_eq!(read_e_step_input(&input[..5], 0, 3), Err(WireError::MalformedInput));
        let mut half_exact = input.clone();
        half_exact[3] = 0.5;
        assert_eq!(read_e_step_input(&half_exact, 0, 3), Err(WireError::MalformedInput));
        let mut wild = input.clone();
        *wild.last_mut().unwrap() = f64::INFINITY; // the last view's translation
        assert_eq!(read_e_step_input(&wild, 0, 3), Err(WireError::NonFiniteTransform));
        // The exact E-step crosses too: the shard evaluates every term.
        let exact = EmSettings { exact: true, ..EmSettings::default() };
        let (exact_em, _) = Em::start(&refs, &means, &exact).unwrap();
        let read = read_e_step_input(&e_step_input(&exact_em), 0, 3).unwrap();
        assert!(read.exact);
        let dense = shard.e_step(&read.step(), &read.transforms, &mut stats);
        assert_eq!(dense, 150 * 20, "every point against every component");
        assert_eq!(
            read_e_step_input(&input, 2, 3).unwrap_err(),
            WireError::MissingTransforms { first: 2 }
        );
        assert!(matches!(
            read_e_step_outputs([&output[..7]], 20, 3),
            Err(WireError::MalformedOutput { .. })
        ));
        assert_eq!(
            read_e_step_outputs([output.as_slice(), output.as_slice()], 20, 3).unwrap_err(),
            WireError::ViewCount { got: 6, expected: 3 }
        );
        assert!(matches!(read_shard_points(&flat[1..], &sizes), Err(WireError::PointCount { .. })));
    }

    /// Decoders of what crosses between workers, fed thousands of mutated inputs and shard
    /// points (seeded): an input either reads as an error or runs through a shard's E-step and
    /// the M-step without a panic (in wasm a panic kills the worker).
    #[test]
    fn mutated_e_step_inputs_are_errors_or_run() {
        use rand::{RngExt, SeedableRng};
        let (views, means) = small_rig(40, 10);
        let refs: Vec<&[[f32; 3]]> = views.iter().map(Vec::as_slice).collect();
        let (em, points) = Em::start(&refs, &means, &EmSettings::default()).unwrap();
        let input = e_step_input(&em);
        let specials = [f64::NAN, f64::INFINITY, -f64::INFINITY, 1e300, -1e300, 0.0, -1.0, 1e-300];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut ran = 0;
        for trial in 0..3000 {
            let mut flat = input.clone();
            for _ in 0..rng.random_range(1..4) {
                let at = rng.random_range(0..flat.len());
                flat[at] = match rng.random_range(0..3) {
                    0 => specials[rng.random_range(0..specials.len())],
                    1 => flat[at] * rng.random_range(-1e6..1e6),
                    _ => rng.random_range(-1e3..1e3),
                };
            }
            if trial % 10 == 0 {
                flat.truncate(rng.random_range(0..flat.len()));
            }
            // A shard's points come from JS too (`JrmpcShard`'s constructor).
            let mut held = points.clone();
            if trial % 3 == 0 {
                let (v, i) = (rng.random_range(0..3), rng.random_range(0..40));
                let axis = rng.random_range(0..3);
                held[v][i][axis] = specials[rng.random_range(0..specials.len())];
            }
            let outcome = std::panic::catch_unwind(|| {
                let Ok(read) = read_e_step_input(&flat, 0, 3) else { return false };
                let mut shard = Shard::new(held);
                let mut stats = em.empty_stats();
                let terms = shard.e_step(&read.step(), &read.transforms, &mut stats);
                let output = e_step_output(terms, &stats);
                read_e_step_outputs([output.as_slice()], read.mixture.len(), 3).is_ok()
            });
            ran += usize::from(outcome.unwrap_or_else(|_| panic!("trial {trial} panicked")));
        }
        assert!(ran > 100, "only {ran} inputs ran");

        // Mutated E-step outputs into the M-step: an error, or an iteration, never a panic.
        let mut shard = Shard::new(points.clone());
        let mut stats = em.empty_stats();
        let terms = shard.e_step(&em.step(), em.transforms(), &mut stats);
        let output = e_step_output(terms, &stats);
        let mut stepped = 0;
        for trial in 0..1000 {
            let mut flat = output.clone();
            for _ in 0..rng.random_range(1..4) {
                let at = rng.random_range(0..flat.len());
                flat[at] = specials[rng.random_range(0..specials.len())];
            }
            let outcome = std::panic::catch_unwind(|| {
                let Ok((terms, back)) = read_e_step_outputs([flat.as_slice()], 10, 3) else {
                    return false;
                };
                let (mut em, _) = Em::start(&refs, &means, &EmSettings::default()).unwrap();
                em.m_step(&back, terms);
                true
            });
            stepped += usize::from(outcome.unwrap_or_else(|_| panic!("output {trial} panicked")));
        }
        assert!(stepped > 100, "only {stepped} outputs stepped");
    }
}
