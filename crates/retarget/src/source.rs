//! The per-frame source mapping (Bouaziz and Pauly, Eq. 12–17, with Eq. 12's first factor
//! read as $P(x^*\mid z^*, X, Z)$, as Eq. 15 defines it): for an observation $\tilde x$
//! (some dimensions possibly missing) and the previous frame's $x_{k-1}$, minimise over
//! $(x, z)$
//! $$E = \sum_{d\ \text{seen}} \frac{(\tilde x_d - x_d)^2}{2\sigma_c^2} +
//! \frac{\lVert x_{k-1} - x\rVert^2}{2\sigma_t^2} +
//! \frac{\lVert x - \mu(z)\rVert^2}{2\sigma_p^2(z)} + \frac D2\log\sigma_p^2(z) +
//! \tfrac12\lVert z\rVert^2,$$
//!
//! with the source GP's mean $\mu(z) = k(z)^\top K^{-1}X$ and variance
//! $\sigma_p^2(z) = \sigma_f^2 + \sigma_w^2 - k(z)^\top K^{-1} k(z)$ (Eq. 16–17). A missing
//! dimension has $\sigma_c = \infty$: only the prior and the temporal term hold it.

use faer::linalg::solvers::Llt;
use faer::prelude::Solve;
use faer::{Mat, Side};
use reprise_numerics::gplvm::kernel::rbf_vector;
use reprise_numerics::gplvm::{GplvmError, Hyper, MeanPredictor};
use reprise_numerics::lbfgs::{lbfgs, LbfgsOptions};

use crate::shared::{kernel_matrix, owned_latents, predictor, Space};

/// The source space's GP: its mean and the inverse kernel for its variance.
pub struct SourceGp {
    mean: MeanPredictor,
    llt: Llt<f64>,
    z: Vec<f64>,
    q: usize,
    hyper: Hyper,
}

/// The noise levels of the solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// $\sigma_c$: the capture's noise (observation units).
    pub capture: f64,
    /// $\sigma_t$: how far a frame may move from the previous one.
    pub temporal: f64,
}

/// One frame's solve.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The most likely source observation $x^*$ (missing dimensions filled in).
    pub x: Vec<f64>,
    /// Its latent $z^*$.
    pub z: Vec<f64>,
    /// $\sigma_p^2(z^*)$: the source GP's predictive variance there.
    pub variance: f64,
    /// The objective at the optimum.
    pub objective: f64,
}

impl SourceGp {
    /// The source GP of `space` at the fitted latents `z` (`n × q`) and `hyper`.
    ///
    /// # Errors
    /// A kernel that will not factor.
    pub fn new(space: &Space<'_>, z: &[f64], q: usize, hyper: Hyper) -> Result<Self, GplvmError> {
        let mean = predictor(space, z, q, hyper)?;
        let zs = owned_latents(space, z, q);
        let k = kernel_matrix(&zs, q, &hyper);
        let llt =
            k.llt(Side::Lower).map_err(|_| GplvmError::Shape("the kernel matrix is not positive definite".into()))?;
        Ok(Self { mean, llt, z: zs, q, hyper })
    }

    /// $\sigma_p^2(z)$ and its gradient.
    pub fn variance(&self, z: &[f64]) -> (f64, Vec<f64>) {
        let q = self.q;
        let m = self.z.len() / q;
        let mut k = vec![0.0; m];
        rbf_vector(z, &self.z, &self.hyper, &mut k);
        // K⁻¹k by the Cholesky factor (better conditioned than an explicit inverse).
        let mut a = Mat::from_fn(m, 1, |i, _| k[i]);
        self.llt.solve_in_place(a.as_mut());
        let kk: Vec<f64> = (0..m).map(|i| a[(i, 0)]).collect();
        let var =
            self.hyper.rbf_variance + self.hyper.white_variance - k.iter().zip(&kk).map(|(a, b)| a * b).sum::<f64>();
        // ∂k_i/∂z = −k_i (z − z_i)/ℓ²; ∂σ²/∂z = −2 Σ_i (K⁻¹k)_i ∂k_i/∂z.
        let ell2 = self.hyper.lengthscale * self.hyper.lengthscale;
        let mut g = vec![0.0; q];
        for i in 0..m {
            for (a, gj) in g.iter_mut().enumerate() {
                *gj += 2.0 * kk[i] * k[i] * (z[a] - self.z[i * q + a]) / ell2;
            }
        }
        (var, g)
    }

    /// $E$ at $(x, z)$ = `p` (`D + q` values) and its gradient; `seen[d]` false for a missing
    /// dimension.
    pub fn objective(
        &self,
        p: &[f64],
        observed: &[f64],
        seen: &[bool],
        previous: Option<&[f64]>,
        noise: Noise,
    ) -> (f64, Vec<f64>) {
        let (dim, q) = (self.mean.d(), self.q);
        let (x, z) = p.split_at(dim);
        let mut grad = vec![0.0; dim + q];
        let mut e = 0.0;
        let c2 = noise.capture * noise.capture;
        for d in (0..dim).filter(|&d| seen[d]) {
            let r = x[d] - observed[d];
            e += r * r / (2.0 * c2);
            grad[d] += r / c2;
        }
        if let Some(prev) = previous {
            let t2 = noise.temporal * noise.temporal;
            for d in 0..dim {
                let r = x[d] - prev[d];
                e += r * r / (2.0 * t2);
                grad[d] += r / t2;
            }
        }
        let mut mu = vec![0.0; dim];
        let mut jac = vec![0.0; dim * q];
        self.mean.mean_jacobian(z, &mut mu, &mut jac);
        let (var, dvar) = self.variance(z);
        let var = var.max(1e-12);
        let mut sq = 0.0;
        for d in 0..dim {
            let r = x[d] - mu[d];
            sq += r * r;
            grad[d] += r / var;
            for a in 0..q {
                grad[dim + a] -= r / var * jac[d * q + a];
            }
        }
        e += sq / (2.0 * var) + 0.5 * dim as f64 * var.ln();
        for a in 0..q {
            grad[dim + a] += (-sq / (2.0 * var * var) + 0.5 * dim as f64 / var) * dvar[a] + z[a];
            e += 0.5 * z[a] * z[a];
        }
        (e, grad)
    }

    /// The frame's solve from `start` $(x, z)$ (the paper starts $x$ at the observation and
    /// $z$ at the latent of the nearest training observation).
    pub fn solve(
        &self,
        start: &[f64],
        observed: &[f64],
        seen: &[bool],
        previous: Option<&[f64]>,
        noise: Noise,
    ) -> Frame {
        let opts = LbfgsOptions { max_iters: 200, ..LbfgsOptions::default() };
        let r = lbfgs(
            |p, g| {
                let (e, grad) = self.objective(p, observed, seen, previous, noise);
                g.copy_from_slice(&grad);
                e
            },
            start,
            &opts,
        );
        let dim = self.mean.d();
        let (objective, _) = self.objective(&r.x, observed, seen, previous, noise);
        let variance = self.variance(&r.x[dim..]).0;
        Frame { x: r.x[..dim].to_vec(), z: r.x[dim..].to_vec(), variance, objective }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1-D curve in 3-D observed at 12 latents (the latents are the truth).
    fn gp() -> (SourceGp, Vec<f64>) {
        let t: Vec<f64> = (0..12).map(|i| -1.5 + 3.0 * f64::from(i) / 11.0).collect();
        let x: Vec<f64> = t.iter().flat_map(|&s| [s.sin(), s.cos(), 0.5 * s]).collect();
        let space = Space { data: &x, dim: 3, rows: (0..12).collect() };
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.8, white_variance: 1e-3 };
        (SourceGp::new(&space, &t, 1, hyper).unwrap(), t)
    }

    #[test]
    fn the_gradient_matches_central_differences() {
        let (g, _) = gp();
        let observed = [0.3, 0.9, 0.2];
        let previous = [0.25, 0.95, 0.15];
        let noise = Noise { capture: 0.05, temporal: 0.2 };
        let p = [0.28, 0.93, 0.21, 0.37];
        for seen in [[true, true, true], [true, false, true]] {
            let (_, grad) = g.objective(&p, &observed, &seen, Some(&previous), noise);
            // σ_p² is a difference of nearly equal numbers near the manifold: smaller steps
            // lose to rounding.
            let h = 1e-5;
            for i in 0..p.len() {
                let (mut a, mut b) = (p, p);
                a[i] += h;
                b[i] -= h;
                let fd = (g.objective(&a, &observed, &seen, Some(&previous), noise).0
                    - g.objective(&b, &observed, &seen, Some(&previous), noise).0)
                    / (2.0 * h);
                assert!((fd - grad[i]).abs() < 1e-5 * (1.0 + grad[i].abs()), "∂E/∂p[{i}]: {fd} vs {}", grad[i]);
            }
        }
    }

    #[test]
    fn a_missing_marker_is_filled_in_from_the_manifold() {
        let (g, _) = gp();
        let s = 0.4f64;
        let truth = [s.sin(), s.cos(), 0.5 * s];
        // The second coordinate is missing (observed as garbage); the first and third are
        // seen with a little noise.
        let observed = [truth[0] + 0.01, 99.0, truth[2] - 0.01];
        let seen = [true, false, true];
        let noise = Noise { capture: 0.02, temporal: 1.0 };
        let f = g.solve(&[observed[0], 0.0, observed[2], 0.0], &observed, &seen, None, noise);
        assert!((f.x[1] - truth[1]).abs() < 0.05, "filled {} vs {}", f.x[1], truth[1]);
        assert!((f.z[0] - s).abs() < 0.1, "latent {} vs {s}", f.z[0]);
        assert!(f.variance < 3e-3, "on the manifold the variance is near σ_w² = 1e-3: {}", f.variance);
    }
}
