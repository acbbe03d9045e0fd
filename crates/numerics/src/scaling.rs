//! Rig-control scaling (Bailey et al. 2016, §4.1, Eq. 3).
//!
//! Scaled controls are $z = W(p - \bar p) + \bar p$ with $W = \mathrm{diag}(w_i)$ chosen
//! so that a unit change of $z_i$ moves the mesh by about one length unit. With
//! $d_n = \lVert e(\bar p) - e(\bar p + n\sigma_i \mathbf{e}_i)\rVert$ the mesh
//! displacement for a step of $n$ standard deviations, Eq. 3 is the 1-D least squares
//! $$ w_i = \arg\min_w \sum_n \left(d_n - w\,|n|\,\sigma_i\right)^2
//!        = \frac{\sum_n d_n |n| \sigma_i}{\sum_n n^2 \sigma_i^2}. $$
//! Units: $w_i$ is mesh length per control unit (e.g. cm/deg).

/// The default steps `n`, in standard deviations (the paper's {−2, −1, 0, 1, 2}; `n = 0`
/// adds nothing to the fit and is left out).
pub const DEFAULT_STEPS: [f64; 4] = [-2.0, -1.0, 1.0, 2.0];

/// A fitted weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightFit {
    /// $w_i$.
    pub weight: f64,
    /// Root-mean-square residual of the fit, $\sqrt{\frac1{|n|}\sum_n (d_n - w|n|\sigma)^2}$,
    /// in mesh length units: how far the rig is from linear in this control.
    pub residual: f64,
}

/// Solves Eq. 3 for one control from its standard deviation `sigma > 0`, the steps `n`
/// and the mesh displacements `d_n` measured at those steps.
pub fn fit_weight(sigma: f64, steps: &[f64], displacements: &[f64]) -> WeightFit {
    debug_assert!(sigma > 0.0 && steps.len() == displacements.len());
    let num: f64 = steps.iter().zip(displacements).map(|(n, d)| d * n.abs() * sigma).sum();
    let den: f64 = steps.iter().map(|n| n * n * sigma * sigma).sum();
    let weight = num / den;
    let sq: f64 = steps.iter().zip(displacements).map(|(n, d)| (d - weight * n.abs() * sigma).powi(2)).sum();
    WeightFit { weight, residual: (sq / steps.len() as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// For a linear rig the displacement is exactly $|n|\sigma\lVert a\rVert$, so the weight
    /// is the column norm and the residual zero.
    #[test]
    fn linear_rig_gives_the_column_norm() {
        let (sigma, norm) = (0.7, 3.25);
        let d: Vec<f64> = DEFAULT_STEPS.iter().map(|n| n.abs() * sigma * norm).collect();
        let fit = fit_weight(sigma, &DEFAULT_STEPS, &d);
        assert!((fit.weight - norm).abs() < 1e-12);
        assert!(fit.residual < 1e-12);
    }

    /// A quadratic response $d = c (n\sigma)^2$: the least-squares slope through the
    /// origin is $c\sigma \sum|n|^3 / \sum n^2 = c\sigma \cdot 18/10$.
    #[test]
    fn nonlinear_response_has_known_slope_and_residual() {
        let (sigma, c) = (2.0, 0.5);
        let d: Vec<f64> = DEFAULT_STEPS.iter().map(|n| c * (n * sigma).powi(2)).collect();
        let fit = fit_weight(sigma, &DEFAULT_STEPS, &d);
        assert!((fit.weight - c * sigma * 1.8).abs() < 1e-12);
        assert!(fit.residual > 0.1);
    }
}
