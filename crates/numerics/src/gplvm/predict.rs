//! Prediction from a fitted GPLVM (method.md §1.3): with $A = K^{-1}Y$ precomputed,
//!
//! $$\mu(x_*) = A^\top k_*,\qquad
//! \frac{\partial\mu}{\partial x_*} = -\frac1{\ell^2}\sum_i A_{i,:}^\top k_i(x_*)(x_* - x_i)^\top,\qquad
//! v(x_*) = \sigma_f^2 [+\sigma_w^2] - k_*^\top K^{-1}k_*,$$
//!
//! with $k_i(x_*) = \sigma_f^2\exp(-\lVert x_*-x_i\rVert^2/(2\ell^2))$ (the white term does
//! not correlate distinct points). The mean and its Jacobian cost $O(N(q+D))$ and
//! $O(NDq)$ and allocate nothing — this is what makes reconstruction linear in $N$; the
//! variance costs one triangular solve, $O(N^2)$.

use std::ops::Deref;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::triangular_solve;
use faer::{Mat, Par};

use super::kernel::{columns, exp_nonpositive, rbf_lower, rbf_vector, sq_dist};
use super::params::{cholesky_with_jitter, JitterUsed};
use super::{GplvmError, Hyper, LikelihoodConfig};

/// The posterior mean map and its Jacobian; needs only the support points $X$ (the
/// training latents, or a sparse fit's inducing points), their weights $K^{-1}Y$ (or
/// $W$) and $\theta$.
#[derive(Debug, Clone, PartialEq)]
pub struct MeanPredictor {
    q: usize,
    d: usize,
    x: Vec<f64>,
    kinv_y: Vec<f64>,
    hyper: Hyper,
}

impl MeanPredictor {
    /// From the training latents `x` (row-major `N × q`), $K^{-1}Y$ (row-major `N × d`) and
    /// the hyperparameters, e.g. as stored by the GPLVM stage.
    pub fn from_parts(x: Vec<f64>, kinv_y: Vec<f64>, q: usize, d: usize, hyper: Hyper) -> Result<Self, GplvmError> {
        hyper.check()?;
        if q == 0 || d == 0 || x.is_empty() || !x.len().is_multiple_of(q) || kinv_y.len() != x.len() / q * d {
            return Err(GplvmError::Shape(format!(
                "x has {} values (q = {q}) and K⁻¹Y {} values (d = {d}): not N × q and N × d",
                x.len(),
                kinv_y.len()
            )));
        }
        Ok(Self { q, d, x, kinv_y, hyper })
    }

    /// Number of support points (training points $N$, or inducing points $M$).
    pub fn n(&self) -> usize {
        self.x.len() / self.q
    }

    /// Latent dimension $q$.
    pub fn q(&self) -> usize {
        self.q
    }

    /// Output dimension $D$.
    pub fn d(&self) -> usize {
        self.d
    }

    /// The hyperparameters.
    pub fn hyper(&self) -> &Hyper {
        &self.hyper
    }

    /// The support points (row-major `N × q`): the training latents, or the inducing points.
    pub fn x(&self) -> &[f64] {
        &self.x
    }

    /// $A = K^{-1}Y$ (row-major `N × D`).
    pub fn kinv_y(&self) -> &[f64] {
        &self.kinv_y
    }

    /// $\mu(x_*)$ into `out` (length $D$).
    pub fn mean(&self, x_star: &[f64], out: &mut [f64]) {
        assert_eq!(x_star.len(), self.q, "x* must have q values");
        assert_eq!(out.len(), self.d, "the mean has D values");
        out.fill(0.0);
        let c = -0.5 / (self.hyper.lengthscale * self.hyper.lengthscale);
        for (xi, ai) in self.x.chunks_exact(self.q).zip(self.kinv_y.chunks_exact(self.d)) {
            let k = self.hyper.rbf_variance * exp_nonpositive(c * sq_dist(x_star, xi));
            out.iter_mut().zip(ai).for_each(|(o, a)| *o += k * a);
        }
    }

    /// $\mu(x_*)$ into `mean` and $\partial\mu/\partial x_*$ into `jac` (row-major `D × q`).
    pub fn mean_jacobian(&self, x_star: &[f64], mean: &mut [f64], jac: &mut [f64]) {
        let (q, d) = (self.q, self.d);
        assert_eq!(x_star.len(), q, "x* must have q values");
        assert_eq!(mean.len(), d, "the mean has D values");
        assert_eq!(jac.len(), d * q, "the Jacobian has D × q values");
        mean.fill(0.0);
        jac.fill(0.0);
        let ell2 = self.hyper.lengthscale * self.hyper.lengthscale;
        let c = -0.5 / ell2;
        let mut diff = [0.0; 8];
        let mut diff_vec = Vec::new();
        let diff: &mut [f64] = if q <= 8 {
            &mut diff[..q]
        } else {
            diff_vec.resize(q, 0.0);
            &mut diff_vec
        };
        for (xi, ai) in self.x.chunks_exact(q).zip(self.kinv_y.chunks_exact(d)) {
            let k = self.hyper.rbf_variance * exp_nonpositive(c * sq_dist(x_star, xi));
            for (df, (a, b)) in diff.iter_mut().zip(x_star.iter().zip(xi)) {
                *df = -k * (a - b) / ell2;
            }
            for (j, a) in ai.iter().enumerate() {
                mean[j] += k * a;
                for (jk, df) in jac[j * q..(j + 1) * q].iter_mut().zip(diff.iter()) {
                    *jk += a * df;
                }
            }
        }
    }
}

/// The lower Cholesky factor of $K = K^{rbf}(X) + \sigma_w^2 I$ under the jitter policy.
fn factor_k(
    x: &[f64],
    n: usize,
    q: usize,
    hyper: &Hyper,
    white: f64,
    config: &LikelihoodConfig,
) -> Result<(Mat<f64>, JitterUsed), GplvmError> {
    let mut xc = Vec::new();
    columns(x, n, q, &mut xc);
    let mut krbf = Mat::<f64>::zeros(n, n);
    rbf_lower(krbf.as_mut(), &xc, q, hyper, &mut vec![0.0; n]);
    let mut chol = Mat::<f64>::zeros(n, n);
    let fill = |mut l: faer::MatMut<'_, f64>| {
        for j in 0..n {
            for i in j..n {
                l[(i, j)] = krbf[(i, j)] + if i == j { white } else { 0.0 };
            }
        }
    };
    let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(n, config.par, Default::default()));
    let jitter = cholesky_with_jitter(chol.as_mut(), fill, &config.jitter, "K", config.par, MemStack::new(&mut mem))?;
    Ok((chol, jitter))
}

/// What the predictive variance is computed from.
#[derive(Debug, Clone)]
enum VarianceFactor {
    /// The lower Cholesky factor $L$ of $K$ at the training latents:
    /// $v = \sigma_f^2 - \lVert L^{-1}k_*\rVert^2$, $O(N^2)$.
    Dense(Mat<f64>),
    /// DTC (`sparse`): with $K_{uu} = LL^\top$, $V = L^{-1}K_{uf}$ and
    /// $B = \sigma^2I + VV^\top = L_BL_B^\top$ (so $A = \sigma^2K_{uu} + K_{uf}K_{fu} = LBL^\top$),
    /// $v = \sigma_f^2 - \lVert a\rVert^2 + \sigma^2\lVert L_B^{-1}a\rVert^2$ with
    /// $a = L^{-1}k(U, x_*)$, $O(M^2)$.
    Sparse { l_uu: Mat<f64>, l_b: Mat<f64> },
}

/// A fitted model's full predictor: the mean map plus what the variance needs. The mean
/// runs over the model's *support points*: the training latents of a dense fit, the
/// inducing points of a sparse one ([`super::sparse`]). Dereferences to [`MeanPredictor`].
#[derive(Debug, Clone)]
pub struct Predictor {
    mean: MeanPredictor,
    variance: VarianceFactor,
    jitter: JitterUsed,
    white_used: f64,
}

impl Deref for Predictor {
    type Target = MeanPredictor;
    fn deref(&self) -> &MeanPredictor {
        &self.mean
    }
}

/// `y` (row-major `N × d`) as a matrix, after checking its shape.
fn output_matrix(y: &[f64], d: usize) -> Result<Mat<f64>, GplvmError> {
    if d == 0 || y.is_empty() || !y.len().is_multiple_of(d) {
        return Err(GplvmError::Shape(format!("y has {} values, not N × d with d = {d}", y.len())));
    }
    Ok(Mat::<f64>::from_fn(y.len() / d, d, |i, j| y[i * d + j]))
}

/// A matrix as a row-major vector.
fn row_major(a: &Mat<f64>) -> Vec<f64> {
    (0..a.nrows()).flat_map(|i| (0..a.ncols()).map(move |j| (i, j))).map(|(i, j)| a[(i, j)]).collect()
}

impl Predictor {
    /// Factors $K = K^{rbf} + (\sigma_w^2 + j)I$ at the training latents `x` (row-major
    /// `N × q`) with the same jitter policy and white floor as the likelihood, and
    /// precomputes $K^{-1}Y$ for `y` (row-major `N × d`).
    pub fn new(x: &[f64], y: &[f64], d: usize, hyper: Hyper, config: &LikelihoodConfig) -> Result<Self, GplvmError> {
        hyper.check()?;
        let mut a = output_matrix(y, d)?;
        let n = a.nrows();
        if x.is_empty() || !x.len().is_multiple_of(n) {
            return Err(GplvmError::Shape(format!("x has {} values, not N × q with N = {n}", x.len())));
        }
        let q = x.len() / n;
        let white = config.white(&hyper).0;
        let (chol, jitter) = factor_k(x, n, q, &hyper, white, config)?;
        triangular_solve::solve_lower_triangular_in_place(chol.as_ref(), a.as_mut(), config.par);
        triangular_solve::solve_upper_triangular_in_place(chol.transpose(), a.as_mut(), config.par);
        let kinv_y = row_major(&a);
        if kinv_y.iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("K⁻¹Y"));
        }
        let mean = MeanPredictor::from_parts(x.to_vec(), kinv_y, q, d, hyper)?;
        Ok(Self { mean, variance: VarianceFactor::Dense(chol), jitter, white_used: white })
    }

    /// The full predictor of a stored mean map: refactors $K$ at its latents (with the
    /// same jitter policy and white floor as the fit, so the same factor), keeping the
    /// stored $K^{-1}Y$.
    pub fn from_mean(mean: MeanPredictor, config: &LikelihoodConfig) -> Result<Self, GplvmError> {
        let (n, q) = (mean.n(), mean.q());
        let hyper = *mean.hyper();
        let white = config.white(&hyper).0;
        let (chol, jitter) = factor_k(&mean.x, n, q, &hyper, white, config)?;
        Ok(Self { mean, variance: VarianceFactor::Dense(chol), jitter, white_used: white })
    }

    /// The DTC predictor of a sparse fit (Lawrence 2007; [`super::sparse`]): latents `x`
    /// (`N × q`), inducing points `u` (`M × q`), outputs `y` (`N × d`). The mean is
    /// $\mu(x_*) = k(x_*, U)^\top W$ with $W = A^{-1}K_{uf}Y$, a [`MeanPredictor`] over
    /// $U$: reconstruction costs $O(M(q + d))$. The white variance is floored by `config`
    /// as the fit's was.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for wrong shapes or inducing points the fit refuses
    /// (none, more than the latents, or two within [`super::sparse::COINCIDE`] length
    /// scales), or matrices that will not factor.
    pub fn sparse(
        x: &[f64],
        u: &[f64],
        y: &[f64],
        d: usize,
        hyper: Hyper,
        config: &LikelihoodConfig,
    ) -> Result<Self, GplvmError> {
        hyper.check()?;
        let y = output_matrix(y, d)?;
        let n = y.nrows();
        if x.is_empty() || !x.len().is_multiple_of(n) {
            return Err(GplvmError::Shape(format!("x has {} values, not N × q with N = {n}", x.len())));
        }
        let q = x.len() / n;
        let white = config.white(&hyper).0;
        let SparseFactors { l_uu, l_b, v } = sparse_factors(x, u, q, &hyper, white)?;
        // W = A⁻¹K_uf Y = L⁻ᵀB⁻¹VY.
        let mut w = &v * &y;
        triangular_solve::solve_lower_triangular_in_place(l_b.as_ref(), w.as_mut(), Par::Seq);
        triangular_solve::solve_upper_triangular_in_place(l_b.transpose(), w.as_mut(), Par::Seq);
        triangular_solve::solve_upper_triangular_in_place(l_uu.transpose(), w.as_mut(), Par::Seq);
        let w = row_major(&w);
        if w.iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("A⁻¹K_uf Y"));
        }
        let mean = MeanPredictor::from_parts(u.to_vec(), w, q, d, hyper)?;
        let jitter = JitterUsed { added: super::sparse::JITTER * hyper.rbf_variance, retries: 0 };
        Ok(Self { mean, variance: VarianceFactor::Sparse { l_uu, l_b }, jitter, white_used: white })
    }

    /// The full predictor of a stored sparse mean map (over the inducing points, with the
    /// stored $W$) and the training latents `x` it was fitted at: refactors $K_{uu}$ and $A$
    /// for the variance, $O(NM^2)$. `mean`'s hyperparameters carry the white variance the
    /// fit used.
    pub fn from_sparse_mean(mean: MeanPredictor, x: &[f64]) -> Result<Self, GplvmError> {
        let hyper = *mean.hyper();
        let q = mean.q();
        if x.is_empty() || !x.len().is_multiple_of(q) {
            return Err(GplvmError::Shape(format!("x has {} values, not N × q with q = {q}", x.len())));
        }
        let white = hyper.white_variance;
        let SparseFactors { l_uu, l_b, .. } = sparse_factors(x, mean.x(), q, &hyper, white)?;
        let jitter = JitterUsed { added: super::sparse::JITTER * hyper.rbf_variance, retries: 0 };
        Ok(Self { mean, variance: VarianceFactor::Sparse { l_uu, l_b }, jitter, white_used: white })
    }

    /// Whether this is a sparse (DTC) predictor, whose support points are inducing points.
    pub fn is_sparse(&self) -> bool {
        matches!(self.variance, VarianceFactor::Sparse { .. })
    }

    /// Jitter added to the diagonal of $K$ (of $K_{uu}$ for a sparse predictor).
    pub fn jitter_used(&self) -> JitterUsed {
        self.jitter
    }

    /// The white variance used (after the floor).
    pub fn white_variance_used(&self) -> f64 {
        self.white_used
    }

    /// $v(x_*)$: dense $\sigma_f^2 - k_*^\top K^{-1}k_*$, sparse (DTC)
    /// $\sigma_f^2 - k_*^\top K_{uu}^{-1}k_* + \sigma^2k_*^\top A^{-1}k_*$; plus $\sigma_w^2$ if `with_noise` (the
    /// variance of a new observation rather than of the latent function).
    pub fn variance(&self, x_star: &[f64], with_noise: bool) -> f64 {
        assert_eq!(x_star.len(), self.q(), "x* must have q values");
        let mut k = Mat::<f64>::zeros(self.n(), 1);
        rbf_vector(x_star, self.x(), self.hyper(), k.col_as_slice_mut(0));
        let mut solve_norm = |l: &Mat<f64>| {
            triangular_solve::solve_lower_triangular_in_place(l.as_ref(), k.as_mut(), Par::Seq);
            k.col_as_slice(0).iter().map(|v| v * v).sum::<f64>()
        };
        let explained = match &self.variance {
            VarianceFactor::Dense(chol) => solve_norm(chol),
            // a = L⁻¹k*, then L_B⁻¹a in place.
            VarianceFactor::Sparse { l_uu, l_b } => solve_norm(l_uu) - self.white_used * solve_norm(l_b),
        };
        let prior = self.hyper().rbf_variance + if with_noise { self.white_used } else { 0.0 };
        (prior - explained).max(0.0)
    }
}

/// What a sparse predictor is built from (see [`VarianceFactor::Sparse`]).
struct SparseFactors {
    /// $L$, the lower factor of $K_{uu}$.
    l_uu: Mat<f64>,
    /// $L_B$, the lower factor of $B = \sigma^2I + VV^\top$.
    l_b: Mat<f64>,
    /// $V = L^{-1}K_{uf}$.
    v: Mat<f64>,
}

/// The [`SparseFactors`] of latents `x` and inducing points `u` (both with `q` columns),
/// white variance `white`.
fn sparse_factors(x: &[f64], u: &[f64], q: usize, hyper: &Hyper, white: f64) -> Result<SparseFactors, GplvmError> {
    super::sparse::check_inducing(u, q, x.len() / q, hyper)?;
    let (kuu, mut v) = (super::sparse::k_uu(u, q, hyper), super::sparse::k_uf(u, x, q, hyper));
    let factor = |m: &Mat<f64>, what: &str| {
        m.llt(faer::Side::Lower).map(|l| l.L().to_owned()).map_err(|_| {
            GplvmError::Shape(format!("{what} will not factor: do inducing points collapse onto each other?"))
        })
    };
    let l_uu = factor(&kuu, "K_uu")?;
    triangular_solve::solve_lower_triangular_in_place(l_uu.as_ref(), v.as_mut(), Par::Seq);
    let mut b = &v * v.transpose();
    (0..b.nrows()).for_each(|i| b[(i, i)] += white);
    Ok(SparseFactors { l_b: factor(&b, "B = σ²I + VVᵀ")?, l_uu, v })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};

    /// With tiny white noise and well-separated training points, μ(x_i) reproduces y_i and
    /// the latent variance there is ~0 while far away it returns to σ_f².
    #[test]
    fn interpolates_training_points() {
        let (n, d, q) = (30, 4, 2);
        // A jittered grid with spacing 1.5ℓ keeps K^rbf well conditioned.
        let (noise, y) = random_problem(n, d, q, 41);
        let x: Vec<f64> = (0..n)
            .flat_map(|i| [1.5 * (i % 6) as f64 + 0.1 * noise[2 * i], 1.5 * (i / 6) as f64 + 0.1 * noise[2 * i + 1]])
            .collect();
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 1e-10 };
        let config = LikelihoodConfig { white_floor: 0.0, ..Default::default() };
        let p = Predictor::new(&x, &y, d, hyper, &config).unwrap();
        assert_eq!(p.jitter_used().retries, 0);
        let mut mu = vec![0.0; d];
        let ymax = y.iter().map(|v| v.abs()).fold(0.0, f64::max);
        for i in 0..n {
            p.mean(&x[i * q..(i + 1) * q], &mut mu);
            let err = mu.iter().zip(&y[i * d..(i + 1) * d]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err < 1e-7 * ymax, "point {i}: {err:e}");
            assert!(p.variance(&x[i * q..(i + 1) * q], false) < 1e-7); // ≈ σ_w² + jitter
        }
        assert!((p.variance(&[100.0, 100.0], true) - (1.0 + 1e-10)).abs() < 1e-12);
    }

    /// The Jacobian of the mean equals central differences (1e-7 relative), and
    /// `mean_jacobian`'s mean equals `mean`.
    #[test]
    fn jacobian_matches_finite_differences() {
        let (n, d, q) = (25, 5, 3);
        let (x, y) = random_problem(n, d, q, 42);
        let hyper = Hyper { rbf_variance: 1.2, lengthscale: 0.8, white_variance: 0.05 };
        let p = Predictor::new(&x, &y, d, hyper, &LikelihoodConfig::default()).unwrap();
        let x_star = [0.2, -0.4, 0.3];
        let (mut mu, mut jac, mut mu2) = (vec![0.0; d], vec![0.0; d * q], vec![0.0; d]);
        p.mean_jacobian(&x_star, &mut mu, &mut jac);
        p.mean(&x_star, &mut mu2);
        assert!(max_rel_err(&mu, &mu2) < 1e-14);
        for j in 0..d {
            let fd = central_diff(&x_star, 1e-4, |xs| {
                let mut m = vec![0.0; d];
                p.mean(xs, &mut m);
                m[j]
            });
            let err = max_rel_err(&jac[j * q..(j + 1) * q], &fd);
            eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
            assert!(err < 1e-7, "output {j}: {err:e}");
        }
    }

    /// The variance equals σ_f² − k*ᵀK⁻¹k* computed with an explicit inverse, and the
    /// mean-only predictor built from parts gives the same mean.
    #[test]
    fn variance_matches_explicit_inverse() {
        let (n, d, q) = (15, 2, 2);
        let (x, y) = random_problem(n, d, q, 43);
        let hyper = Hyper { rbf_variance: 0.7, lengthscale: 1.3, white_variance: 0.1 };
        let config = LikelihoodConfig { jitter: crate::gplvm::Jitter::NONE, ..Default::default() };
        let p = Predictor::new(&x, &y, d, hyper, &config).unwrap();
        let k = Mat::<f64>::from_fn(n, n, |i, j| {
            let kr = 0.7 * (-sq_dist(&x[i * q..(i + 1) * q], &x[j * q..(j + 1) * q]) / (2.0 * 1.69)).exp();
            kr + if i == j { 0.1 } else { 0.0 }
        });
        let kinv = faer::linalg::solvers::DenseSolveCore::inverse(&k.partial_piv_lu());
        let x_star = [0.5, 0.1];
        let mut ks = vec![0.0; n];
        rbf_vector(&x_star, &x, &hyper, &mut ks);
        let quad: f64 =
            (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).map(|(i, j)| ks[i] * kinv[(i, j)] * ks[j]).sum();
        assert!((p.variance(&x_star, false) - (0.7 - quad)).abs() < 1e-12);
        assert!((p.variance(&x_star, true) - (0.8 - quad)).abs() < 1e-12);
        let m = MeanPredictor::from_parts(x.clone(), p.kinv_y().to_vec(), q, d, hyper).unwrap();
        let (mut a, mut b) = (vec![0.0; d], vec![0.0; d]);
        m.mean(&x_star, &mut a);
        p.mean(&x_star, &mut b);
        assert_eq!(a, b);
        assert!(MeanPredictor::from_parts(x, vec![0.0; 3], q, d, hyper).is_err());
    }
}
