//! The floating Gaussian mixture and the per-view sufficient statistics that link it to the data.

use nalgebra::Vector3;

/// K isotropic Gaussians: means (m), variances (m^2) and priors (mixing weights, which sum to
/// `1 / (1 + gamma)`; the rest is the uniform outlier class).
#[derive(Clone, Debug, PartialEq)]
pub struct Mixture {
    pub means: Vec<Vector3<f64>>,
    pub variances: Vec<f64>,
    pub priors: Vec<f64>,
}

impl Mixture {
    pub fn len(&self) -> usize {
        self.means.len()
    }

    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// Per component, its peak density factor `prior * Q^1.5` (`Q = 1 / variance`): each term of
    /// the E-step is this times `exp(-Q d^2 / 2)` (the common `(2 pi)^-1.5` cancels).
    pub fn peak_scales(&self) -> Vec<f64> {
        self.variances
            .iter()
            .zip(&self.priors)
            .map(|(v, p)| {
                let q = 1.0 / v;
                p * q * q.sqrt()
            })
            .collect()
    }

    /// Mean of the standard deviations (m) of the components that still hold data (prior > 0).
    pub fn mean_sigma(&self) -> f64 {
        let (sum, n) = self
            .variances
            .iter()
            .zip(&self.priors)
            .filter(|(_, p)| **p > 0.0)
            .fold((0.0, 0usize), |(s, n), (v, _)| (s + v.sqrt(), n + 1));
        if n == 0 { 0.0 } else { sum / n as f64 }
    }
}

/// Per-view, per-component sums over the view's points of the posteriors `alpha` (TPAMI 2018,
/// eq. 12-18 use only these): `lambda = sum alpha`, `s1 = sum alpha v`, `s2 = sum alpha |v|^2`,
/// where `v` is the untransformed (pre-aligned, centred) point. O(K) memory per view.
#[derive(Clone, Debug)]
pub struct ViewStats {
    pub lambda: Vec<f64>,
    pub s1: Vec<Vector3<f64>>,
    pub s2: Vec<f64>,
}

impl ViewStats {
    pub fn zeros(k: usize) -> Self {
        Self { lambda: vec![0.0; k], s1: vec![Vector3::zeros(); k], s2: vec![0.0; k] }
    }

    pub fn clear(&mut self) {
        self.lambda.fill(0.0);
        self.s1.fill(Vector3::zeros());
        self.s2.fill(0.0);
    }

    /// Expected number of this view's points explained by the mixture.
    pub fn support(&self) -> f64 {
        self.lambda.iter().sum()
    }
}
