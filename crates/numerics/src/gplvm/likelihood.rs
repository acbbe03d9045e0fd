//! The GPLVM negative log likelihood and its gradients (method.md §1.1–1.2).
//!
//! $$E_Y = -\log p(Y\mid X) = \tfrac D2\log\lvert K\rvert + \tfrac12\operatorname{tr}(K^{-1}YY^\top) +
//! \tfrac{ND}2\log 2\pi,\qquad K = K^{rbf} + (\sigma_w^2 + j)I,$$
//!
//! with $j$ the jitter ([`Jitter`]). With $LL^\top = K$, $A = K^{-1}Y$:
//! $\log\lvert K\rvert = 2\sum_i\log L_{ii}$ and $\operatorname{tr}(K^{-1}YY^\top) = \sum_{ij}A_{ij}Y_{ij}$.
//! The matrix gradient is $G = \partial E_Y/\partial K = \tfrac D2K^{-1} - \tfrac12AA^\top$;
//! with $B = G\circ K^{rbf}$,
//!
//! $$\frac{\partial E_Y}{\partial x_i} = -\frac2{\ell^2}\sum_j B_{ij}(x_i - x_j),\quad
//! \frac{\partial E_Y}{\partial\sigma_f^2} = \frac1{\sigma_f^2}\sum_{ij}B_{ij},\quad
//! \frac{\partial E_Y}{\partial\ell} = \frac1{\ell^3}\sum_{ij}B_{ij}D_{ij},\quad
//! \frac{\partial E_Y}{\partial\sigma_w^2} = \operatorname{tr}G .$$
//!
//! Cost per evaluation: one Cholesky ($N^3/3$), the SPD inverse from it ($2N^3/3$), the
//! solve for $A$ and the lower half of $AA^\top$ ($3N^2D$), and one fused $O(N^2q)$ pass
//! over the lower triangle for every gradient. Only lower triangles are formed; the
//! workspace holds three $N\times N$ matrices ($K^{rbf}$, $L$, $K^{-1}$/$G$) plus faer's
//! $N\times N$ scratch for the inverse, allocated once.

use faer::dyn_stack::StackReq;
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::triangular::{matmul as tri_matmul, BlockStructure};
use faer::linalg::triangular_solve;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, Par};

use super::kernel::{columns, pair_grad_pass, rbf_lower, sq_dists_below, vectorised};
use super::params::{cholesky_with_jitter, JitterUsed, Scratch};
use super::{GplvmError, Hyper, HyperGrad, Jitter};

/// Numerical settings of the likelihood.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LikelihoodConfig {
    /// Diagonal jitter policy (default [`Jitter::GPY`]: always $10^{-8}$).
    pub jitter: Jitter,
    /// Floor on the white variance relative to the RBF variance: the kernel uses
    /// $\max(\sigma_w^2, r\sigma_f^2, a)$ (method.md §1.6). Default $r = 10^{-6}$; 0 disables.
    pub white_floor: f64,
    /// Absolute floor $a$ on the white variance, in the units of $Y^2$ (default 0: off).
    /// A floor tied to the *data* rather than to $\sigma_f^2$: [`super::fit()`] sets it to
    /// [`super::FitConfig::noise_floor`] × the mean per-dimension variance of $Y$, which
    /// makes the MAP well posed on noise-free curves (docs/method.md, "The GPLVM fit").
    pub white_min: f64,
    /// Parallelism of the dense factorisations and products.
    pub par: Par,
}

impl Default for LikelihoodConfig {
    fn default() -> Self {
        Self { jitter: Jitter::GPY, white_floor: 1e-6, white_min: 0.0, par: Par::Seq }
    }
}

/// Which floor set the white variance the kernel uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Floor {
    /// $\sigma_w^2$ itself (above both floors).
    None,
    /// $r\sigma_f^2$ (so the used value depends on $\sigma_f^2$).
    Relative,
    /// The absolute floor $a$ (a constant).
    Absolute,
}

impl LikelihoodConfig {
    /// The white variance the kernel uses, $\max(\sigma_w^2, r\sigma_f^2, a)$, and which
    /// term it is (ties go to $\sigma_w^2$, then to the relative floor: one-sided
    /// derivatives, exact away from the kinks).
    pub(crate) fn white(&self, hyper: &Hyper) -> (f64, Floor) {
        let relative = self.white_floor * hyper.rbf_variance;
        let floor = relative.max(self.white_min);
        if hyper.white_variance >= floor {
            (hyper.white_variance, Floor::None)
        } else if relative >= self.white_min {
            (relative, Floor::Relative)
        } else {
            (self.white_min, Floor::Absolute)
        }
    }
}

/// One evaluation of [`Likelihood::evaluate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LikelihoodEval {
    /// $E_Y = -\log p(Y\mid X)$.
    pub value: f64,
    /// $\partial E_Y/\partial(\sigma_f^2, \ell, \sigma_w^2)$ in natural space, of the clamped
    /// kernel (when the floor is active the white-variance entry is 0 and the floor's
    /// dependence on $\sigma_f^2$ is in the first entry).
    pub grad_hyper: HyperGrad,
    /// Jitter added to the diagonal.
    pub jitter: JitterUsed,
    /// The white variance the kernel used (after the floor).
    pub white_variance_used: f64,
    /// Whether the floor was active.
    pub white_clamped: bool,
}

impl LikelihoodEval {
    /// The hyperparameter gradient in log space at `at` (the hyperparameters evaluated).
    pub fn grad_hyper_log(&self, at: &Hyper) -> HyperGrad {
        self.grad_hyper.to_log(at)
    }
}

/// Workspace for evaluating $E_Y$ and its gradients for a fixed $Y$ at many $(X, \theta)$.
#[derive(Debug)]
pub struct Likelihood {
    n: usize,
    d: usize,
    q: usize,
    config: LikelihoodConfig,
    y: Mat<f64>,
    krbf: Mat<f64>,
    l: Mat<f64>,
    kinv: Mat<f64>,
    a: Mat<f64>,
    xc: Vec<f64>,
    dist: Vec<f64>,
    bcol: Vec<f64>,
    gx: Vec<f64>,
    mem: Scratch,
}

impl Likelihood {
    /// A workspace for the row-major `N × d` data `y` and latent dimension `q`.
    pub fn new(y: &[f64], d: usize, q: usize, config: LikelihoodConfig) -> Result<Self, GplvmError> {
        if d == 0 || q == 0 || y.is_empty() || !y.len().is_multiple_of(d) {
            return Err(GplvmError::Shape(format!("y has {} values, not a multiple of d = {d} (q = {q})", y.len())));
        }
        if y.iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("value in Y"));
        }
        if !(config.white_floor >= 0.0 && config.white_floor.is_finite()) {
            return Err(GplvmError::Params(format!("white floor must be >= 0, got {}", config.white_floor)));
        }
        if !(config.white_min >= 0.0 && config.white_min.is_finite()) {
            return Err(GplvmError::Params(format!("absolute white floor must be >= 0, got {}", config.white_min)));
        }
        let n = y.len() / d;
        let par = config.par;
        let scratch = StackReq::any_of(&[
            llt::factor::cholesky_in_place_scratch::<f64>(n, par, Default::default()),
            llt::inverse::inverse_scratch::<f64>(n, par),
        ]);
        Ok(Self {
            n,
            d,
            q,
            config,
            y: Mat::from_fn(n, d, |i, j| y[i * d + j]),
            krbf: Mat::zeros(n, n),
            l: Mat::zeros(n, n),
            kinv: Mat::zeros(n, n),
            a: Mat::zeros(n, d),
            xc: Vec::with_capacity(n * q),
            dist: vec![0.0; n],
            bcol: vec![0.0; n],
            gx: vec![0.0; n * q],
            mem: Scratch::new(scratch),
        })
    }

    /// Number of points $N$.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Output dimension $D$.
    pub fn d(&self) -> usize {
        self.d
    }

    /// Latent dimension $q$.
    pub fn q(&self) -> usize {
        self.q
    }

    /// The settings.
    pub fn config(&self) -> &LikelihoodConfig {
        &self.config
    }

    /// The white variance the kernel uses at `hyper`, and whether a floor is active.
    pub fn white_used(&self, hyper: &Hyper) -> (f64, bool) {
        let (white, active) = self.config.white(hyper);
        (white, active != Floor::None)
    }

    /// Builds $K$, factors it and solves for $A$; returns ($E_Y$, jitter, white used).
    fn factor_and_value(&mut self, x: &[f64], hyper: &Hyper) -> Result<(f64, JitterUsed, f64, Floor), GplvmError> {
        let (n, d, q) = (self.n, self.d, self.q);
        if x.len() != n * q {
            return Err(GplvmError::Shape(format!("x has {} values, expected N·q = {n}·{q}", x.len())));
        }
        if x.iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("latent coordinate"));
        }
        hyper.check()?;
        let (white, active) = self.config.white(hyper);
        let par = self.config.par;
        columns(x, n, q, &mut self.xc);
        rbf_lower(self.krbf.as_mut(), &self.xc, q, hyper, &mut self.dist);
        let krbf = &self.krbf;
        let fill = |mut l: faer::MatMut<'_, f64>| {
            for j in 0..n {
                let src = &krbf.col_as_slice(j)[j..];
                let dst = &mut l.rb_mut().col_mut(j).try_as_col_major_mut().expect("column-major").as_slice_mut()[j..];
                dst.copy_from_slice(src);
                dst[0] += white;
            }
        };
        let stack = self.mem.stack();
        let jitter = cholesky_with_jitter(self.l.as_mut(), fill, &self.config.jitter, "K", par, stack)?;
        let logdet = 2.0 * (0..n).map(|i| self.l[(i, i)].ln()).sum::<f64>();
        self.a.copy_from(&self.y);
        triangular_solve::solve_lower_triangular_in_place(self.l.as_ref(), self.a.as_mut(), par);
        triangular_solve::solve_upper_triangular_in_place(self.l.transpose(), self.a.as_mut(), par);
        let trace: f64 = (0..d).map(|j| dot(self.a.col_as_slice(j), self.y.col_as_slice(j))).sum();
        let value = 0.5 * ((n * d) as f64 * (2.0 * std::f64::consts::PI).ln() + d as f64 * logdet + trace);
        if !value.is_finite() {
            return Err(GplvmError::NonFinite("negative log likelihood"));
        }
        Ok((value, jitter, white, active))
    }

    /// $E_Y$ alone (one Cholesky and one solve; no inverse), and the jitter used.
    pub fn value(&mut self, x: &[f64], hyper: &Hyper) -> Result<(f64, JitterUsed), GplvmError> {
        self.factor_and_value(x, hyper).map(|(v, j, _, _)| (v, j))
    }

    /// $E_Y$ and every gradient: $\partial E_Y/\partial X$ is written (overwritten) into
    /// `grad_x` (row-major `N × q`), the hyperparameter gradient is returned.
    pub fn evaluate(&mut self, x: &[f64], hyper: &Hyper, grad_x: &mut [f64]) -> Result<LikelihoodEval, GplvmError> {
        let (n, d, q) = (self.n, self.d, self.q);
        if grad_x.len() != n * q {
            return Err(GplvmError::Shape(format!("grad_x has {} values, expected {}", grad_x.len(), n * q)));
        }
        let (value, jitter, white, active) = self.factor_and_value(x, hyper)?;
        let par = self.config.par;
        // Lower triangle of G' = K⁻¹ − AAᵀ/D, so that G = (D/2) G'.
        llt::inverse::inverse(self.kinv.as_mut(), self.l.as_ref(), par, self.mem.stack());
        tri_matmul(
            self.kinv.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Add,
            self.a.as_ref(),
            BlockStructure::Rectangular,
            self.a.transpose(),
            BlockStructure::Rectangular,
            -1.0 / d as f64,
            par,
        );
        let half_d = 0.5 * d as f64;
        self.gx.fill(0.0);
        let (trace_g, sum_b, sum_bd) = vectorised(GradPass {
            xc: &self.xc,
            gx: &mut self.gx,
            dist: &mut self.dist,
            bcol: &mut self.bcol,
            g: self.kinv.as_ref(),
            krbf: self.krbf.as_ref(),
            q,
            half_d,
        });
        let ell2 = hyper.lengthscale * hyper.lengthscale;
        let scale = -2.0 / ell2;
        for i in 0..n {
            for kk in 0..q {
                grad_x[i * q + kk] = scale * self.gx[kk * n + i];
            }
        }
        let mut grad_hyper = HyperGrad {
            rbf_variance: sum_b / hyper.rbf_variance,
            lengthscale: sum_bd / (ell2 * hyper.lengthscale),
            white_variance: trace_g,
        };
        match active {
            Floor::None => {}
            Floor::Relative => {
                grad_hyper.rbf_variance += self.config.white_floor * trace_g;
                grad_hyper.white_variance = 0.0;
            }
            Floor::Absolute => grad_hyper.white_variance = 0.0,
        }
        let clamped = active != Floor::None;
        if grad_x.iter().any(|v| !v.is_finite()) || grad_hyper.to_array().iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("likelihood gradient"));
        }
        Ok(LikelihoodEval { value, grad_hyper, jitter, white_variance_used: white, white_clamped: clamped })
    }
}

/// The fused gradient pass over the lower triangle: per column $j$, the distances,
/// $B_{ij} = \tfrac D2 G'_{ij}K^{rbf}_{ij}$ and the pairwise latent-gradient update; returns
/// $(\operatorname{tr}G, \sum_{ij}B_{ij}, \sum_{ij}B_{ij}D_{ij})$. A [`pulp::WithSimd`] so that
/// it is compiled per ISA.
struct GradPass<'a> {
    xc: &'a [f64],
    gx: &'a mut [f64],
    dist: &'a mut [f64],
    bcol: &'a mut [f64],
    g: faer::MatRef<'a, f64>,
    krbf: faer::MatRef<'a, f64>,
    q: usize,
    half_d: f64,
}

impl pulp::WithSimd for GradPass<'_> {
    type Output = (f64, f64, f64);
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> (f64, f64, f64) {
        let Self { xc, gx, dist, bcol, g, krbf, q, half_d } = self;
        let n = g.nrows();
        let (mut trace_g, mut sum_b, mut sum_bd) = (0.0, 0.0, 0.0);
        for j in 0..n {
            sq_dists_below(xc, n, q, j, dist);
            let gc = g.col(j).try_as_col_major().expect("column-major").as_slice();
            let k = krbf.col(j).try_as_col_major().expect("column-major").as_slice();
            let gjj = half_d * gc[j];
            trace_g += gjj;
            sum_b += gjj * k[j];
            let (sb, sbd) = b_column(&mut bcol[j + 1..n], &gc[j + 1..n], &k[j + 1..n], &dist[j + 1..n], half_d);
            sum_b += 2.0 * sb;
            sum_bd += 2.0 * sbd;
            pair_grad_pass(xc, gx, n, q, j, bcol);
        }
        (trace_g, sum_b, sum_bd)
    }
}

/// $b_i = h\,g_i k_i$ into `b`; returns $(\sum_i b_i, \sum_i b_i d_i)$ (four partial sums
/// each, so the loop vectorises).
#[inline(always)]
fn b_column(b: &mut [f64], g: &[f64], k: &[f64], d: &[f64], h: f64) -> (f64, f64) {
    let (mut sb, mut sbd) = ([0.0; 4], [0.0; 4]);
    let mut b4 = b.chunks_exact_mut(4);
    let (mut g4, mut k4, mut d4) = (g.chunks_exact(4), k.chunks_exact(4), d.chunks_exact(4));
    for (((b, g), k), d) in (&mut b4).zip(&mut g4).zip(&mut k4).zip(&mut d4) {
        for l in 0..4 {
            let v = h * g[l] * k[l];
            b[l] = v;
            sb[l] += v;
            sbd[l] += v * d[l];
        }
    }
    let (mut tb, mut tbd) = (0.0, 0.0);
    for (((b, g), k), d) in b4.into_remainder().iter_mut().zip(g4.remainder()).zip(k4.remainder()).zip(d4.remainder()) {
        *b = h * g * k;
        tb += *b;
        tbd += *b * d;
    }
    ((sb[0] + sb[1]) + (sb[2] + sb[3]) + tb, (sbd[0] + sbd[1]) + (sbd[2] + sbd[3]) + tbd)
}

#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};

    fn setup(n: usize, d: usize, q: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Hyper) {
        let (x, y) = random_problem(n, d, q, seed);
        (x, y, Hyper { rbf_variance: 1.3, lengthscale: 0.9, white_variance: 0.05 })
    }

    /// ∂E_Y/∂X equals central finite differences of E_Y to 1e-7 relative.
    #[test]
    fn grad_x_matches_finite_differences() {
        let (n, d, q) = (25, 6, 3);
        let (x, y, h) = setup(n, d, q, 1);
        let mut lik = Likelihood::new(&y, d, q, LikelihoodConfig::default()).unwrap();
        let mut g = vec![0.0; n * q];
        lik.evaluate(&x, &h, &mut g).unwrap();
        let fd = central_diff(&x, 1e-4, |xp| lik.value(xp, &h).unwrap().0);
        let err = max_rel_err(&g, &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "max relative error {err:e}");
    }

    /// Each hyperparameter gradient, natural and log space, equals central differences.
    #[test]
    fn grad_hyper_matches_finite_differences() {
        let (n, d, q) = (20, 5, 2);
        let (x, y, h) = setup(n, d, q, 2);
        let mut lik = Likelihood::new(&y, d, q, LikelihoodConfig::default()).unwrap();
        let mut g = vec![0.0; n * q];
        let ev = lik.evaluate(&x, &h, &mut g).unwrap();
        let nat = [h.rbf_variance, h.lengthscale, h.white_variance];
        let fd_nat = central_diff(&nat, 1e-4, |p| {
            lik.value(&x, &Hyper { rbf_variance: p[0], lengthscale: p[1], white_variance: p[2] }).unwrap().0
        });
        let err = max_rel_err(&ev.grad_hyper.to_array(), &fd_nat);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "natural: {err:e} {:?} vs {fd_nat:?}", ev.grad_hyper);
        let fd_log =
            central_diff(&h.to_log(), 1e-4, |p| lik.value(&x, &Hyper::from_log([p[0], p[1], p[2]])).unwrap().0);
        let err = max_rel_err(&ev.grad_hyper_log(&h).to_array(), &fd_log);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "log: {err:e}");
    }

    /// With the white-variance floor active the gradient is that of the clamped function:
    /// zero in σ_w², and the floor's r·σ_f² dependence appears in the σ_f² entry.
    #[test]
    fn white_floor_gradient_is_that_of_the_clamped_kernel() {
        let (n, d, q) = (15, 4, 2);
        let (x, y, _) = setup(n, d, q, 3);
        let config = LikelihoodConfig { white_floor: 0.1, ..Default::default() };
        let h = Hyper { rbf_variance: 1.2, lengthscale: 0.7, white_variance: 0.01 };
        let mut lik = Likelihood::new(&y, d, q, config).unwrap();
        let mut g = vec![0.0; n * q];
        let ev = lik.evaluate(&x, &h, &mut g).unwrap();
        assert!(ev.white_clamped && (ev.white_variance_used - 0.12).abs() < 1e-15);
        assert_eq!(ev.grad_hyper.white_variance, 0.0);
        let fd = central_diff(&h.to_log(), 1e-4, |p| lik.value(&x, &Hyper::from_log([p[0], p[1], p[2]])).unwrap().0);
        let err = max_rel_err(&ev.grad_hyper_log(&h).to_array(), &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "{err:e}");
    }

    /// With the absolute floor active (above the relative one) the kernel uses the
    /// constant `white_min`: the gradient is zero in σ_w² and has no floor term in σ_f²;
    /// central differences agree, and above the floor σ_w² is used as given.
    #[test]
    fn absolute_white_floor_gradient_is_that_of_the_clamped_kernel() {
        let (n, d, q) = (15, 4, 2);
        let (x, y, _) = setup(n, d, q, 3);
        let config = LikelihoodConfig { white_floor: 1e-3, white_min: 0.05, ..Default::default() };
        let h = Hyper { rbf_variance: 1.2, lengthscale: 0.7, white_variance: 0.01 };
        let mut lik = Likelihood::new(&y, d, q, config).unwrap();
        let mut g = vec![0.0; n * q];
        let ev = lik.evaluate(&x, &h, &mut g).unwrap();
        assert!(ev.white_clamped && (ev.white_variance_used - 0.05).abs() < 1e-15);
        assert_eq!(ev.grad_hyper.white_variance, 0.0);
        let fd = central_diff(&h.to_log(), 1e-4, |p| lik.value(&x, &Hyper::from_log([p[0], p[1], p[2]])).unwrap().0);
        let err = max_rel_err(&ev.grad_hyper_log(&h).to_array(), &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "{err:e}");
        let above = Hyper { white_variance: 0.2, ..h };
        let ev = lik.evaluate(&x, &above, &mut g).unwrap();
        assert!(!ev.white_clamped && ev.white_variance_used == 0.2);
        assert!(Likelihood::new(&y, d, q, LikelihoodConfig { white_min: -1.0, ..config }).is_err());
    }

    /// σ_f² → 0 leaves white noise only: E_Y = (ND/2) log(2πσ_w²) + ‖Y‖²/(2σ_w²).
    #[test]
    fn closed_form_without_rbf() {
        let (n, d, q) = (12, 3, 2);
        let (x, y, _) = setup(n, d, q, 4);
        let config = LikelihoodConfig { jitter: Jitter::NONE, white_floor: 0.0, white_min: 0.0, par: Par::Seq };
        let mut lik = Likelihood::new(&y, d, q, config).unwrap();
        let h = Hyper { rbf_variance: 1e-300, lengthscale: 1.0, white_variance: 0.3 };
        let (v, _) = lik.value(&x, &h).unwrap();
        let yy: f64 = y.iter().map(|v| v * v).sum();
        let want = 0.5 * (n * d) as f64 * (2.0 * std::f64::consts::PI * 0.3).ln() + yy / 0.6;
        assert!((v - want).abs() < 1e-12 * want.abs(), "{v} vs {want}");
    }

    /// Translation invariance Σ_i ∂E/∂x_i = 0 and rotation invariance (∇_Xᵀ X symmetric).
    #[test]
    fn gradient_invariances() {
        let (n, d, q) = (30, 4, 3);
        let (x, y, h) = setup(n, d, q, 5);
        let mut lik = Likelihood::new(&y, d, q, LikelihoodConfig::default()).unwrap();
        let mut g = vec![0.0; n * q];
        lik.evaluate(&x, &h, &mut g).unwrap();
        let scale: f64 = g.iter().map(|v| v.abs()).sum();
        for k in 0..q {
            let s: f64 = (0..n).map(|i| g[i * q + k]).sum();
            assert!(s.abs() < 1e-12 * scale, "{s}");
        }
        for a in 0..q {
            for b in 0..a {
                let ab: f64 = (0..n).map(|i| g[i * q + a] * x[i * q + b]).sum();
                let ba: f64 = (0..n).map(|i| g[i * q + b] * x[i * q + a]).sum();
                assert!((ab - ba).abs() < 1e-12 * scale, "{ab} {ba}");
            }
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(Likelihood::new(&[1.0, 2.0, 3.0], 2, 1, Default::default()), Err(GplvmError::Shape(_))));
        let mut lik = Likelihood::new(&[1.0, -1.0], 1, 1, Default::default()).unwrap();
        let h = Hyper { rbf_variance: 1.0, lengthscale: -1.0, white_variance: 0.1 };
        assert!(matches!(lik.value(&[0.0, 1.0], &h), Err(GplvmError::Params(_))));
        let h = Hyper { lengthscale: 1.0, ..h };
        assert!(matches!(lik.value(&[0.0], &h), Err(GplvmError::Shape(_))));
        assert!(matches!(lik.value(&[0.0, f64::NAN], &h), Err(GplvmError::NonFinite(_))));
    }
}
