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
//!
//! **Coarse path** ([`ConnectivityPrior::coarse`]): the heat kernel of a coarse graph
//! whose nodes are runs of consecutive frames ([`coarse_groups`]), prolonged back to every
//! frame. With $R$ the $N\times m$ 0/1 matrix of the groups, the coarse weights are the
//! fine ones summed, $W^c = R^\top W R$ — a group's inner pairs become its self-loop
//! $W^c_{aa}$ — with degrees $T^c = R^\top T$; $K^c = \exp(\beta(T_c^{-1/2}W^cT_c^{-1/2} - I))$
//! with the fine $\beta$, and every fine pair takes its nodes' entry shared equally,
//! $K_{ij} = K^c_{ab}/\sqrt{n_an_b}$ ($i \in a$, $j \in b$, $n_a$ the group sizes), so
//! $E_C = -w_c\sum_{ab} n_an_b\log(K^c_{ab}/\sqrt{n_an_b})$ over all $N^2$ fine pairs.
//! Every frame keeps its own weights and so its own gradient: by the chain rule through
//! $W^c$, the per-pair factor of the exact gradient becomes
//! $A_{ij} = 2s_aM_{ab}s_b + e_a + e_b$ of the coarse graph's $M$ and $e$, and the rest is
//! the exact path's $O(N^2q)$ pass. The eigenproblem has $m \approx N/k$ nodes for runs of
//! $k$, so the cost is $\approx k^{-3}$ of the exact path's plus $O(N^2)$. It is an
//! approximation of the exact prior (its error and its effect on the fit are measured in
//! `tests/gplvm_timing.rs` and docs/method.md); with runs of one frame it *is* the exact prior.

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

/// `count` rows of a [`ConnectivityPrior::on_subset`] spread evenly over all the rows in
/// order of segment and time: the $\lfloor (k + \frac12)N/\text{count}\rfloor$-th, so the
/// subset's size, and its prior's cost, do not grow with $N$ or with the number of
/// segments. All rows when `count` ≥ N.
pub fn spread_rows(times: &[f64], segments: &[i64], count: usize) -> Vec<usize> {
    let n = times.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| segments[a].cmp(&segments[b]).then(times[a].total_cmp(&times[b])));
    let count = count.min(n);
    let mut rows: Vec<usize> =
        (0..count).map(|k| order[((k as f64 + 0.5) * n as f64 / count as f64) as usize]).collect();
    rows.sort_unstable();
    rows
}

/// Consecutive frames merged into one node of the coarse graph (see the module docs).
#[derive(Debug, Clone)]
struct Coarsening {
    /// $n_a$, the number of fine points in each group.
    size: Vec<f64>,
    /// Coarse weights $W^c = R^\top W R$ (lower triangle and diagonal).
    wc: Mat<f64>,
}

/// The groups of a [`ConnectivityPrior::coarse`]: per segment (rows with equal ids, in
/// order of `times`), runs of `size` consecutive frames (the last run of a segment may be
/// shorter). Returns the group of each row, groups numbered in order of segment and time.
pub fn coarse_groups(times: &[f64], segments: &[i64], size: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..times.len()).collect();
    order.sort_by(|&a, &b| segments[a].cmp(&segments[b]).then(times[a].total_cmp(&times[b])));
    let mut group = vec![0; times.len()];
    let mut next = 0;
    for run in order.chunk_by(|&a, &b| segments[a] == segments[b]) {
        for chunk in run.chunks(size.max(1)) {
            chunk.iter().for_each(|&r| group[r] = next);
            next += 1;
        }
    }
    group
}

/// Workspace of the connectivity prior for `N` points in `q` dimensions.
#[derive(Debug)]
pub struct ConnectivityPrior {
    /// Points the prior is computed over (N, or m on a subset).
    points: usize,
    /// Rows of the input (N).
    n_full: usize,
    /// Size of the eigenproblem: the points, or the coarse graph's nodes.
    m: usize,
    /// The subset's rows, if any.
    rows: Option<Vec<usize>>,
    /// The coarse graph, if any.
    coarse: Option<Coarsening>,
    /// Node of the eigenproblem of each point (the point itself without coarsening).
    node: Vec<usize>,
    xs: Vec<f64>,
    gs: Vec<f64>,
    q: usize,
    params: ConnectivityParams,
    /// Fine weights (points × points, lower triangle).
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
        Self::with_spectral_size(n, n, q, params)
    }

    /// A workspace for `n` points whose eigenproblem has size `m`.
    fn with_spectral_size(n: usize, m: usize, q: usize, params: ConnectivityParams) -> Result<Self, GplvmError> {
        params.check()?;
        if n < 2 || m < 2 || q == 0 {
            return Err(GplvmError::Shape(format!(
                "connectivity prior needs N >= 2 points in >= 2 nodes and q >= 1, got {n}, {m} and {q}"
            )));
        }
        let scratch = self_adjoint_evd_scratch::<f64>(m, ComputeEigenvectors::Yes, params.par, Default::default());
        Ok(Self {
            points: n,
            n_full: n,
            m,
            rows: None,
            coarse: None,
            node: (0..n).collect(),
            xs: vec![],
            gs: vec![],
            q,
            params,
            w: Mat::zeros(n, n),
            u: Mat::zeros(m, m),
            b1: Mat::zeros(m, m),
            b2: Mat::zeros(m, m),
            lambda: Mat::zeros(m, 1),
            s: vec![0.0; m],
            t: vec![0.0; m],
            e: vec![0.0; m],
            xc: Vec::with_capacity(n * q),
            dist: vec![0.0; n],
            bcol: vec![0.0; n],
            gx: vec![0.0; n * q],
            mem: Scratch::new(scratch),
        })
    }

    /// The coarse-graph prior over `n` points (see the module docs): `group[i]` is the
    /// coarse node of point `i`; the groups must be numbered `0..m` with none empty.
    pub fn coarse(group: Vec<usize>, q: usize, params: ConnectivityParams) -> Result<Self, GplvmError> {
        let n = group.len();
        let m = group.iter().max().map_or(0, |g| g + 1);
        let mut size = vec![0.0; m];
        group.iter().for_each(|&g| size[g] += 1.0);
        if let Some(a) = size.iter().position(|&c| c == 0.0) {
            return Err(GplvmError::Shape(format!("coarse group {a} of 0..{m} has no point")));
        }
        let mut prior = Self::with_spectral_size(n, m, q, params)?;
        prior.coarse = Some(Coarsening { size, wc: Mat::zeros(m, m) });
        prior.node = group;
        Ok(prior)
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
        self.points
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
        let (n, m, q) = (self.points, self.m, self.q);
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
            let mean = col.iter().sum::<f64>() / n as f64;
            spread += col.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>();
        }
        let mean_d = 2.0 * spread / (n - 1) as f64;
        if mean_d <= 0.0 {
            return Err(GplvmError::Params("connectivity prior: all latent points coincide".into()));
        }
        let epsilon = self.params.epsilon * mean_d;
        // Fine W (strict lower triangle); on the coarse graph W^c = RᵀWR (lower and
        // diagonal, a group's inner pairs counted in both orders), else the fine degrees.
        self.t.fill(0.0);
        if let Some(c) = self.coarse.as_mut() {
            c.wc.fill(0.0);
        }
        for j in 0..n {
            sq_dists_below(&self.xc, n, q, j, &mut self.dist);
            let wcol = self.w.col_as_slice_mut(j);
            wcol[j] = 0.0;
            for (wv, dd) in wcol[j + 1..].iter_mut().zip(&self.dist[j + 1..n]) {
                *wv = inv_pow(dd + epsilon, half_p);
            }
            match self.coarse.as_mut() {
                Some(c) => {
                    let b = self.node[j];
                    for (wv, &a) in wcol[j + 1..].iter().zip(&self.node[j + 1..]) {
                        let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
                        c.wc[(hi, lo)] += if a == b { 2.0 * wv } else { *wv };
                    }
                }
                None => {
                    let mut tj = 0.0;
                    for (ti, wv) in self.t[j + 1..].iter_mut().zip(&wcol[j + 1..]) {
                        tj += wv;
                        *ti += wv;
                    }
                    self.t[j] += tj;
                }
            }
        }
        // The graph of the eigenproblem: the fine W or W^c, with their degrees.
        let wsp = match self.coarse.as_ref() {
            Some(c) => {
                self.t.fill(0.0);
                for b in 0..m {
                    let col = c.wc.col_as_slice(b);
                    self.t[b] += col[b];
                    for (a, v) in col.iter().enumerate().skip(b + 1) {
                        self.t[a] += v;
                        self.t[b] += v;
                    }
                }
                &c.wc
            }
            None => &self.w,
        };
        for (s, t) in self.s.iter_mut().zip(&self.t) {
            *s = 1.0 / t.sqrt();
        }
        // H = S W S − I (lower triangle) in b1.
        for j in 0..m {
            let wcol = wsp.col_as_slice(j);
            let hcol = self.b1.col_as_slice_mut(j);
            let sj = self.s[j];
            for ((h, wv), si) in hcol[j..].iter_mut().zip(&wcol[j..]).zip(&self.s[j..]) {
                *h = si * wv * sj;
            }
            hcol[j] -= 1.0;
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
        // K = (U diag(e^{βλ})) Uᵀ, lower triangle, in b2.
        for a in 0..m {
            let ea = (beta * self.lambda[(a, 0)]).exp();
            self.e[a] = ea;
            let src = self.u.col_as_slice(a);
            for (dst, v) in self.b1.col_as_slice_mut(a).iter_mut().zip(src) {
                *dst = v * ea;
            }
        }
        lower_times(&mut self.b2, &self.b1, self.u.transpose(), par);
        // Σ_ij log K_ij over the fine pairs: on the coarse graph K_ij = K^c_ab / √(n_a n_b),
        // so node pair (a, b) stands for n_a n_b fine pairs.
        let min = self.params.min_entry;
        let (mut logs, mut clamped) = (LogProduct::default(), 0.0);
        for j in 0..m {
            let col = self.b2.col_as_slice(j);
            for (i, k) in col.iter().enumerate().skip(j) {
                let (pairs, fine) = self.pair_count(i, j, *k);
                let mult = if i == j { pairs } else { 2.0 * pairs };
                if fine < min {
                    clamped += mult;
                    logs.push(min, mult);
                } else {
                    // A NaN entry (not clamped) makes the value NaN.
                    logs.push(fine, mult);
                }
            }
        }
        let value = -weight * logs.ln();
        if !value.is_finite() {
            return Err(GplvmError::NonFinite("connectivity prior"));
        }
        Ok(ConnectivityEval { value, beta, weight, epsilon, clamped: clamped as usize })
    }

    /// For node pair `(a, b)` of the eigenproblem with kernel entry `k`: how many fine pairs
    /// it stands for ($n_an_b$, 1 without coarsening) and their entry $k/\sqrt{n_an_b}$.
    #[inline]
    fn pair_count(&self, a: usize, b: usize, k: f64) -> (f64, f64) {
        match &self.coarse {
            Some(c) => {
                let pairs = c.size[a] * c.size[b];
                (pairs, k / pairs.sqrt())
            }
            None => (1.0, k),
        }
    }

    /// $E_C(X)$ alone (the eigendecomposition and one product).
    pub fn value(&mut self, x: &[f64]) -> Result<ConnectivityEval, GplvmError> {
        self.value_pass(x)
    }

    /// The full symmetric heat kernel at `x` (before the clamp), for diagnostics: $K_c$
    /// over the points, or on the coarse graph $K^c$ over its nodes ($m\times m$; a fine
    /// pair's entry is $K^c_{ab}/\sqrt{n_an_b}$).
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
        let (n, m, q) = (self.points, self.m, self.q);
        let eval = self.value_points(x)?;
        let par = self.params.par;
        let (beta, weight, epsilon) = (eval.beta, eval.weight, eval.epsilon);
        let min = self.params.min_entry;
        // G = ∂ψ/∂K = w n_a n_b / K (0 where clamped), full symmetric, in b2.
        for j in 0..m {
            for i in j..m {
                let k = self.b2[(i, j)];
                let (pairs, fine) = self.pair_count(i, j, k);
                self.b2[(i, j)] = if fine < min { 0.0 } else { weight * pairs / k };
            }
        }
        mirror_lower(self.b2.as_mut());
        // Ψ = (Uᵀ G) U, lower; then Ψ ∘ Φ, mirrored.
        matmul(self.b1.as_mut(), Accum::Replace, self.u.transpose(), self.b2.as_ref(), 1.0, par);
        lower_times(&mut self.b2, &self.b1, self.u.as_ref(), par);
        for b in 0..m {
            let lb = self.lambda[(b, 0)];
            let eb = self.e[b];
            let col = self.b2.col_as_slice_mut(b);
            for (a, v) in col.iter_mut().enumerate().skip(b) {
                *v *= divided_difference(beta, self.lambda[(a, 0)], lb, self.e[a], eb);
            }
        }
        mirror_lower(self.b2.as_mut());
        // M = (U Ψ∘Φ) Uᵀ, lower, in b2, then mirrored.
        matmul(self.b1.as_mut(), Accum::Replace, self.u.as_ref(), self.b2.as_ref(), 1.0, par);
        lower_times(&mut self.b2, &self.b1, self.u.transpose(), par);
        mirror_lower(self.b2.as_mut());
        // e_a = −(M(H+I))_aa / T_a with (H+I) = SWS, W the eigenproblem's graph (its
        // diagonal is 0 on the fine graph, W^c_aa on the coarse one).
        let mut r = std::mem::take(&mut self.e);
        r.fill(0.0);
        let wsp = self.coarse.as_ref().map_or(&self.w, |c| &c.wc);
        for j in 0..m {
            let (mcol, wcol) = (self.b2.col_as_slice(j), wsp.col_as_slice(j));
            let sj = self.s[j];
            let mut rj = mcol[j] * wcol[j] * sj * sj;
            for (i, ((mv, wv), si)) in mcol.iter().zip(wcol).zip(&self.s).enumerate().skip(j + 1) {
                let v = mv * wv * si * sj;
                r[i] += v;
                rj += v;
            }
            r[j] += rj;
        }
        for (ri, ti) in r.iter_mut().zip(&self.t) {
            *ri = -*ri / ti;
        }
        // Per fine pair (i, j) in nodes (a, b): C_ij = (2 s_a M_ab s_b + e_a + e_b) c'(D̃_ij),
        // stored in the lower triangle of w.
        let half_p = 0.5 * self.params.power;
        let mut d_eps = 0.0;
        for j in 0..n {
            sq_dists_below(&self.xc, n, q, j, &mut self.dist);
            let b = self.node[j];
            let mcol = self.b2.col_as_slice(b);
            let wcol = self.w.col_as_slice_mut(j);
            let (sb, eb) = (self.s[b], r[b]);
            for ((wv, &a), dd) in wcol[j + 1..].iter_mut().zip(&self.node[j + 1..]).zip(&self.dist[j + 1..n]) {
                let pair = 2.0 * self.s[a] * mcol[a] * sb + r[a] + eb;
                let c = pair * (-half_p * *wv / (dd + epsilon));
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

/// $\sum_i m_i\ln x_i$ for positive $x_i$ and whole multiplicities $m_i$, with one
/// logarithm at the end: the product $\prod_i x_i^{m_i}$ is kept as a mantissa in $[1, 2)$
/// times a power of two, renormalised after every factor (factors of at most 8 powers, so
/// no step under- or overflows for $x \ge 10^{-30}$). Relative rounding about $10^{-16}$
/// per factor: over the $m^2/2$ entries of the heat kernel an absolute error near
/// $10^{-11}$ in the sum, where a `ln` per entry cost 7 % of an evaluation. A non-finite
/// or non-positive $x$ makes the sum NaN.
#[derive(Debug, Clone, Copy)]
struct LogProduct {
    mantissa: f64,
    exponent: i64,
    bad: bool,
}

impl Default for LogProduct {
    fn default() -> Self {
        Self { mantissa: 1.0, exponent: 0, bad: false }
    }
}

impl LogProduct {
    /// Multiplies in $x^m$ (`m` a whole number ≥ 0).
    #[inline]
    fn push(&mut self, x: f64, m: f64) {
        if !(x.is_finite() && x > 0.0) || m.fract() != 0.0 {
            self.bad = true;
            return;
        }
        let mut left = m as i64;
        while left > 0 {
            let step = left.min(8);
            self.mantissa *= x.powi(step as i32);
            left -= step;
            let bits = self.mantissa.to_bits();
            let biased = ((bits >> 52) & 0x7ff) as i64;
            if biased == 0 || biased == 0x7ff {
                // Subnormal or overflow: only for x far outside a heat kernel's range.
                self.bad = true;
                return;
            }
            self.exponent += biased - 1023;
            self.mantissa = f64::from_bits((bits & !(0x7ff << 52)) | (1023 << 52));
        }
    }

    /// $\sum_i m_i\ln x_i$.
    fn ln(&self) -> f64 {
        if self.bad {
            f64::NAN
        } else {
            self.mantissa.ln() + self.exponent as f64 * std::f64::consts::LN_2
        }
    }
}

/// The divided difference of $\lambda \mapsto e^{\beta\lambda}$ at $\lambda_a, \lambda_b$
/// (with $e_a = e^{\beta\lambda_a}$, $e_b = e^{\beta\lambda_b}$ already computed):
/// $(e_a - e_b)/(\lambda_a - \lambda_b) = \beta e_b\varphi_1(\beta(\lambda_a - \lambda_b))$.
/// The quotient of the two exponentials, whose relative rounding error is about
/// $\epsilon/|z|$, is used where $|z| = \beta|\lambda_a-\lambda_b| \ge 10^{-3}$ (error
/// $\lesssim 10^{-13}$); `expm1` only for close eigenvalues. Most pairs are far apart, so
/// this saves an `expm1` per entry of the $m\times m$ matrix.
#[inline]
fn divided_difference(beta: f64, la: f64, lb: f64, ea: f64, eb: f64) -> f64 {
    let z = beta * (la - lb);
    if z.abs() >= 1e-3 {
        (ea - eb) / (la - lb)
    } else {
        beta * eb * phi1(z)
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

    /// The coarse path: its gradient matches central differences (1e-7) for runs of 2 and
    /// 3 frames over several segments, singleton groups reproduce the exact prior, and on
    /// smooth trajectories its value is within a few percent of the exact one.
    #[test]
    fn coarse_gradient_matches_finite_differences_and_singletons_are_exact() {
        let (n, q) = (26, 3);
        let (x, _) = random_problem(n, 1, q, 28);
        let times: Vec<f64> = (0..n).map(|i| (i % 13) as f64).collect();
        let segs: Vec<i64> = (0..n).map(|i| (i / 13) as i64).collect();
        for size in [2, 3] {
            let groups = coarse_groups(&times, &segs, size);
            assert_eq!(groups.iter().max().unwrap() + 1, 2 * 13usize.div_ceil(size));
            let mut prior = ConnectivityPrior::coarse(groups, q, params(4.0, 30.0)).unwrap();
            let mut g = vec![0.0; n * q];
            let ev = prior.value_grad_add(&x, &mut g).unwrap();
            assert_eq!(ev.clamped, 0);
            let fd = central_diff(&x, 1e-4, |xp| prior.value(xp).unwrap().value);
            let err = max_rel_err(&g, &fd);
            eprintln!("{}:{} size {size}: max relative error {err:.1e}", file!(), line!());
            assert!(err < 1e-7, "size {size}: {err:e}");
        }
        let mut exact = ConnectivityPrior::new(n, q, params(4.0, 30.0)).unwrap();
        let mut single = ConnectivityPrior::coarse((0..n).collect(), q, params(4.0, 30.0)).unwrap();
        let (mut ge, mut gs) = (vec![0.0; n * q], vec![0.0; n * q]);
        let ve = exact.value_grad_add(&x, &mut ge).unwrap().value;
        let vs = single.value_grad_add(&x, &mut gs).unwrap().value;
        assert!((ve - vs).abs() < 1e-12 * ve.abs(), "{ve} {vs}");
        assert!(max_rel_err(&gs, &ge) < 1e-10);
        assert!(ConnectivityPrior::coarse(vec![0, 2, 2], q, params(4.0, 1.0)).is_err());
        assert!(ConnectivityPrior::coarse(vec![0, 0, 0], q, params(4.0, 1.0)).is_err());
    }

    /// On smooth curves (the latent trajectories the dynamics prior makes), pairs of
    /// frames keep the prior's value within 3 % and its gradient within a direction
    /// cosine of 0.9 of the exact one; the subset of every other frame does far worse on
    /// both (the check has teeth).
    #[test]
    fn coarse_pairs_approximate_the_exact_prior_on_smooth_curves() {
        let (segments, len, q) = (4, 40, 3);
        let n = segments * len;
        let (noise, _) = random_problem(segments, 1, 12, 29);
        let x: Vec<f64> = (0..n)
            .flat_map(|i| {
                let (s, t) = (i / len, (i % len) as f64 / len as f64);
                let c = &noise[s * 12..(s + 1) * 12];
                (0..q).map(move |k| {
                    let c = &c[k * 4..k * 4 + 4];
                    0.3 * c[0] + c[1] * t + c[2] * (3.0 * t).sin() + 0.5 * c[3] * (5.0 * t).cos()
                })
            })
            .collect();
        let times: Vec<f64> = (0..n).map(|i| (i % len) as f64).collect();
        let segs: Vec<i64> = (0..n).map(|i| (i / len) as i64).collect();
        let p = ConnectivityParams { weight: 1e-3, ..Default::default() };
        let eval = |prior: &mut ConnectivityPrior| {
            let mut g = vec![0.0; n * q];
            let v = prior.value_grad_add(&x, &mut g).unwrap().value;
            (v, g)
        };
        let (ve, ge) = eval(&mut ConnectivityPrior::new(n, q, p).unwrap());
        let (vc, gc) = eval(&mut ConnectivityPrior::coarse(coarse_groups(&times, &segs, 2), q, p).unwrap());
        let (vs, gs) = eval(&mut ConnectivityPrior::on_subset(n, subset_rows(&times, &segs, 2), q, p).unwrap());
        let cos = |a: &[f64], b: &[f64]| {
            let dot: f64 = a.iter().zip(b).map(|(a, b)| a * b).sum();
            dot / (a.iter().map(|v| v * v).sum::<f64>() * b.iter().map(|v| v * v).sum::<f64>()).sqrt()
        };
        let (ec, es) = ((vc - ve).abs() / ve.abs(), (vs - ve).abs() / ve.abs());
        let (cc, cs) = (cos(&gc, &ge), cos(&gs, &ge));
        eprintln!("value error coarse {ec:.3} subset {es:.3}; gradient cosine coarse {cc:.3} subset {cs:.3}");
        assert!(ec < 0.03 && cc > 0.9, "coarse: value error {ec}, cosine {cc}");
        assert!(es > 2.0 * ec && cs < cc, "subset: value error {es}, cosine {cs}");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(ConnectivityPrior::new(1, 2, ConnectivityParams::default()).is_err());
        let bad = ConnectivityParams { beta: 0.0, ..Default::default() };
        assert!(matches!(ConnectivityPrior::new(5, 2, bad), Err(GplvmError::Params(_))));
        let mut p = ConnectivityPrior::new(3, 1, ConnectivityParams::default()).unwrap();
        assert!(matches!(p.value(&[1.0, 1.0, 1.0]), Err(GplvmError::Params(_))));
    }

    /// The one-logarithm sum equals the sum of logarithms on heat-kernel-like values
    /// (1e-16 to 1, multiplicities 1 to 32) to 1e-12 relative, and a zero, a NaN or a
    /// fractional multiplicity makes it NaN.
    #[test]
    fn log_product_equals_the_sum_of_logs() {
        let mut acc = LogProduct::default();
        let mut reference = 0.0;
        for i in 0..20_000 {
            let x = (-(((i * 7919) % 3700) as f64) / 100.0).exp().max(1e-16);
            let m = (1 + i % 32) as f64;
            acc.push(x, m);
            reference += m * x.ln();
        }
        assert!((acc.ln() - reference).abs() <= 1e-12 * reference.abs(), "{} vs {reference}", acc.ln());
        for (x, m) in [(0.0, 1.0), (f64::NAN, 1.0), (0.5, 1.5)] {
            let mut bad = LogProduct::default();
            bad.push(x, m);
            assert!(bad.ln().is_nan(), "{x} {m}");
        }
    }

    /// The divided difference agrees with β e_b φ1(β(λa − λb)) on both sides of the switch
    /// (far, near and equal eigenvalues) to 1e-12 relative, and is symmetric.
    #[test]
    fn divided_difference_matches_phi1_everywhere() {
        let beta = 1.7f64;
        for (la, lb) in
            [(-1.9f64, -0.1f64), (-0.5, -0.5 + 6e-4), (-0.5, -0.5 + 5e-4), (-0.3, -0.3), (-1.0, -1.0 + 1e-9)]
        {
            let (ea, eb) = ((beta * la).exp(), (beta * lb).exp());
            let reference = beta * eb * phi1(beta * (la - lb));
            let got = divided_difference(beta, la, lb, ea, eb);
            assert!((got - reference).abs() <= 1e-12 * reference.abs(), "{la} {lb}: {got} vs {reference}");
            let swapped = divided_difference(beta, lb, la, eb, ea);
            assert!((got - swapped).abs() <= 1e-12 * reference.abs(), "{la} {lb}: not symmetric");
        }
    }
}
