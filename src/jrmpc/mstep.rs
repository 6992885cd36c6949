//! M-step: transforms, then means, then variances, then priors, each with the values just
//! updated (TPAMI 2018, Sec. 4; the order the reference implementations use).

use nalgebra::{Matrix3, Vector3};

use super::model::{Mixture, ViewStats};

/// Below this many expected points a view or component carries no information.
const MIN_SUPPORT: f64 = 1e-6;

/// Weighted Procrustes between a view's weighted point means `S1_jk / lambda_jk` and the
/// component means, weights `lambda_jk Q_k` (eq. 13-15). Returns `None` when the view has no
/// support; keeps `previous` rotation when the data do not determine one (rank < 2, e.g. all
/// points identical), so a degenerate view never produces an arbitrary rotation.
pub fn view_transform(
    stats: &ViewStats,
    mixture: &Mixture,
    previous: &Matrix3<f64>,
) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let mut s = 0.0;
    let mut c_w = Vector3::zeros();
    let mut c_x = Vector3::zeros();
    let mut p = Matrix3::zeros();
    for (k, x) in mixture.means.iter().enumerate() {
        let q = 1.0 / mixture.variances[k];
        let w = stats.lambda[k] * q;
        s += w;
        c_w += q * stats.s1[k];
        c_x += w * x;
        p += q * x * stats.s1[k].transpose();
    }
    if stats.support() < MIN_SUPPORT || !(s.is_finite() && s > 0.0) {
        return None;
    }
    p -= c_x * c_w.transpose() / s;
    let svd = p.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let sv = svd.singular_values;
    let rank_ok = sv.max() > 0.0 && sv.iter().filter(|&&x| x > 1e-9 * sv.max()).count() >= 2;
    let rotation = if rank_ok {
        let d = (u * v_t).determinant().signum();
        u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t
    } else {
        *previous
    };
    let translation = (c_x - rotation * c_w) / s;
    let finite = rotation.iter().chain(translation.iter()).all(|x| x.is_finite());
    finite.then_some((rotation, translation))
}

/// Means, variances (eq. 16-17, plus `floor`) and, if `update_priors`, priors (eq. 18; the sum
/// over all components, not the paper-era normalisation by the first). A component that no
/// point supports any more keeps its mean and variance and gets prior 0, so it drops out of the
/// E-step instead of turning into NaN.
pub fn update_mixture(
    mixture: &mut Mixture,
    stats: &[ViewStats],
    transforms: &[(Matrix3<f64>, Vector3<f64>)],
    gamma: f64,
    floor: f64,
    update_priors: bool,
) {
    let lambda: Vec<f64> =
        (0..mixture.len()).map(|k| stats.iter().map(|st| st.lambda[k]).sum()).collect();
    for (k, &support) in lambda.iter().enumerate() {
        if support < MIN_SUPPORT {
            continue;
        }
        let sum: Vector3<f64> =
            stats.iter().zip(transforms).map(|(st, (r, t))| r * st.s1[k] + st.lambda[k] * t).sum();
        let mean = sum / support;
        let spread: f64 = stats
            .iter()
            .zip(transforms)
            .map(|(st, (r, t))| {
                let d = t - mean;
                st.s2[k] + st.lambda[k] * d.norm_squared() + 2.0 * (r * st.s1[k]).dot(&d)
            })
            .sum();
        mixture.means[k] = mean;
        // Rounding can leave a tiny negative spread for a component holding one point.
        mixture.variances[k] = (spread / (3.0 * support)).max(0.0) + floor;
    }
    if update_priors {
        let total: f64 = lambda.iter().filter(|&&l| l >= MIN_SUPPORT).sum();
        for (prior, &l) in mixture.priors.iter_mut().zip(&lambda) {
            *prior =
                if l >= MIN_SUPPORT && total > 0.0 { l / ((1.0 + gamma) * total) } else { 0.0 };
        }
    } else {
        for (prior, &l) in mixture.priors.iter_mut().zip(&lambda) {
            if l < MIN_SUPPORT {
                *prior = 0.0;
            }
        }
    }
}
