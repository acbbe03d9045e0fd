//! The GPLVM likelihood under the deterministic training conditional (DTC; Lawrence 2007,
//! "Learning for larger datasets with the Gaussian process latent variable model"): $M$
//! inducing points $U$ in the latent space stand for the $N$ latent points, so one
//! evaluation costs $O(NM^2 + NMD)$ instead of $O(N^3)$ (#32).
//!
//! With $K_{uu} = k(U, U) + jI$ ($j$ a fixed jitter), $K_{uf} = k(U, X)$,
//! $Q = K_{fu}K_{uu}^{-1}K_{uf}$ and $C = Q + \sigma^2 I$ ($\sigma^2 = \sigma_w^2$):
//! $$E = \tfrac D2\log\lvert C\rvert + \tfrac12\operatorname{tr}(C^{-1}YY^\top) + \tfrac{ND}2\log 2\pi .$$
//!
//! By Woodbury, with $A = \sigma^2K_{uu} + K_{uf}K_{fu}$ ($M\times M$), $B = K_{uf}Y$ and
//! $W = A^{-1}B$:
//! $\log\lvert C\rvert = (N - M)\log\sigma^2 + \log\lvert A\rvert - \log\lvert K_{uu}\rvert$ and
//! $\operatorname{tr}(C^{-1}YY^\top) = \sigma^{-2}(\operatorname{tr}Y^\top Y - \operatorname{tr}B^\top W)$.
//!
//! Gradients, with $H = \tfrac D2A^{-1} + \tfrac1{2\sigma^2}WW^\top$:
//! $$\frac{\partial E}{\partial K_{uu}} = \sigma^2H - \tfrac D2K_{uu}^{-1},\quad
//! \frac{\partial E}{\partial K_{uf}} = 2HK_{uf} - \sigma^{-2}WY^\top,$$
//! $$\frac{\partial E}{\partial\sigma^2} = \frac{D(N - M)}{2\sigma^2} + \operatorname{tr}(HK_{uu})
//! - \frac{\operatorname{tr}Y^\top Y - \operatorname{tr}B^\top W}{2\sigma^4},$$
//!
//! then through the RBF kernel to $X$, $U$, $\sigma_f^2$ and $\ell$. No $N\times N$ matrix is
//! formed. When $U = X$ (and $j \to 0$), $Q = K$ and $E$ is the dense likelihood.
//!
//! [`SparseLikelihood::bound`] adds Titsias's trace term
//! $\frac{D}{2\sigma^2}\operatorname{tr}(K_{ff} - Q_{ff}) = \frac{D}{2\sigma^2}(N\sigma_f^2 - \lVert V\rVert^2)$
//! ($V = L^{-1}K_{uf}$, $K_{uu} = LL^\top$): the collapsed variational bound for *point*
//! latents (SGPR; GPy's `SparseGPLVM`), which keeps reprise's MAP model with its priors and
//! needs no ψ-statistics (those are for distributions over $X$, the Bayesian GPLVM). The
//! fit uses it: without the term, half the dragon-face labels never converged at
//! $M = 50$ (docs/design/2026-12-08-sparse-gplvm-in-the-stage.md).

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve;
use faer::{Mat, Par, Side};

use super::kernel::sq_dist;
use super::latent::{best_latent, ProjectOptions, Projection};
use super::{GplvmError, Hyper, HyperGrad, MeanPredictor};

/// The jitter on $K_{uu}$'s diagonal, relative to $\sigma_f^2$.
pub const JITTER: f64 = 1e-8;

/// Inducing points closer than this many length scales are refused as coinciding.
pub const COINCIDE: f64 = 1e-6;

/// One evaluation of [`SparseLikelihood::evaluate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SparseEval {
    /// $E$.
    pub value: f64,
    /// $\partial E/\partial(\sigma_f^2, \ell, \sigma_w^2)$, natural space.
    pub grad_hyper: HyperGrad,
}

/// The DTC likelihood of a fixed $Y$.
#[derive(Debug, Clone)]
pub struct SparseLikelihood {
    y: Mat<f64>,
    yy: f64,
    q: usize,
    /// Whether Titsias's trace term is added ([`SparseLikelihood::bound`]).
    bound: bool,
}

impl SparseLikelihood {
    /// The likelihood of the row-major `N × d` data `y` with latent dimension `q`.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for no data, rows that are not whole, or `q = 0`.
    pub fn new(y: &[f64], d: usize, q: usize) -> Result<Self, GplvmError> {
        if d == 0 || q == 0 || y.is_empty() || !y.len().is_multiple_of(d) {
            return Err(GplvmError::Shape(format!("{} values are not rows of {d} (q = {q})", y.len())));
        }
        let n = y.len() / d;
        Ok(Self { y: Mat::from_fn(n, d, |i, j| y[i * d + j]), yy: y.iter().map(|v| v * v).sum(), q, bound: false })
    }

    /// The same data under Titsias's collapsed variational bound (2009; GPy's
    /// `SparseGPLVM`, GPflow's SGPR) for point latents: DTC's $E$ plus
    /// $\frac{D}{2\sigma^2}\operatorname{tr}(K_{ff} - Q_{ff})$, so $E$ bounds the dense $E$ from
    /// above and a latent far from every inducing point pays for what they cannot
    /// explain there.
    pub fn bound(self) -> Self {
        Self { bound: true, ..self }
    }

    /// Rows $N$.
    pub fn n(&self) -> usize {
        self.y.nrows()
    }

    /// Latent dimension $q$.
    pub fn q(&self) -> usize {
        self.q
    }

    /// $E$ at latents `x` (`N × q`), inducing points `u` (`M × q`) and `hyper`, with
    /// $\partial E/\partial X$ into `grad_x` and $\partial E/\partial U$ into `grad_u`.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for wrong lengths, more inducing points than rows, inducing
    /// points that coincide ([`COINCIDE`]), or a matrix that will not factor.
    pub fn evaluate(
        &self,
        x: &[f64],
        u: &[f64],
        hyper: &Hyper,
        grad_x: &mut [f64],
        grad_u: &mut [f64],
    ) -> Result<SparseEval, GplvmError> {
        let (n, d, q) = (self.n(), self.y.ncols(), self.q);
        let m = u.len() / q;
        if x.len() != n * q || u.len() != m * q || m == 0 || grad_x.len() != x.len() || grad_u.len() != u.len() {
            return Err(GplvmError::Shape(format!("{n} latents and {m} inducing points of {q} dimensions expected")));
        }
        let (sf2, ell2, s2) = (hyper.rbf_variance, hyper.lengthscale * hyper.lengthscale, hyper.white_variance);
        fn row(v: &[f64], i: usize, q: usize) -> &[f64] {
            &v[i * q..(i + 1) * q]
        }
        check_inducing(u, q, n, hyper)?;
        let jitter = JITTER * sf2;
        let (kuu, kuf) = (k_uu(u, q, hyper), k_uf(u, x, q, hyper));
        let collapse = || {
            GplvmError::Shape(
                "the inducing points' kernel will not factor: do inducing points collapse onto each other?".into(),
            )
        };
        // The stable form (as GPflow's SGPR): K_uu = LLᵀ, V = L⁻¹K_uf, B = σ²I + VVᵀ, so
        // A = LBLᵀ, log|A| − log|K_uu| = log|B|, and with Ŵ = B⁻¹VY = LᵀW every term
        // below is formed at B's moderate scale before L⁻ᵀ… L⁻¹ is applied once.
        let l = kuu.llt(Side::Lower).map_err(|_| collapse())?.L().to_owned();
        let mut v = kuf.clone();
        triangular_solve::solve_lower_triangular_in_place(l.as_ref(), v.as_mut(), Par::Seq);
        let mut bmat = &v * v.transpose();
        (0..m).for_each(|i| bmat[(i, i)] += s2);
        let lb = bmat.llt(Side::Lower).map_err(|_| collapse())?;
        let logdet_b = (0..m).map(|i| 2.0 * lb.L()[(i, i)].ln()).sum::<f64>();
        let vy = &v * &self.y;
        let what = lb.solve(&vy);
        let btw: f64 = (0..m).flat_map(|i| (0..d).map(move |j| (i, j))).map(|(i, j)| vy[(i, j)] * what[(i, j)]).sum();
        let log_c = (n - m) as f64 * s2.ln() + logdet_b;
        let fit = self.yy - btw;
        // Titsias's trace term (the bound's): c·T, c = D/(2σ²), T = tr(K_ff − Q_ff) = Nσf² − ‖V‖².
        let c = if self.bound { 0.5 * d as f64 / s2 } else { 0.0 };
        let trace = n as f64 * sf2
            - (0..m).flat_map(|i| (0..n).map(move |j| (i, j))).map(|(i, j)| v[(i, j)].powi(2)).sum::<f64>();
        let value = 0.5 * d as f64 * log_c
            + fit / (2.0 * s2)
            + 0.5 * (n * d) as f64 * (2.0 * std::f64::consts::PI).ln()
            + c * trace;

        // ∂E/∂K_uu = L⁻ᵀGL⁻¹ with G = (D/2)(σ²B⁻¹ − I) + ½ŴŴᵀ, and
        // ∂E/∂K_uf = L⁻ᵀR with R = D·B⁻¹V − σ⁻²Ŵ(Y − VᵀŴ)ᵀ.
        let b_inv = lb.solve(Mat::<f64>::identity(m, m));
        let half_d = 0.5 * d as f64;
        // The trace term adds c·VVᵀ to G and −2c·V to R.
        let mut g = &b_inv * (half_d * s2) + (&what * what.transpose()) * 0.5 + (&v * v.transpose()) * c;
        (0..m).for_each(|i| g[(i, i)] -= half_d);
        let resid = &self.y - v.transpose() * &what;
        let mut g_uf = (&b_inv * &v) * d as f64 - (&what * resid.transpose()) * (1.0 / s2) - &v * (2.0 * c);
        let lt = l.transpose();
        triangular_solve::solve_upper_triangular_in_place(lt, g_uf.as_mut(), Par::Seq);
        triangular_solve::solve_upper_triangular_in_place(lt, g.as_mut(), Par::Seq);
        let mut g_uu = g.transpose().to_owned();
        triangular_solve::solve_upper_triangular_in_place(lt, g_uu.as_mut(), Par::Seq);
        // tr(HK_uu) = (D/2)tr(B⁻¹) + ‖Ŵ‖²/(2σ²).
        let tr_b_inv: f64 = (0..m).map(|i| b_inv[(i, i)]).sum();
        let w_sq: f64 = (0..m).flat_map(|i| (0..d).map(move |j| (i, j))).map(|(i, j)| what[(i, j)].powi(2)).sum();
        let tr_hk = half_d * tr_b_inv + w_sq / (2.0 * s2);
        let d_s2 = 0.5 * d as f64 * (n - m) as f64 / s2 + tr_hk - fit / (2.0 * s2 * s2) - c * trace / s2;

        // Through the kernel: ∂k(a, b)/∂a = k (b − a)/ℓ², ∂k/∂σf² = k/σf², ∂k/∂ℓ = k|a − b|²/ℓ³.
        grad_x.fill(0.0);
        grad_u.fill(0.0);
        // The trace term's Nσf² (the diagonal of K_ff).
        let (mut d_sf2, mut d_ell) = (c * n as f64, 0.0);
        let ell3 = ell2 * hyper.lengthscale;
        for i in 0..m {
            for j in 0..n {
                let (g, kv) = (g_uf[(i, j)], kuf[(i, j)]);
                if kv == 0.0 {
                    continue;
                }
                let (ui, xj) = (row(u, i, q), row(x, j, q));
                for a in 0..q {
                    let delta = (ui[a] - xj[a]) / ell2;
                    grad_x[j * q + a] += g * kv * delta;
                    grad_u[i * q + a] -= g * kv * delta;
                }
                d_sf2 += g * kv / sf2;
                d_ell += g * kv * sq_dist(ui, xj) / ell3;
            }
            for j in 0..m {
                let kv = kuu[(i, j)] - if i == j { jitter } else { 0.0 };
                let g = g_uu[(i, j)];
                // The jitter scales with σf² too.
                d_sf2 += g * (kv + if i == j { jitter } else { 0.0 }) / sf2;
                if i != j {
                    let (ui, uj) = (row(u, i, q), row(u, j, q));
                    for a in 0..q {
                        grad_u[i * q + a] += 2.0 * g * kv * (uj[a] - ui[a]) / ell2;
                    }
                    d_ell += g * kv * sq_dist(ui, uj) / ell3;
                }
            }
        }
        Ok(SparseEval {
            value,
            grad_hyper: HyperGrad { rbf_variance: d_sf2, lengthscale: d_ell, white_variance: d_s2 },
        })
    }
}

/// Refuses inducing points the fit cannot use: none, more than the `n` latent points, or
/// two closer than [`COINCIDE`] length scales (they would make $K_{uu}$ singular but for the
/// jitter, a duplicate that explains nothing).
pub(crate) fn check_inducing(u: &[f64], q: usize, n: usize, hyper: &Hyper) -> Result<(), GplvmError> {
    let m = u.len() / q;
    if m == 0 || u.len() != m * q {
        return Err(GplvmError::Shape(format!("{} inducing values are not points of {q} dimensions", u.len())));
    }
    if m > n {
        return Err(GplvmError::Shape(format!("{m} inducing points for {n} latent points: at most one per point")));
    }
    let tiny = (COINCIDE * hyper.lengthscale).powi(2);
    let row = |i: usize| &u[i * q..(i + 1) * q];
    for i in 0..m {
        if let Some(j) = (0..i).find(|&j| sq_dist(row(i), row(j)) < tiny) {
            return Err(GplvmError::Shape(format!(
                "inducing points {j} and {i} coincide (closer than {COINCIDE} length scales): they collapse onto each other"
            )));
        }
    }
    Ok(())
}

/// $K_{uu} = k(U, U) + jI$ with $j$ = [`JITTER`] $\cdot\,\sigma_f^2$ (`M × M`).
pub(crate) fn k_uu(u: &[f64], q: usize, hyper: &Hyper) -> Mat<f64> {
    let m = u.len() / q;
    let jitter = JITTER * hyper.rbf_variance;
    let mut k = k_uf(u, u, q, hyper);
    (0..m).for_each(|i| k[(i, i)] += jitter);
    k
}

/// $K_{uf} = k(U, X)$ (`M × N`), the RBF part only.
pub(crate) fn k_uf(u: &[f64], x: &[f64], q: usize, hyper: &Hyper) -> Mat<f64> {
    let ell2 = hyper.lengthscale * hyper.lengthscale;
    Mat::from_fn(u.len() / q, x.len() / q, |i, j| {
        hyper.rbf_variance * (-0.5 * sq_dist(&u[i * q..(i + 1) * q], &x[j * q..(j + 1) * q]) / ell2).exp()
    })
}

/// The latent point of a new pose `y` (x* for y*, centred like the model's outputs) under
/// `predictor`: the minimiser of $\lVert y - \mu(x)\rVert^2$ ([`best_latent`]), started
/// from the support points (a sparse model's inducing points) whose predicted poses are
/// nearest `y`. $O(M(q + d))$ per evaluation.
pub fn infer_latent(predictor: &MeanPredictor, y: &[f64], opts: &ProjectOptions) -> Projection {
    let (q, d) = (predictor.q(), predictor.d());
    let mut at = vec![0.0; d];
    let outputs: Vec<f64> = predictor
        .x()
        .chunks_exact(q)
        .flat_map(|u| {
            predictor.mean(u, &mut at);
            at.clone()
        })
        .collect();
    best_latent(predictor, y, predictor.x(), &outputs, opts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::{Jitter, Likelihood, LikelihoodConfig, Predictor};

    /// 12 points on a curve in 3-D, their 2-D latents, and 5 inducing points among them.
    fn problem() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..12).map(|i| -1.0 + 2.0 * f64::from(i) / 11.0).collect();
        let y: Vec<f64> = t.iter().flat_map(|&s| [s.sin(), s * s, 0.5 * s.cos()]).collect();
        let x: Vec<f64> = t.iter().flat_map(|&s| [s, 0.3 * (3.0 * s).sin()]).collect();
        let u: Vec<f64> = [0.9, -0.5, 0.1, 0.4, -0.8].iter().flat_map(|&s: &f64| [s, 0.2 * s * s]).collect();
        (y, x, u)
    }

    #[test]
    fn every_gradient_matches_central_differences() {
        for bound in [false, true] {
            every_gradient_matches(bound);
        }
    }

    fn every_gradient_matches(bound: bool) {
        let (y, x, u) = problem();
        let lik = SparseLikelihood::new(&y, 3, 2).unwrap();
        let lik = if bound { lik.bound() } else { lik };
        let hyper = Hyper { rbf_variance: 1.3, lengthscale: 0.7, white_variance: 0.05 };
        let (mut gx, mut gu) = (vec![0.0; x.len()], vec![0.0; u.len()]);
        let e = lik.evaluate(&x, &u, &hyper, &mut gx, &mut gu).unwrap();
        let (mut sx, mut su) = (gx.clone(), gu.clone());
        let mut value = |x: &[f64], u: &[f64], h: &Hyper| lik.evaluate(x, u, h, &mut sx, &mut su).unwrap().value;
        let h = 1e-6;
        let close =
            |fd: f64, g: f64, what: &str| assert!((fd - g).abs() < 1e-5 * (1.0 + g.abs()), "{what}: {fd} vs {g}");
        for i in 0..x.len() {
            let (mut a, mut b) = (x.clone(), x.clone());
            a[i] += h;
            b[i] -= h;
            close((value(&a, &u, &hyper) - value(&b, &u, &hyper)) / (2.0 * h), gx[i], &format!("x[{i}]"));
        }
        for i in 0..u.len() {
            let (mut a, mut b) = (u.clone(), u.clone());
            a[i] += h;
            b[i] -= h;
            close((value(&x, &a, &hyper) - value(&x, &b, &hyper)) / (2.0 * h), gu[i], &format!("u[{i}]"));
        }
        let bump = |f: &dyn Fn(&mut Hyper, f64)| {
            let (mut a, mut b) = (hyper, hyper);
            f(&mut a, h);
            f(&mut b, -h);
            (a, b)
        };
        let (a, b) = bump(&|p, s| p.rbf_variance += s);
        close((value(&x, &u, &a) - value(&x, &u, &b)) / (2.0 * h), e.grad_hyper.rbf_variance, "σf²");
        let (a, b) = bump(&|p, s| p.lengthscale += s);
        close((value(&x, &u, &a) - value(&x, &u, &b)) / (2.0 * h), e.grad_hyper.lengthscale, "ℓ");
        let (a, b) = bump(&|p, s| p.white_variance += s);
        close((value(&x, &u, &a) - value(&x, &u, &b)) / (2.0 * h), e.grad_hyper.white_variance, "σw²");
    }

    /// Titsias's bound lies above the dense $E$ (it bounds $\log p$ from below), above DTC's
    /// by exactly the trace term, and meets the dense $E$ with the inducing points at the
    /// latents.
    #[test]
    fn the_bound_lies_above_the_dense_likelihood_and_meets_it_at_the_latents() {
        let (y, x, u) = problem();
        let hyper = Hyper { rbf_variance: 1.1, lengthscale: 0.8, white_variance: 0.02 };
        let config = LikelihoodConfig { jitter: Jitter::NONE, white_floor: 0.0, ..LikelihoodConfig::default() };
        let dense =
            Likelihood::new(&y, 3, 2, config).unwrap().evaluate(&x, &hyper, &mut vec![0.0; x.len()]).unwrap().value;
        let (dtc, vfe) = (SparseLikelihood::new(&y, 3, 2).unwrap(), SparseLikelihood::new(&y, 3, 2).unwrap().bound());
        let e = |l: &SparseLikelihood, u: &[f64]| {
            l.evaluate(&x, u, &hyper, &mut vec![0.0; x.len()], &mut vec![0.0; u.len()]).unwrap().value
        };
        let (few_dtc, few_vfe) = (e(&dtc, &u), e(&vfe, &u));
        assert!(few_vfe > dense && few_vfe > few_dtc, "bound {few_vfe}, DTC {few_dtc}, dense {dense}");
        let at = e(&vfe, &x);
        assert!((at - dense).abs() < 1e-4 * dense.abs().max(1.0), "{at} vs {dense}");
    }

    #[test]
    fn inducing_points_at_the_latents_give_the_dense_likelihood() {
        let (y, x, _) = problem();
        let hyper = Hyper { rbf_variance: 1.1, lengthscale: 0.8, white_variance: 0.02 };
        let sparse = SparseLikelihood::new(&y, 3, 2).unwrap();
        let (mut gx, mut gu) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        let s = sparse.evaluate(&x, &x, &hyper, &mut gx, &mut gu).unwrap();
        let config = LikelihoodConfig { jitter: Jitter::NONE, white_floor: 0.0, ..LikelihoodConfig::default() };
        let mut dense = Likelihood::new(&y, 3, 2, config).unwrap();
        let mut g = vec![0.0; x.len()];
        let e = dense.evaluate(&x, &hyper, &mut g).unwrap();
        assert!((s.value - e.value).abs() < 1e-5 * e.value.abs().max(1.0), "{} vs {}", s.value, e.value);
        // Moving a latent moves its inducing point with it: the sum of both gradients.
        for i in 0..x.len() {
            let total = gx[i] + gu[i];
            assert!((total - g[i]).abs() < 1e-4 * (1.0 + g[i].abs()), "x[{i}]: {total} vs {}", g[i]);
        }
        let (a, b) = (s.grad_hyper, e.grad_hyper);
        for (p, r) in
            [(a.rbf_variance, b.rbf_variance), (a.lengthscale, b.lengthscale), (a.white_variance, b.white_variance)]
        {
            assert!((p - r).abs() < 1e-4 * (1.0 + r.abs()), "{p} vs {r}");
        }
    }

    #[test]
    fn a_training_poses_latent_is_recovered_through_the_inducing_points() {
        // 40 poses of a 1-D curve in 3-D at known latents; 8 inducing points among them.
        let t: Vec<f64> = (0..40).map(|i| -1.5 + 3.0 * f64::from(i) / 39.0).collect();
        let y: Vec<f64> = t.iter().flat_map(|&s| [s.sin(), s.cos(), 0.4 * s]).collect();
        let u: Vec<f64> = t.iter().step_by(5).copied().collect();
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.6, white_variance: 1e-4 };
        let config = LikelihoodConfig { white_floor: 0.0, ..LikelihoodConfig::default() };
        let p = Predictor::sparse(&t, &u, &y, 3, hyper, &config).unwrap();
        assert_eq!(p.n(), 8, "the predictor is over the inducing points");
        for j in [3, 17, 31] {
            let found = infer_latent(&p, &y[3 * j..3 * j + 3], &ProjectOptions::default());
            assert!((found.x[0] - t[j]).abs() < 0.02, "pose {j}: latent {} vs {}", found.x[0], t[j]);
        }
    }

    #[test]
    fn the_sparse_predictor_at_the_latents_is_the_dense_one_and_reloads_unchanged() {
        let (y, x, u) = problem();
        let hyper = Hyper { rbf_variance: 1.1, lengthscale: 0.8, white_variance: 0.02 };
        let config = LikelihoodConfig { jitter: Jitter::NONE, white_floor: 0.0, ..LikelihoodConfig::default() };
        let dense = Predictor::new(&x, &y, 3, hyper, &config).unwrap();
        let sparse = Predictor::sparse(&x, &x, &y, 3, hyper, &config).unwrap();
        assert!(sparse.is_sparse() && !dense.is_sparse());
        let (mut a, mut b) = (vec![0.0; 3], vec![0.0; 3]);
        for xs in [[0.1, 0.2], [-0.7, 0.0], [2.0, -1.0]] {
            dense.mean(&xs, &mut a);
            sparse.mean(&xs, &mut b);
            a.iter().zip(&b).for_each(|(a, b)| assert!((a - b).abs() < 1e-5, "mean {a} vs {b}"));
            let (vd, vs) = (dense.variance(&xs, true), sparse.variance(&xs, true));
            assert!((vd - vs).abs() < 1e-5, "variance at {xs:?}: {vd} vs {vs}");
        }
        // Fewer inducing points: the variance grows away from them and stays in [0, σf² + σ²].
        let few = Predictor::sparse(&x, &u, &y, 3, hyper, &config).unwrap();
        let near = few.variance(&u[..2], false);
        let far = few.variance(&[5.0, 5.0], false);
        assert!(near < 0.1 * hyper.rbf_variance && (far - hyper.rbf_variance).abs() < 1e-9, "{near} {far}");
        // Stored (U, W, θ with the white variance used) and reloaded with the latents: the same.
        let stored = MeanPredictor::from_parts(few.x().to_vec(), few.kinv_y().to_vec(), 2, 3, hyper).unwrap();
        let again = Predictor::from_sparse_mean(stored, &x).unwrap();
        for xs in [[0.1, 0.2], [0.9, -0.5]] {
            assert!((again.variance(&xs, true) - few.variance(&xs, true)).abs() < 1e-12);
            few.mean(&xs, &mut a);
            again.mean(&xs, &mut b);
            assert_eq!(a, b);
        }
    }

    #[test]
    fn more_inducing_points_than_rows_or_collapsed_ones_are_refused() {
        let (y, x, _) = problem();
        let lik = SparseLikelihood::new(&y, 3, 2).unwrap();
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 0.01 };
        let many = [x.clone(), x[..2].to_vec()].concat();
        let (mut gx, mut gu) = (vec![0.0; x.len()], vec![0.0; many.len()]);
        let err = lik.evaluate(&x, &many, &hyper, &mut gx, &mut gu).unwrap_err().to_string();
        assert!(err.contains("13 inducing points for 12"), "{err}");
        let same = [0.3, 0.1].repeat(4);
        let mut gu = vec![0.0; same.len()];
        let err = lik.evaluate(&x, &same, &hyper, &mut gx, &mut gu).unwrap_err().to_string();
        assert!(err.contains("inducing points 0 and 1 coincide"), "{err}");
    }
}
