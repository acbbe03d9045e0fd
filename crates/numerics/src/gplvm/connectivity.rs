//! The connectivity prior of Levine et al. 2012 (method.md §3): a graph-diffusion kernel
//! over the latent points whose log entries reward a well-connected embedding.
//!
//! With $\tilde D_{ij} = D_{ij} + \varepsilon$ ($D$ the squared distances), inverse-power
//! weights $W_{ij} = \tilde D_{ij}^{-p/2}$ ($W_{ii} = 0$), degrees $T_{ii} = \sum_j W_{ij}$,
//! $S = T^{-1/2}$, the normalised Laplacian $\tilde L = I - SWS$ and
//! $H = -\tilde L = U\Lambda U^\top$ (ONE symmetric eigendecomposition):
//!
//! $$K_c = \exp(-\beta\tilde L) = U\operatorname{diag}(e^{\beta\lambda_a})U^\top,\qquad
//! E_C = -\psi_C = -w_c\sum_{i,j}\log\max((K_c)_{ij}, 10^{-16}).$$
//!
//! $\beta$ and $w_c$ are optionally scaled with $N$: $\beta N/400$ and $w_c(500/N)^2$
//! (GPCM's `scale_beta`/`scale_weight`, on by default). $\varepsilon = r\cdot$ the mean
//! off-diagonal $D_{ij}$ guards coincident points; method.md suggests the median, the mean
//! is used here because it is differentiable and keeps the prior exactly invariant to
//! scale, so the gradient below includes $\varepsilon$'s dependence on $X$.
//!
//! Gradient, analytic (method.md §3.4): $G_c = w_c[1/K_{ij}]$ (0 where clamped);
//! through the exponential by the Daleckii–Krein formula
//! $M = U[(U^\top G_cU)\circ\Phi]U^\top$ with the divided differences
//! $\Phi_{ab} = \beta e^{\beta\lambda_a}\varphi_1(\beta(\lambda_b-\lambda_a))$,
//! $\varphi_1(z) = \operatorname{expm1}(z)/z$ (stable for close eigenvalues); through the
//! normalisation $e_i = -(M(H+I))_{ii}/T_{ii}$ and, per unordered pair,
//! $A_{ij} = 2(SMS)_{ij} + e_i + e_j$; finally with $C_{ij} = A_{ij}\,c'(\tilde D_{ij})$,
//! $c'(\tilde D) = -\tfrac p2\tilde D^{-p/2-1}$, plus the $\varepsilon$ term,
//! $\nabla_{x_i}\psi_C = 2\sum_j C_{ij}(x_i - x_j)$. The divided differences ARE the
//! exact derivative of the matrix exponential, so the gradient is analytic, not a
//! finite-difference approximation; it costs four $N\times N$ products (two of them
//! computing only a triangle) on top of the eigendecomposition that the value needs.
//!
//! Cost per value+gradient: the eigendecomposition ($\approx 9N^3$ flops) and about
//! $7N^3$ flops of products; memory four $N\times N$ matrices plus faer's scratch.
//!
//! **Subset path** ([`ConnectivityPrior::on_subset`]): the same prior over $m$ chosen
//! rows only — the prior the label would have if it had only those frames ($\beta$ and
//! $w_c$ scaled with $m$, so $w_c(500/m)^2$ keeps the prior's total weight), with zero
//! gradient on the other rows. [`subset_rows`] picks every `stride`-th frame of each
//! segment in time order plus each segment's last frame, so the subsampled trajectories
//! keep their shape and ends. Cost $\approx (m/N)^3$ of the exact path. It is a different
//! function, not an approximation with a vanishing error: the fit uses it as a cheap
//! first stage before the exact prior (see `fit`'s schedule), and its error against the
//! exact prior is measured by `tests/connectivity_paths.rs`.

use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{matmul as tri_matmul, BlockStructure};
use faer::{Accum, Mat, MatMut, Par};

use super::kernel::{columns, pair_grad_pass, sq_dists_below};
use super::params::Scratch;
use super::GplvmError;

/// Parameters of the connectivity prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConnectivityParams {
    /// Exponent $p$ of $W_{ij} = \lVert x_i - x_j\rVert^{-p}$ (default 4, the seed's; GPCM's
    /// default is 2).
    pub power: f64,
    /// Diffusion time $\beta$ (default 1).
    pub beta: f64,
    /// Weight $w_c$ (default 1).
    pub weight: f64,
    /// Use $\beta N/400$ (default on).
    pub scale_beta_with_n: bool,
    /// Use $w_c(500/N)^2$ (default on): the prior then acts on the mean log entry.
    pub scale_weight_with_n: bool,
    /// $\varepsilon$ relative to the mean off-diagonal squared distance (default $10^{-8}$).
    pub epsilon: f64,
    /// Lower clamp on the entries of $K_c$ before the log (default $10^{-16}$, GPCM's).
    pub min_entry: f64,
    /// Parallelism of the eigendecomposition and products.
    pub par: Par,
}

impl Default for ConnectivityParams {
    fn default() -> Self {
        Self {
            power: 4.0,
            beta: 1.0,
            weight: 1.0,
            scale_beta_with_n: true,
            scale_weight_with_n: true,
            epsilon: 1e-8,
            min_entry: 1e-16,
            par: Par::Seq,
        }
    }
}

impl ConnectivityParams {
    /// The $\beta$ used for `n` points.
    pub fn beta_for(&self, n: usize) -> f64 {
        if self.scale_beta_with_n {
            self.beta * n as f64 / 400.0
        } else {
            self.beta
        }
    }

    /// The $w_c$ used for `n` points.
    pub fn weight_for(&self, n: usize) -> f64 {
        if self.scale_weight_with_n {
            self.weight * (500.0 / n as f64).powi(2)
        } else {
            self.weight
        }
    }

    fn check(&self) -> Result<(), GplvmError> {
        let ok = self.power.is_finite()
            && self.power > 0.0
            && self.beta.is_finite()
            && self.beta > 0.0
            && self.weight.is_finite()
            && self.weight >= 0.0
            && self.epsilon.is_finite()
            && self.epsilon >= 0.0
            && self.min_entry.is_finite()
            && self.min_entry > 0.0;
        if ok {
            Ok(())
        } else {
            Err(GplvmError::Params(format!("invalid connectivity parameters {self:?}")))
        }
    }
}

/// One evaluation of the connectivity prior.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConnectivityEval {
    /// $E_C = -\psi_C$.
    pub value: f64,
    /// $\beta$ after the $N$ scaling.
    pub beta: f64,
    /// $w_c$ after the $N$ scaling.
    pub weight: f64,
    /// The absolute $\varepsilon$ added to every squared distance.
    pub epsilon: f64,
    /// Entries of $K_c$ (counting both triangles) raised to `min_entry`.
    pub clamped: usize,
}

/// The rows of a [`ConnectivityPrior::on_subset`]: per segment (rows with equal ids, in
/// order of `times`), every `stride`-th row from the first, and the last. `stride = 1`
/// is every row.
pub fn subset_rows(times: &[f64], segments: &[i64], stride: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..times.len()).collect();
    order.sort_by(|&a, &b| segments[a].cmp(&segments[b]).then(times[a].total_cmp(&times[b])));
    let mut rows = Vec::new();
    for run in order.chunk_by(|&a, &b| segments[a] == segments[b]) {
        rows.extend(run.iter().step_by(stride.max(1)));
        if (run.len() - 1) % stride.max(1) != 0 {
            rows.push(run[run.len() - 1]);
        }
    }
    rows.sort_unstable();
    rows
}

/// Workspace of the connectivity prior for `N` points in `q` dimensions.
#[derive(Debug)]
pub struct ConnectivityPrior {
    /// Points the prior is computed over (N, or m on a subset).
    n: usize,
    /// Rows of the input (N).
    n_full: usize,
    /// The subset's rows, if any.
    rows: Option<Vec<usize>>,
    xs: Vec<f64>,
    gs: Vec<f64>,
    q: usize,
    params: ConnectivityParams,
    w: Mat<f64>,
    u: Mat<f64>,
    b1: Mat<f64>,
    b2: Mat<f64>,
    lambda: Mat<f64>,
    s: Vec<f64>,
    t: Vec<f64>,
    e: Vec<f64>,
    xc: Vec<f64>,
    dist: Vec<f64>,
    bcol: Vec<f64>,
    gx: Vec<f64>,
    mem: Scratch,
}

impl ConnectivityPrior {
    /// A workspace for `n ≥ 2` points of dimension `q`.
    pub fn new(n: usize, q: usize, params: ConnectivityParams) -> Result<Self, GplvmError> {
        params.check()?;
        if n < 2 || q == 0 {
            return Err(GplvmError::Shape(format!("connectivity prior needs N >= 2 and q >= 1, got {n} and {q}")));
        }
        let scratch = self_adjoint_evd_scratch::<f64>(n, ComputeEigenvectors::Yes, params.par, Default::default());
        Ok(Self {
            n,
            n_full: n,
            rows: None,
            xs: vec![],
            gs: vec![],
            q,
            params,
            w: Mat::zeros(n, n),
            u: Mat::zeros(n, n),
            b1: Mat::zeros(n, n),
            b2: Mat::zeros(n, n),
            lambda: Mat::zeros(n, 1),
            s: vec![0.0; n],
            t: vec![0.0; n],
            e: vec![0.0; n],
            xc: Vec::with_capacity(n * q),
            dist: vec![0.0; n],
            bcol: vec![0.0; n],
            gx: vec![0.0; n * q],
            mem: Scratch::new(scratch),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &ConnectivityParams {
        &self.params
    }

    /// The prior over the rows `rows` (distinct, each `< n`) of an `n`-row input only
    /// (see the module docs).
    pub fn on_subset(n: usize, rows: Vec<usize>, q: usize, params: ConnectivityParams) -> Result<Self, GplvmError> {
        let mut seen = vec![false; n];
        for &r in &rows {
            if r >= n || std::mem::replace(&mut seen[r], true) {
                return Err(GplvmError::Shape(format!("subset row {r} repeated or not below N = {n}")));
            }
        }
        let mut prior = Self::new(rows.len(), q, params)?;
        prior.n_full = n;
        prior.xs = vec![0.0; rows.len() * q];
        prior.gs = vec![0.0; rows.len() * q];
        prior.rows = Some(rows);
        Ok(prior)
    }

    /// Number of rows $N$ of the input.
    pub fn n(&self) -> usize {
        self.n_full
    }

    /// Number of points the prior is computed over ($N$, or $m$ on a subset).
    pub fn points(&self) -> usize {
        self.n
    }

    /// Checks `x`'s length and, on a subset, gathers its rows into `xs`.
    fn gather(&mut self, x: &[f64]) -> Result<(), GplvmError> {
        let q = self.q;
        if x.len() != self.n_full * q {
            return Err(GplvmError::Shape(format!("x has {} values, expected N·q = {}·{q}", x.len(), self.n_full)));
        }
        if let Some(rows) = &self.rows {
            for (dst, &r) in self.xs.chunks_exact_mut(q).zip(rows) {
                dst.copy_from_slice(&x[r * q..(r + 1) * q]);
            }
        }
        Ok(())
    }

    /// Weights, eigendecomposition, the lower triangle of $K_c$ in `b2`, and the value, at
    /// the (gathered) input.
    fn value_pass(&mut self, x: &[f64]) -> Result<ConnectivityEval, GplvmError> {
        self.gather(x)?;
        if self.rows.is_some() {
            let xs = std::mem::take(&mut self.xs);
            let r = self.value_points(&xs);
            self.xs = xs;
            r
        } else {
            self.value_points(x)
        }
    }

    /// [`Self::value_pass`] on the `points × q` coordinates `x`.
    fn value_points(&mut self, x: &[f64]) -> Result<ConnectivityEval, GplvmError> {
        let (n, q) = (self.n, self.q);
        if x.iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("latent coordinate"));
        }
        let par = self.params.par;
        let beta = self.params.beta_for(n);
        let weight = self.params.weight_for(n);
        let half_p = 0.5 * self.params.power;
        columns(x, n, q, &mut self.xc);
        // Mean off-diagonal squared distance: Σ_{i<j} D_ij = N Σ_i ‖x_i − x̄‖².
        let mut spread = 0.0;
        for k in 0..q {
            let col = &self.xc[k * n..(k + 1) * n];
            let m = col.iter().sum::<f64>() / n as f64;
            spread += col.iter().map(|v| (v - m) * (v - m)).sum::<f64>();
        }
        let mean_d = 2.0 * spread / (n - 1) as f64;
        if mean_d <= 0.0 {
            return Err(GplvmError::Params("connectivity prior: all latent points coincide".into()));
        }
        let epsilon = self.params.epsilon * mean_d;
        // W (strict lower triangle) and degrees.
        self.t.fill(0.0);
        for j in 0..n {
            sq_dists_below(&self.xc, n, q, j, &mut self.dist);
            let wcol = self.w.col_as_slice_mut(j);
            wcol[j] = 0.0;
            let mut tj = 0.0;
            for (i, (wv, dd)) in wcol.iter_mut().zip(&self.dist[..n]).enumerate().skip(j + 1) {
                *wv = inv_pow(dd + epsilon, half_p);
                tj += *wv;
                self.t[i] += *wv;
            }
            self.t[j] += tj;
        }
        for (s, t) in self.s.iter_mut().zip(&self.t) {
            *s = 1.0 / t.sqrt();
        }
        // H = S W S − I (lower triangle) in b1.
        for j in 0..n {
            let wcol = self.w.col_as_slice(j);
            let hcol = self.b1.col_as_slice_mut(j);
            hcol[j] = -1.0;
            let sj = self.s[j];
            for ((h, wv), si) in hcol[j + 1..].iter_mut().zip(&wcol[j + 1..]).zip(&self.s[j + 1..]) {
                *h = si * wv * sj;
            }
        }
        let stack = self.mem.stack();
        self_adjoint_evd(
            self.b1.as_ref(),
            self.lambda.as_mut().col_mut(0).as_diagonal_mut(),
            Some(self.u.as_mut()),
            par,
            stack,
            Default::default(),
        )
        .map_err(|_| GplvmError::Eigen)?;
        // K_c = (U diag(e^{βλ})) Uᵀ, lower triangle, in b2.
        for a in 0..n {
            let ea = (beta * self.lambda[(a, 0)]).exp();
            self.e[a] = ea;
            let src = self.u.col_as_slice(a);
            for (dst, v) in self.b1.col_as_slice_mut(a).iter_mut().zip(src) {
                *dst = v * ea;
            }
        }
        lower_times(&mut self.b2, &self.b1, self.u.transpose(), par);
        let min = self.params.min_entry;
        let (mut sum_log, mut clamped) = (0.0, 0usize);
        for j in 0..n {
            let col = self.b2.col_as_slice(j);
            for (i, k) in col.iter().enumerate().skip(j) {
                let mult = if i == j { 1 } else { 2 };
                if *k < min {
                    clamped += mult;
                    sum_log += mult as f64 * min.ln();
                } else {
                    sum_log += mult as f64 * k.ln();
                }
            }
        }
        let value = -weight * sum_log;
        if !value.is_finite() {
            return Err(GplvmError::NonFinite("connectivity prior"));
        }
        Ok(ConnectivityEval { value, beta, weight, epsilon, clamped })
    }

    /// $E_C(X)$ alone (the eigendecomposition and one product).
    pub fn value(&mut self, x: &[f64]) -> Result<ConnectivityEval, GplvmError> {
        self.value_pass(x)
    }

    /// The full symmetric heat kernel $K_c$ at `x` (before the clamp), for diagnostics.
    pub fn heat_kernel(&mut self, x: &[f64]) -> Result<Mat<f64>, GplvmError> {
        self.value_pass(x)?;
        let mut k = self.b2.clone();
        mirror_lower(k.as_mut());
        Ok(k)
    }

    /// Returns $E_C$ and **adds** $\nabla_X E_C$ to `grad` (row-major `N × q`).
    pub fn value_grad_add(&mut self, x: &[f64], grad: &mut [f64]) -> Result<ConnectivityEval, GplvmError> {
        let q = self.q;
        if grad.len() != self.n_full * q {
            return Err(GplvmError::Shape(format!("grad has {} values, expected {}", grad.len(), self.n_full * q)));
        }
        self.gather(x)?;
        let Some(rows) = self.rows.take() else {
            return self.grad_points(x, grad);
        };
        let (xs, mut gs) = (std::mem::take(&mut self.xs), std::mem::take(&mut self.gs));
        gs.fill(0.0);
        let r = self.grad_points(&xs, &mut gs);
        for (g, &row) in gs.chunks_exact(q).zip(&rows) {
            grad[row * q..(row + 1) * q].iter_mut().zip(g).for_each(|(a, b)| *a += b);
        }
        (self.xs, self.gs, self.rows) = (xs, gs, Some(rows));
        r
    }

    /// [`Self::value_grad_add`] on the `points × q` coordinates `x`.
    fn grad_points(&mut self, x: &[f64], grad: &mut [f64]) -> Result<ConnectivityEval, GplvmError> {
        let (n, q) = (self.n, self.q);
        let eval = self.value_points(x)?;
        let par = self.params.par;
        let (beta, weight, epsilon) = (eval.beta, eval.weight, eval.epsilon);
        let min = self.params.min_entry;
        // G_c = w / K (0 where clamped), full symmetric, in b2.
        for j in 0..n {
            for k in self.b2.col_as_slice_mut(j)[j..].iter_mut() {
                *k = if *k < min { 0.0 } else { weight / *k };
            }
        }
        mirror_lower(self.b2.as_mut());
        // Ψ = (Uᵀ G_c) U, lower; then Ψ ∘ Φ, mirrored.
        matmul(self.b1.as_mut(), Accum::Replace, self.u.transpose(), self.b2.as_ref(), 1.0, par);
        lower_times(&mut self.b2, &self.b1, self.u.as_ref(), par);
        for b in 0..n {
            let lb = self.lambda[(b, 0)];
            let eb = self.e[b];
            let col = self.b2.col_as_slice_mut(b);
            for (a, v) in col.iter_mut().enumerate().skip(b) {
                let z = beta * (self.lambda[(a, 0)] - lb);
                *v *= beta * eb * phi1(z);
            }
        }
        mirror_lower(self.b2.as_mut());
        // M = (U Ψ∘Φ) Uᵀ, lower, in b2.
        matmul(self.b1.as_mut(), Accum::Replace, self.u.as_ref(), self.b2.as_ref(), 1.0, par);
        lower_times(&mut self.b2, &self.b1, self.u.transpose(), par);
        // e_i = −(M(H+I))_ii / T_ii with (H+I) = SWS, W_ii = 0.
        let mut r = std::mem::take(&mut self.e);
        r.fill(0.0);
        for j in 0..n {
            let (mcol, wcol) = (self.b2.col_as_slice(j), self.w.col_as_slice(j));
            let sj = self.s[j];
            let mut rj = 0.0;
            for (i, ((m, wv), si)) in mcol.iter().zip(wcol).zip(&self.s).enumerate().skip(j + 1) {
                let v = m * wv * si * sj;
                r[i] += v;
                rj += v;
            }
            r[j] += rj;
        }
        for (ri, ti) in r.iter_mut().zip(&self.t) {
            *ri = -*ri / ti;
        }
        // Per pair: C_ij = (2 s_i M_ij s_j + e_i + e_j) c'(D̃_ij), stored in the lower triangle of w.
        let half_p = 0.5 * self.params.power;
        let mut d_eps = 0.0;
        for j in 0..n {
            sq_dists_below(&self.xc, n, q, j, &mut self.dist);
            let mcol = self.b2.col_as_slice(j);
            let wcol = self.w.col_as_slice_mut(j);
            let (sj, ej) = (self.s[j], r[j]);
            for ((((wv, m), si), ei), dd) in wcol[j + 1..]
                .iter_mut()
                .zip(&mcol[j + 1..])
                .zip(&self.s[j + 1..])
                .zip(&r[j + 1..])
                .zip(&self.dist[j + 1..n])
            {
                let a = 2.0 * si * m * sj + ei + ej;
                let c = a * (-half_p * *wv / (dd + epsilon));
                *wv = c;
                d_eps += c;
            }
        }
        // ε = r_ε · mean_{i<j} D_ij: every pair's D also moves ε.
        let shift = d_eps * self.params.epsilon * 2.0 / (n * (n - 1)) as f64;
        // ∇ψ_i = 2 Σ_j C'_ij (x_i − x_j); E_C = −ψ_C.
        self.gx.fill(0.0);
        for j in 0..n {
            let ccol = self.w.col_as_slice(j);
            for (b, c) in self.bcol[j + 1..].iter_mut().zip(&ccol[j + 1..]) {
                *b = c + shift;
            }
            pair_grad_pass(&self.xc, &mut self.gx, n, q, j, &self.bcol);
        }
        self.e = r;
        for i in 0..n {
            for k in 0..q {
                let g = -2.0 * self.gx[k * n + i];
                if !g.is_finite() {
                    return Err(GplvmError::NonFinite("connectivity gradient"));
                }
                grad[i * q + k] += g;
            }
        }
        Ok(eval)
    }
}

/// $v^{-s}$, with integer powers exact.
#[inline]
fn inv_pow(v: f64, s: f64) -> f64 {
    if s == 2.0 {
        1.0 / (v * v)
    } else if s == 1.0 {
        1.0 / v
    } else {
        v.powf(-s)
    }
}

/// $\varphi_1(z) = (e^z - 1)/z$, with $\varphi_1(0) = 1$.
#[inline]
fn phi1(z: f64) -> f64 {
    if z.abs() < 1e-8 {
        1.0 + 0.5 * z
    } else {
        z.exp_m1() / z
    }
}

/// Copies the strict lower triangle onto the upper one.
fn mirror_lower(mut m: MatMut<'_, f64>) {
    let n = m.nrows();
    for j in 0..n {
        for i in j + 1..n {
            let v = m[(i, j)];
            m[(j, i)] = v;
        }
    }
}

/// `dst ← lower(a · b)`: only the lower triangle of the (symmetric) product is formed.
fn lower_times(dst: &mut Mat<f64>, a: &Mat<f64>, b: faer::MatRef<'_, f64>, par: Par) {
    tri_matmul(
        dst.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        a.as_ref(),
        BlockStructure::Rectangular,
        b,
        BlockStructure::Rectangular,
        1.0,
        par,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};

    fn params(power: f64, beta: f64) -> ConnectivityParams {
        ConnectivityParams { power, beta, weight: 0.8, ..Default::default() }
    }

    /// The analytic gradient equals central finite differences (1e-7 relative), for p = 4
    /// and p = 2 and a non-integer p, and a β that makes the kernel far from identity.
    #[test]
    fn gradient_matches_finite_differences() {
        for (power, beta, seed) in [(4.0, 2.0 * 400.0 / 12.0, 21), (2.0, 1.0, 22), (3.3, 40.0, 23)] {
            let (n, q) = (12, 3);
            let (x, _) = random_problem(n, 1, q, seed);
            let mut prior = ConnectivityPrior::new(n, q, params(power, beta)).unwrap();
            let mut g = vec![0.0; n * q];
            let ev = prior.value_grad_add(&x, &mut g).unwrap();
            assert_eq!(ev.clamped, 0);
            let fd = central_diff(&x, 1e-4, |xp| prior.value(xp).unwrap().value);
            let err = max_rel_err(&g, &fd);
            eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
            assert!(err < 1e-7, "p = {power}: {err:e}");
        }
    }

    /// Exactly degenerate eigenvalues (two concentric regular hexagons have the dihedral
    /// symmetry, so their graph has repeated eigenvalues) do not spoil the gradient: the
    /// φ₁ form of the divided differences stays accurate where (e^a − e^b)/(a − b) would
    /// cancel catastrophically. The radial gradient is nonzero, so the check has teeth.
    #[test]
    fn gradient_with_degenerate_spectrum() {
        let m = 6;
        let x: Vec<f64> = (0..2 * m)
            .flat_map(|i| {
                let a = std::f64::consts::TAU * (i % m) as f64 / m as f64;
                let r = if i < m { 1.0 } else { 2.0 };
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let mut prior = ConnectivityPrior::new(2 * m, 2, params(4.0, 60.0)).unwrap();
        let mut g = vec![0.0; 4 * m];
        prior.value_grad_add(&x, &mut g).unwrap();
        let lambda: Vec<f64> = (0..2 * m).map(|a| prior.lambda[(a, 0)]).collect();
        let repeated = lambda.windows(2).filter(|w| (w[1] - w[0]).abs() < 1e-12).count();
        assert!(repeated >= 2, "expected repeated eigenvalues, got {lambda:?}");
        let fd = central_diff(&x, 1e-4, |xp| prior.value(xp).unwrap().value);
        let err = max_rel_err(&g, &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "{err:e}");
        assert!(g.iter().map(|v| v.abs()).fold(0.0, f64::max) > 1e-3, "gradient should not vanish: {g:?}");
    }

    /// A reference matrix exponential of −β L̃ (scaling and squaring of a Taylor series)
    /// equals K_c to 1e-12, and K_c v₀ = v₀ for v₀ = T^{1/2} 1.
    #[test]
    fn heat_kernel_matches_reference_expm() {
        let (n, q) = (9, 2);
        let (x, _) = random_problem(n, 1, q, 24);
        let p = ConnectivityParams { scale_beta_with_n: false, beta: 1.7, epsilon: 0.0, ..Default::default() };
        let mut prior = ConnectivityPrior::new(n, q, p).unwrap();
        let kc = prior.heat_kernel(&x).unwrap();
        // −β L̃ = β(SWS − I), from the definition.
        let w = |i: usize, j: usize| {
            if i == j {
                0.0
            } else {
                let d = crate::gplvm::kernel::sq_dist(&x[i * q..(i + 1) * q], &x[j * q..(j + 1) * q]);
                1.0 / (d * d)
            }
        };
        let t: Vec<f64> = (0..n).map(|i| (0..n).map(|j| w(i, j)).sum()).collect();
        let a =
            Mat::<f64>::from_fn(n, n, |i, j| 1.7 * (w(i, j) / (t[i] * t[j]).sqrt() - if i == j { 1.0 } else { 0.0 }));
        let reference = expm_reference(&a);
        let err = (0..n).flat_map(|i| (0..n).map(move |j| (i, j))).map(|(i, j)| (kc[(i, j)] - reference[(i, j)]).abs());
        let err = err.fold(0.0, f64::max);
        assert!(err < 1e-12, "{err:e}");
        for i in 0..n {
            let kv: f64 = (0..n).map(|j| kc[(i, j)] * t[j].sqrt()).sum();
            assert!((kv - t[i].sqrt()).abs() < 1e-12 * t[i].sqrt(), "row {i}");
        }
    }

    /// exp(A) by scaling and squaring a 30-term Taylor series (reference for tiny N).
    fn expm_reference(a: &Mat<f64>) -> Mat<f64> {
        let n = a.nrows();
        let norm = (0..n).map(|i| (0..n).map(|j| a[(i, j)].abs()).sum::<f64>()).fold(0.0, f64::max);
        let sq = (norm.max(1.0).log2().ceil() as i32 + 4).max(0);
        let scaled = a * faer::Scale(0.5f64.powi(sq));
        let mut sum = Mat::<f64>::identity(n, n);
        let mut term = Mat::<f64>::identity(n, n);
        for k in 1..30 {
            term = &term * &scaled * faer::Scale(1.0 / k as f64);
            sum += &term;
        }
        for _ in 0..sq {
            sum = &sum * &sum;
        }
        sum
    }

    /// ψ_C is invariant to scale, rotation and shift, so Σ_i ∇_i = 0 and Σ_i x_iᵀ∇_i = 0.
    #[test]
    fn invariances() {
        let (n, q) = (15, 3);
        let (x, _) = random_problem(n, 1, q, 25);
        let mut prior = ConnectivityPrior::new(n, q, params(4.0, 1.0)).unwrap();
        let mut g = vec![0.0; n * q];
        let v0 = prior.value_grad_add(&x, &mut g).unwrap().value;
        // Rotation about the z axis by 0.4 rad, scale 3.7, shift +1.
        let (c, s) = (0.4f64.cos(), 0.4f64.sin());
        let moved: Vec<f64> = x
            .chunks(q)
            .flat_map(|r| [3.7 * (c * r[0] - s * r[1]) + 1.0, 3.7 * (s * r[0] + c * r[1]) + 1.0, 3.7 * r[2] + 1.0])
            .collect();
        let v1 = prior.value(&moved).unwrap().value;
        assert!((v0 - v1).abs() < 1e-12 * v0.abs(), "{v0} {v1}");
        let scale: f64 = g.iter().map(|v| v.abs()).sum();
        for k in 0..q {
            let sum: f64 = (0..n).map(|i| g[i * q + k]).sum();
            assert!(sum.abs() < 1e-12 * scale, "translation {k}: {sum:e}");
        }
        let radial: f64 = g.iter().zip(&x).map(|(g, x)| g * x).sum();
        assert!(radial.abs() < 1e-12 * scale, "homogeneity {radial:e}");
    }

    /// Two separated clusters: descending E_C alone brings them together relative to
    /// their size (the ratio of centroid distance to within-cluster spread falls).
    #[test]
    fn descent_pulls_clusters_together() {
        let (n, q) = (20, 2);
        let (noise, _) = random_problem(n, 1, q, 26);
        let mut x: Vec<f64> =
            (0..n).flat_map(|i| [noise[i * q] + if i < 10 { -4.0 } else { 4.0 }, noise[i * q + 1]]).collect();
        let ratio = |x: &[f64]| {
            let c = |r: std::ops::Range<usize>| {
                let m = r.len() as f64;
                let cx = r.clone().map(|i| x[i * 2]).sum::<f64>() / m;
                let cy = r.clone().map(|i| x[i * 2 + 1]).sum::<f64>() / m;
                let spread = r.map(|i| (x[i * 2] - cx).powi(2) + (x[i * 2 + 1] - cy).powi(2)).sum::<f64>() / m;
                (cx, cy, spread)
            };
            let (a, b) = (c(0..10), c(10..20));
            ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt() / (0.5 * (a.2 + b.2)).sqrt()
        };
        let before = ratio(&x);
        let mut prior = ConnectivityPrior::new(n, q, ConnectivityParams::default()).unwrap();
        let v_before = prior.value(&x).unwrap().value;
        for _ in 0..30 {
            let mut g = vec![0.0; n * q];
            prior.value_grad_add(&x, &mut g).unwrap();
            let gmax = g.iter().map(|v| v.abs()).fold(0.0, f64::max);
            x.iter_mut().zip(&g).for_each(|(x, g)| *x -= 0.05 * g / gmax);
        }
        let after = ratio(&x);
        let v_after = prior.value(&x).unwrap().value;
        assert!(v_after < v_before, "{v_before} -> {v_after}");
        assert!(after < 0.9 * before, "centroid distance / spread: {before} -> {after}");
    }

    /// The subset path: the value is the prior of the gathered rows alone, the gradient
    /// matches central differences on the full input (1e-7), and rows outside the subset
    /// get none.
    #[test]
    fn subset_gradient_matches_finite_differences() {
        let (n, q) = (23, 3);
        let (x, _) = random_problem(n, 1, q, 27);
        let times: Vec<f64> = (0..n).map(|i| (i % 12) as f64).collect();
        let segs: Vec<i64> = (0..n).map(|i| (i / 12) as i64).collect();
        let rows = subset_rows(&times, &segs, 3);
        assert_eq!(rows, [0, 3, 6, 9, 11, 12, 15, 18, 21, 22]);
        let mut sub = ConnectivityPrior::on_subset(n, rows.clone(), q, params(4.0, 30.0)).unwrap();
        let mut g = vec![0.0; n * q];
        let ev = sub.value_grad_add(&x, &mut g).unwrap();
        let gathered: Vec<f64> = rows.iter().flat_map(|&r| x[r * q..(r + 1) * q].to_vec()).collect();
        let mut alone = ConnectivityPrior::new(rows.len(), q, params(4.0, 30.0)).unwrap();
        assert_eq!(alone.value(&gathered).unwrap().value, ev.value);
        let fd = central_diff(&x, 1e-4, |xp| sub.value(xp).unwrap().value);
        let err = max_rel_err(&g, &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "{err:e}");
        assert!((0..n).filter(|i| !rows.contains(i)).all(|i| g[i * q..(i + 1) * q].iter().all(|v| *v == 0.0)));
        assert!(ConnectivityPrior::on_subset(n, vec![1, 1], q, params(4.0, 1.0)).is_err());
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(ConnectivityPrior::new(1, 2, ConnectivityParams::default()).is_err());
        let bad = ConnectivityParams { beta: 0.0, ..Default::default() };
        assert!(matches!(ConnectivityPrior::new(5, 2, bad), Err(GplvmError::Params(_))));
        let mut p = ConnectivityPrior::new(3, 1, ConnectivityParams::default()).unwrap();
        assert!(matches!(p.value(&[1.0, 1.0, 1.0]), Err(GplvmError::Params(_))));
    }
}
