//! The MAP fit of one GPLVM (Bailey et al. 2016 §4.3, Eq. 7): initialisation, the
//! objective of [`super::Objective`] minimised by [`crate::scg`], and the predictor of
//! the result.
//!
//! - **Data.** $Y$ is centred by its column means before fitting (the GP has mean 0); the
//!   means are kept as [`Fit::offset`] and added back by every reconstruction. PCA
//!   coordinates of the whole label are already centred; a subset (held-out checks) is not.
//! - **Initial latents** ([`initial_latents`]): the first $q$ columns of the centred $Y$,
//!   each scaled to unit variance. The paper starts from the raw PCA coordinates; GPy and
//!   GPmat both whiten, and the dynamics prior's fixed amplitude $\sigma_t^2 = 1$ assumes
//!   unit-variance latents (method.md §1.4).
//! - **Initial hyperparameters** ([`initial_hyper`]): $\sigma_f^2$ = the mean column
//!   variance of $Y$, $\ell = 1$, $\sigma_w^2 = r\,\sigma_f^2$ with $r$ =
//!   [`FitConfig::init_white_ratio`] (method.md §1.4 suggests 0.01–0.1).
//! - **Priors**: the dynamics prior over each segment's frame times and the connectivity
//!   prior, each optional.
//! - **Optimiser** ([`Optimizer`]): SCG (the paper's) or L-BFGS, both stopped by the
//!   convergence rule of [`crate::optim`] with $f_{typ} = N\cdot d$ (the number of
//!   modelled values), unless SCG is asked for its Netlab/paramz step tests. A NaN in the
//!   objective or its gradient stops the fit with [`GplvmError::Diverged`]; a point where
//!   $K$ stays indefinite after every jitter escalation is $+\infty$, a rejected step.

use super::params::JitterUsed;
use super::{
    coarse_groups, spread_rows, subset_rows, ConnectivityParams, ConnectivityPrior, DynamicsParams, DynamicsPrior,
    EvalInfo, GplvmError, Hyper, Likelihood, LikelihoodConfig, Objective, Predictor, SignalPrior, SparseLikelihood,
};
use crate::lbfgs::{lbfgs, LbfgsOptions};
use crate::optim::{Convergence, OptInfo, OptIter, OptResult, StopReason};
use crate::scg::{scg, ScgOptions, Termination};

/// The optimiser of a fit, with its settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Optimizer {
    /// Netlab's scaled conjugate gradients (the paper's choice).
    Scg(ScgOptions),
    /// Limited-memory BFGS.
    Lbfgs(LbfgsOptions),
}

impl Optimizer {
    /// SCG stopped by `convergence`, at most `max_iters` iterations.
    pub fn scg(convergence: Convergence, max_iters: usize) -> Self {
        Self::Scg(ScgOptions { max_iters, termination: Termination::Converged, convergence, ..Default::default() })
    }

    /// L-BFGS stopped by `convergence`, at most `max_iters` iterations.
    pub fn lbfgs(convergence: Convergence, max_iters: usize) -> Self {
        Self::Lbfgs(LbfgsOptions { max_iters, convergence, ..Default::default() })
    }

    /// `"scg"` or `"lbfgs"`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Scg(_) => "scg",
            Self::Lbfgs(_) => "lbfgs",
        }
    }

    /// The iteration cap.
    pub fn max_iters(&self) -> usize {
        match self {
            Self::Scg(o) => o.max_iters,
            Self::Lbfgs(o) => o.max_iters,
        }
    }

    /// The same optimiser with another iteration cap.
    fn with_max_iters(mut self, max_iters: usize) -> Self {
        match &mut self {
            Self::Scg(o) => o.max_iters = max_iters,
            Self::Lbfgs(o) => o.max_iters = max_iters,
        }
        self
    }

    /// The same optimiser with the convergence rule's $f_{typ}$ set.
    fn with_f_typical(mut self, f_typical: f64) -> Self {
        match &mut self {
            Self::Scg(o) => o.convergence.f_typical = f_typical,
            Self::Lbfgs(o) => o.convergence.f_typical = f_typical,
        }
        self
    }

    /// Minimises `f` from `x0`.
    pub fn run(&self, f: impl FnMut(&[f64], &mut [f64]) -> f64, x0: &[f64]) -> OptResult {
        match self {
            Self::Scg(o) => scg(f, x0, o),
            Self::Lbfgs(o) => lbfgs(f, x0, o),
        }
    }
}

impl Default for Optimizer {
    fn default() -> Self {
        Self::lbfgs(Convergence::default(), 10_000)
    }
}

/// How the connectivity prior enters the fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConnectivityPath {
    /// The exact prior throughout.
    Exact,
    /// First the prior on every `stride`-th frame of each segment
    /// ([`ConnectivityPrior::on_subset`]) to convergence, then the exact prior to
    /// convergence from there: the result is converged on the exact objective.
    Staged {
        /// Subset stride (2 keeps about half the frames).
        stride: usize,
    },
    /// The subset prior throughout (a different, cheaper objective); the exact one is
    /// only evaluated at the end, for the report.
    Subset {
        /// Subset stride.
        stride: usize,
    },
    /// The coarse-graph prior throughout ([`ConnectivityPrior::coarse`]: runs of `size`
    /// consecutive frames of a segment as one node, every frame keeping its own weights):
    /// an approximation of the exact prior at about `size`⁻³ of its cost; the exact one is
    /// also evaluated at the end, for the report.
    Coarse {
        /// Frames per node (2 halves the eigenproblem).
        size: usize,
    },
    /// The subset prior throughout on `rows` rows spread evenly over the label
    /// ([`super::spread_rows`]): a fixed cost per evaluation whatever $N$.
    Sampled {
        /// Rows of the subset.
        rows: usize,
    },
    /// The exact prior for labels of at most [`ConnectivityPath::AUTO_EXACT_FRAMES`]
    /// frames (where it costs about as much as the likelihood), the coarse one up to
    /// [`ConnectivityPath::AUTO_COARSE_FRAMES`], and above that `Sampled` on
    /// [`ConnectivityPath::AUTO_EXACT_FRAMES`] rows: a fixed $O(300^3)$ per evaluation
    /// whatever $N$ (film-scale labels; the coarse graph's $O((N/k)^3 + N^2)$ would
    /// dominate a sparse fit's $O(NM^2)$).
    Auto {
        /// Frames per node of the coarse graph.
        size: usize,
    },
}

impl ConnectivityPath {
    /// The largest label `Auto` fits with the exact prior.
    pub const AUTO_EXACT_FRAMES: usize = 300;

    /// The largest label `Auto` fits with the coarse prior.
    pub const AUTO_COARSE_FRAMES: usize = 2000;

    /// The path a label of `n` frames takes (`Auto` resolved; the others as they are).
    pub fn for_frames(self, n: usize) -> Self {
        match self {
            Self::Auto { .. } if n <= Self::AUTO_EXACT_FRAMES => Self::Exact,
            Self::Auto { size } if n <= Self::AUTO_COARSE_FRAMES => Self::Coarse { size },
            Self::Auto { .. } => Self::Sampled { rows: Self::AUTO_EXACT_FRAMES },
            other => other,
        }
    }

    /// Whether the exact prior is evaluated for this path on `n` frames: always on the
    /// paths that minimise it, and for the report on the others up to
    /// [`ConnectivityPath::AUTO_COARSE_FRAMES`] (above, its $O(N^3)$ time and four
    /// $N\times N$ matrices would cost more than the whole fit).
    pub fn exact_for(self, n: usize) -> bool {
        self.ends_exact() || n <= Self::AUTO_COARSE_FRAMES
    }

    /// `"exact"`, `"staged"`, `"subset"`, `"sampled"`, `"coarse"` or `"auto"`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Exact => "exact",
            Self::Staged { .. } => "staged",
            Self::Subset { .. } => "subset",
            Self::Sampled { .. } => "sampled",
            Self::Coarse { .. } => "coarse",
            Self::Auto { .. } => "auto",
        }
    }

    /// The cheaper prior the fit starts with (to the end, unless staged), if any.
    fn cheap_prior(
        &self,
        params: ConnectivityParams,
        data: &FitData<'_>,
        q: usize,
    ) -> Result<Option<ConnectivityPrior>, GplvmError> {
        let n = data.times.len();
        match *self {
            Self::Exact | Self::Auto { .. } => Ok(None),
            Self::Staged { stride } | Self::Subset { stride } => {
                ConnectivityPrior::on_subset(n, subset_rows(data.times, data.segments, stride), q, params).map(Some)
            }
            Self::Sampled { rows } => {
                ConnectivityPrior::on_subset(n, spread_rows(data.times, data.segments, rows), q, params).map(Some)
            }
            Self::Coarse { size } => {
                ConnectivityPrior::coarse(coarse_groups(data.times, data.segments, size), q, params).map(Some)
            }
        }
    }

    /// Whether the exact prior takes over after the cheap one has converged.
    fn ends_exact(&self) -> bool {
        matches!(self, Self::Exact | Self::Staged { .. })
    }
}

/// Everything a fit needs besides the data. The optimiser's iteration cap is for the
/// whole fit (all stages together).
#[derive(Debug, Clone, PartialEq)]
pub struct FitConfig {
    /// Latent dimension $q$ (the paper: 3).
    pub q: usize,
    /// Initial $\sigma_w^2 / \sigma_f^2$ (default 0.05).
    pub init_white_ratio: f64,
    /// Keep $\ell$ at its initial 1 (default true). The likelihood depends on $X/\ell$
    /// only and the connectivity prior is scale invariant, so with $\ell$ free the
    /// dynamics prior (densest at $X = 0$) shrinks $X$ and $\ell$ together without end:
    /// the objective then has no minimiser and no fit converges. Fixing $\ell$ is a
    /// choice of units for $X$ that loses nothing in the likelihood.
    pub fix_lengthscale: bool,
    /// Numerical settings of the likelihood (jitter, white floors, parallelism).
    pub likelihood: LikelihoodConfig,
    /// The noise floor $\varepsilon$: the white variance is kept at or above
    /// $\varepsilon\,\bar v$, $\bar v$ the mean per-dimension variance of the centred $Y$
    /// (it becomes [`LikelihoodConfig::white_min`], unless that is larger). 0 turns it off.
    /// Noise-free curves otherwise drive $\sigma_w^2/\sigma_f^2$ to its floor and $\sigma_f^2$
    /// up without end, and no fit converges (docs/method.md, "The GPLVM fit").
    pub noise_floor: f64,
    /// Standard deviation $s$ of $\log\sigma_f^2$ under the [`SignalPrior`] centred on
    /// $\bar v$ (median $\bar v$); 0 turns the prior off.
    pub signal_prior_sd: f64,
    /// The dynamics prior's fixed hyperparameters, or `None` to leave it out.
    pub dynamics: Option<DynamicsParams>,
    /// The connectivity prior's parameters, or `None` to leave it out.
    pub connectivity: Option<ConnectivityParams>,
    /// How the connectivity prior enters the fit.
    pub connectivity_path: ConnectivityPath,
    /// The optimiser (its convergence rule's $f_{typ}$ is set to $N\cdot d$ by [`fit`]).
    pub optimizer: Optimizer,
    /// Optimise the whitened latents $Z$, $X = L_tZ$ (default true; only with the
    /// dynamics prior): the same objective, far better conditioned (see `Coordinates`).
    pub whiten: bool,
    /// `Some(M)`: the sparse fit ([`super::sparse`], DTC) with $M$ inducing points tied to
    /// the latents of $M$ frames spread evenly over the label ([`inducing_rows`]):
    /// $U = X_S$, GPmat's `fixInducing`, so they move with those latents and add no
    /// parameters. One evaluation costs $O(NM^2 + NMd)$ instead of $O(N^3)$. (Inducing
    /// points free as parameters of their own let the DTC likelihood keep improving
    /// without end: on the unit tests' 120 frames with M = 30 such a fit had not
    /// converged after 3,000 iterations, $E$ 45 below the dense optimum and falling, where
    /// the tied fit converged in 1,205 iterations to within 0.4 of the dense fit's $E$ —
    /// the dense fit took 1,203.) `None` (the default): the dense fit.
    pub inducing: Option<usize>,
    /// With `inducing`: add Titsias's trace term ([`SparseLikelihood::bound`]), making
    /// the sparse objective the collapsed variational bound rather than DTC's likelihood.
    pub sparse_bound: bool,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            q: 3,
            init_white_ratio: 0.05,
            fix_lengthscale: true,
            likelihood: LikelihoodConfig::default(),
            noise_floor: 0.0,
            signal_prior_sd: 0.0,
            dynamics: Some(DynamicsParams::default()),
            connectivity: Some(ConnectivityParams::default()),
            connectivity_path: ConnectivityPath::Exact,
            optimizer: Optimizer::default(),
            whiten: true,
            inducing: None,
            sparse_bound: true,
        }
    }
}

/// One label's training data.
#[derive(Debug, Clone, Copy)]
pub struct FitData<'a> {
    /// $Y$, row-major `N × d` (PCA coordinates, one row per frame).
    pub y: &'a [f64],
    /// Output dimension $d$.
    pub d: usize,
    /// Frame time of each row (the dynamics prior's input; frames, or seconds — in the
    /// units of [`DynamicsParams::lengthscale`]).
    pub times: &'a [f64],
    /// Segment of each row: rows with equal ids form one block of the dynamics prior.
    pub segments: &'a [i64],
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Latent points, row-major `N × q`, in the order of the data's rows.
    pub x: Vec<f64>,
    /// Optimised hyperparameters.
    pub hyper: Hyper,
    /// Column means of $Y$ subtracted before fitting (length $d$).
    pub offset: Vec<f64>,
    /// The predictor at the optimum (holds $K^{-1}(Y - \text{offset})$).
    pub predictor: Predictor,
    /// The optimiser's summary (of the last stage, with iterations and evaluations
    /// summed over the stages).
    pub info: OptInfo,
    /// Iterations of each stage (one stage, or the subset stage then the exact one).
    pub stage_iterations: Vec<usize>,
    /// The optimiser's per-iteration trace.
    pub trace: Vec<OptIter>,
    /// The parts of the objective the optimiser minimises, at the start (see
    /// [`Self::minimised`]).
    pub initial: EvalInfo,
    /// The objective's parts at the optimum, with the exact connectivity prior where it
    /// was evaluated ([`Self::exact_connectivity`]), else with the path's.
    pub last: EvalInfo,
    /// The parts of the objective the optimiser minimised, at the optimum: [`Self::last`]
    /// unless the fit ended on a cheaper connectivity prior (`coarse`, `subset`).
    pub minimised: EvalInfo,
    /// Jitter the dynamics prior's blocks needed (`None` without the prior).
    pub dynamics_jitter: Option<JitterUsed>,
    /// Whether [`Self::last`] holds the exact connectivity prior
    /// ([`ConnectivityPath::exact_for`]).
    pub exact_connectivity: bool,
}

/// The smallest number of frames a fit accepts for latent dimension `q`: $q + 2$ (fewer
/// points than that cannot pin down a $q$-dimensional embedding and three kernel
/// hyperparameters).
pub fn min_frames(q: usize) -> usize {
    q + 2
}

/// Column means of a row-major `N × d` matrix.
fn column_means(y: &[f64], d: usize) -> Vec<f64> {
    let n = (y.len() / d).max(1) as f64;
    let mut m = vec![0.0; d];
    y.chunks_exact(d).for_each(|r| m.iter_mut().zip(r).for_each(|(m, v)| *m += v));
    m.iter_mut().for_each(|m| *m /= n);
    m
}

/// The first `q` columns of the row-major `N × d` matrix `y`, each centred and scaled to
/// unit (population) variance. Fails if a column is constant (the data has rank below `q`).
pub fn initial_latents(y: &[f64], d: usize, q: usize) -> Result<Vec<f64>, GplvmError> {
    if q == 0 || d < q || y.is_empty() || !y.len().is_multiple_of(d) {
        return Err(GplvmError::Shape(format!("need N × d data with d ≥ q = {q}, got {} values, d = {d}", y.len())));
    }
    let n = y.len() / d;
    let mut x: Vec<f64> = y.chunks_exact(d).flat_map(|r| r[..q].to_vec()).collect();
    for k in 0..q {
        let mean = (0..n).map(|i| x[i * q + k]).sum::<f64>() / n as f64;
        (0..n).for_each(|i| x[i * q + k] -= mean);
        let var = (0..n).map(|i| x[i * q + k].powi(2)).sum::<f64>() / n as f64;
        if !(var > 0.0 && var.is_finite()) {
            return Err(GplvmError::Shape(format!(
                "column {k} of Y is constant: the data has rank below the latent dimension {q}"
            )));
        }
        let s = var.sqrt();
        (0..n).for_each(|i| x[i * q + k] /= s);
    }
    Ok(x)
}

/// The frames whose latents are a sparse fit's inducing points: `m` frames of the initial
/// latents `x0` (row-major `N × q`) at $\lfloor (k + \frac12)N/m\rfloor$, each replaced by
/// the next frame along if its latent lies within [`DISTINCT`] of one already taken (held
/// poses give equal latents, which would collapse onto each other).
///
/// # Errors
/// [`GplvmError::Shape`] if `m` is 0 or more than $N$, or the latents hold fewer than `m`
/// distinct points.
pub fn inducing_rows(x0: &[f64], q: usize, m: usize) -> Result<Vec<usize>, GplvmError> {
    let n = x0.len() / q;
    if m == 0 || m > n {
        return Err(GplvmError::Shape(format!(
            "{m} inducing points for a label of {n} frames: need 1 to {n} (at most one per frame)"
        )));
    }
    let row = |i: usize| &x0[i * q..(i + 1) * q];
    let mut taken: Vec<usize> = Vec::with_capacity(m);
    let mut used = vec![false; n];
    let distinct = |i: usize, taken: &[usize]| {
        taken.iter().all(|&j| super::kernel::sq_dist(row(i), row(j)) >= DISTINCT * DISTINCT)
    };
    for k in 0..m {
        let want = ((k as f64 + 0.5) * n as f64 / m as f64) as usize;
        let found = (0..n).map(|s| (want + s) % n).find(|&i| !used[i] && distinct(i, &taken));
        let Some(i) = found else {
            return Err(GplvmError::Shape(format!(
                "the label's {n} frames start at only {} distinct latent points: {m} inducing points would collapse onto each other; use at most {}",
                taken.len(),
                taken.len()
            )));
        };
        used[i] = true;
        taken.push(i);
    }
    Ok(taken)
}

/// Two starting inducing points closer than this (in the whitened initial latents' units,
/// where $\ell = 1$) count as one.
pub const DISTINCT: f64 = 1e-3;

/// The starting hyperparameters for centred data `y` (see the module docs).
pub fn initial_hyper(y: &[f64], d: usize, white_ratio: f64) -> Hyper {
    let var = mean_variance(y, d);
    let var = if var > 0.0 && var.is_finite() { var } else { 1.0 };
    Hyper { rbf_variance: var, lengthscale: 1.0, white_variance: white_ratio * var }
}

/// The mean per-dimension variance $\bar v = \lVert Y\rVert_F^2/(Nd)$ of centred `y`.
pub fn mean_variance(y: &[f64], d: usize) -> f64 {
    let n = (y.len() / d).max(1) as f64;
    y.iter().map(|v| v * v).sum::<f64>() / (n * d as f64)
}

/// The likelihood settings of a fit on centred `y`: `config.likelihood` with the absolute
/// white floor raised to `noise_floor` × [`mean_variance`].
pub fn likelihood_config(config: &FitConfig, y: &[f64], d: usize) -> LikelihoodConfig {
    let mut lik = config.likelihood;
    let floor = config.noise_floor * mean_variance(y, d);
    if floor.is_finite() {
        lik.white_min = lik.white_min.max(floor);
    }
    lik
}

/// Fits one GPLVM. `on_evaluation` is called after every objective evaluation with the
/// value (for progress reporting).
pub fn fit(data: FitData<'_>, config: &FitConfig, mut on_evaluation: impl FnMut(f64)) -> Result<Fit, GplvmError> {
    fit_observed(data, config, |e| on_evaluation(e.info.value))
}

/// One objective evaluation during a fit, as [`fit_observed`] reports it.
#[derive(Debug, Clone, Copy)]
pub struct Evaluation<'a> {
    /// The flat parameter vector evaluated ([`super::Layout`]: $X$ row-major, then the log
    /// hyperparameters).
    pub params: &'a [f64],
    /// The gradient there, as the optimiser saw it (in its coordinates: of the whitened
    /// latents when [`FitConfig::whiten`]; the fixed $\log\ell$ entry zeroed).
    pub grad: &'a [f64],
    /// The objective's parts there.
    pub info: &'a EvalInfo,
}

/// [`fit`], calling `observe` after every objective evaluation with the point, its
/// gradient and the objective's parts (for diagnostics: which parameters still move).
pub fn fit_observed(
    data: FitData<'_>,
    config: &FitConfig,
    mut on_evaluation: impl FnMut(Evaluation<'_>),
) -> Result<Fit, GplvmError> {
    let (d, q) = (data.d, config.q);
    if d == 0 || data.y.is_empty() || !data.y.len().is_multiple_of(d) {
        return Err(GplvmError::Shape(format!("Y has {} values, not N × d with d = {d}", data.y.len())));
    }
    let n = data.y.len() / d;
    if n < min_frames(q) {
        return Err(GplvmError::Shape(format!(
            "{n} frames: a {q}-dimensional latent space needs at least {} frames",
            min_frames(q)
        )));
    }
    if d < q {
        return Err(GplvmError::Shape(format!("Y has {d} columns, fewer than the latent dimension {q}")));
    }
    if data.times.len() != n || data.segments.len() != n {
        return Err(GplvmError::Shape(format!(
            "{n} frames but {} times and {} segment ids",
            data.times.len(),
            data.segments.len()
        )));
    }
    if data.y.iter().any(|v| !v.is_finite()) {
        return Err(GplvmError::NonFinite("value in Y"));
    }
    if !(config.init_white_ratio > 0.0 && config.init_white_ratio.is_finite()) {
        return Err(GplvmError::Params(format!("init_white_ratio must be > 0, got {}", config.init_white_ratio)));
    }
    if !(config.noise_floor >= 0.0 && config.noise_floor.is_finite()) {
        return Err(GplvmError::Params(format!("noise_floor must be >= 0, got {}", config.noise_floor)));
    }
    let offset = column_means(data.y, d);
    let y: Vec<f64> = data.y.chunks_exact(d).flat_map(|r| r.iter().zip(&offset).map(|(v, m)| v - m)).collect();
    let x0 = initial_latents(&y, d, q)?;
    let hyper0 = initial_hyper(&y, d, config.init_white_ratio);
    let lik_config = likelihood_config(config, &y, d);
    let dynamics = config.dynamics.map(|p| DynamicsPrior::new(data.times, data.segments, q, p)).transpose()?;
    let dynamics_jitter = dynamics.as_ref().map(DynamicsPrior::jitter_used);
    let path = config.connectivity_path.for_frames(n);
    let exact_connectivity = path.exact_for(n);
    let connectivity =
        config.connectivity.filter(|_| exact_connectivity).map(|p| ConnectivityPrior::new(n, q, p)).transpose()?;
    let cheap = match config.connectivity {
        Some(p) => path.cheap_prior(p, &data, q)?,
        None => None,
    };
    if !(config.signal_prior_sd >= 0.0 && config.signal_prior_sd.is_finite()) {
        return Err(GplvmError::Params(format!("signal_prior_sd must be >= 0, got {}", config.signal_prior_sd)));
    }
    let signal = (config.signal_prior_sd > 0.0)
        .then_some(SignalPrior { median: hyper0.rbf_variance, log_sd: config.signal_prior_sd });
    let coords = Coordinates { white: dynamics.clone().filter(|_| config.whiten), nq: n * q };
    // The frames whose latents are the inducing points (a sparse fit), chosen once.
    let rows = config.inducing.map(|m| inducing_rows(&x0, q, m)).transpose()?;
    let objective = match &rows {
        None => Objective::new(Likelihood::new(&y, d, q, lik_config)?, dynamics, connectivity)?,
        Some(rows) => {
            let likelihood = SparseLikelihood::new(&y, d, q)?;
            let likelihood = if config.sparse_bound { likelihood.bound() } else { likelihood };
            Objective::sparse(likelihood, rows.clone(), lik_config, dynamics, connectivity)?
        }
    };
    let mut objective = objective.with_signal_prior(signal)?;
    let layout = objective.layout();
    let p0 = layout.pack(&x0, &hyper0);
    let mut grad = vec![0.0; p0.len()];
    let mut initial = objective.try_evaluate(&p0, &mut grad)?;
    let optimizer = config.optimizer.with_f_typical((n * d) as f64);
    let mut runs = Vec::new();
    let mut start = coords.to_optimiser(&p0);
    // The log ℓ entry, whose gradient is zeroed when ℓ is fixed (so no optimiser moves it).
    let fixed = config.fix_lengthscale.then_some(layout.hyper_offset() + 1);
    let mut fitted = None;
    if let Some(cheap) = cheap {
        let exact = objective.set_connectivity(Some(cheap));
        if !path.ends_exact() {
            // The start of the objective this fit minimises, like `minimised` at its end.
            initial = objective.try_evaluate(&p0, &mut grad)?;
        }
        runs.push(optimise(&mut objective, &coords, &optimizer, &start, fixed, &mut on_evaluation)?);
        if !path.ends_exact() {
            fitted = Some(objective.try_evaluate(&coords.to_model(&runs[0].x), &mut grad)?);
        }
        if exact_connectivity {
            // The exact prior for the last stage or for the report; without it (film-scale
            // labels) `last` keeps the path's.
            objective.set_connectivity(exact);
        }
        start = runs[0].x.clone();
    }
    // The cap is for the whole fit: the exact stage gets what the cheap stage left.
    let left = optimizer.max_iters() - runs.first().map_or(0, |r| r.info.iterations);
    if runs.is_empty() || (left > 0 && path.ends_exact()) {
        let optimizer = optimizer.with_max_iters(left);
        runs.push(optimise(&mut objective, &coords, &optimizer, &start, fixed, &mut on_evaluation)?);
    }
    let result = merge(runs);
    let point = coords.to_model(&result.0.x);
    // The optimiser's last call may have been a rejected trial: evaluate the returned point.
    let last = objective.try_evaluate(&point, &mut grad)?;
    let minimised = fitted.unwrap_or_else(|| last.clone());
    let hyper = layout.hyper(&point);
    let x = layout.x(&point).to_vec();
    let predictor = match &rows {
        None => Predictor::new(&x, &y, d, hyper, &lik_config)?,
        Some(rows) => {
            let u: Vec<f64> = rows.iter().flat_map(|&r| x[r * q..(r + 1) * q].to_vec()).collect();
            Predictor::sparse(&x, &u, &y, d, hyper, &lik_config)?
        }
    };
    let (result, stage_iterations) = result;
    Ok(Fit {
        x,
        hyper,
        offset,
        predictor,
        info: result.info,
        stage_iterations,
        trace: result.trace,
        initial,
        last,
        minimised,
        dynamics_jitter,
        exact_connectivity: exact_connectivity || config.connectivity.is_none(),
    })
}

/// The coordinates the optimiser moves: the model's ($X$ and the log hyperparameters), or,
/// with the dynamics prior, its whitened latents $Z$ with $X = L_tZ$ per segment
/// ([`DynamicsPrior::unwhiten`]). The map is linear and invertible, so the objective, its
/// minimisers and the fit are the same; what changes is the conditioning: $K_t^{-1}$ of a
/// smooth time kernel with a small white term has a condition number of $10^4$–$10^6$,
/// which in $X$ makes L-BFGS crawl along the stiff, high-frequency-in-time directions,
/// while in $Z$ the prior's Hessian is $wI$.
struct Coordinates {
    white: Option<DynamicsPrior>,
    /// $N q$: the latents come first in the parameter vector.
    nq: usize,
}

impl Coordinates {
    /// Model parameters from the optimiser's.
    fn to_model(&self, p: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        self.to_model_into(p, &mut out);
        out
    }

    /// [`Self::to_model`] into `out` (reused across evaluations).
    fn to_model_into(&self, p: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend_from_slice(p);
        if let Some(w) = &self.white {
            w.unwhiten(&p[..self.nq], &mut out[..self.nq]);
        }
    }

    /// The optimiser's parameters from the model's.
    fn to_optimiser(&self, p: &[f64]) -> Vec<f64> {
        let mut out = p.to_vec();
        if let Some(w) = &self.white {
            w.whiten(&p[..self.nq], &mut out[..self.nq]);
        }
        out
    }

    /// The gradient in the optimiser's coordinates, in place, from the model's.
    fn grad_to_optimiser(&self, g: &mut [f64], scratch: &mut Vec<f64>) {
        if let Some(w) = &self.white {
            scratch.clear();
            scratch.extend_from_slice(&g[..self.nq]);
            w.grad_to_white(scratch, &mut g[..self.nq]);
        }
    }
}

/// One optimiser run on `objective` in `coords` (with the parameter `fixed` held); a NaN
/// stops it with [`GplvmError::Diverged`].
fn optimise(
    objective: &mut Objective,
    coords: &Coordinates,
    optimizer: &Optimizer,
    start: &[f64],
    fixed: Option<usize>,
    on_evaluation: &mut impl FnMut(Evaluation<'_>),
) -> Result<OptResult, GplvmError> {
    let mut evaluations = 0;
    let mut failure = None;
    let (mut scratch, mut model) = (Vec::new(), Vec::new());
    let result = optimizer.run(
        |p, g| {
            coords.to_model_into(p, &mut model);
            let v = objective.evaluate(&model, g);
            coords.grad_to_optimiser(g, &mut scratch);
            if let Some(i) = fixed {
                g[i] = 0.0;
            }
            evaluations += 1;
            if v.is_nan() && failure.is_none() {
                failure = objective.last().error.clone();
            }
            on_evaluation(Evaluation { params: &model, grad: g, info: objective.last() });
            v
        },
        start,
    );
    if result.info.reason == StopReason::NonFinite {
        let cause = failure.map_or_else(|| "NaN".to_string(), |e| e.to_string());
        return Err(GplvmError::Diverged { iteration: result.info.iterations, evaluations, cause });
    }
    Ok(result)
}

/// The runs of a staged fit as one: the last run's point and summary with iterations and
/// evaluations summed, the traces concatenated (evaluations and seconds cumulative), and
/// each run's iterations.
fn merge(runs: Vec<OptResult>) -> (OptResult, Vec<usize>) {
    let stages = runs.iter().map(|r| r.info.iterations).collect();
    let mut runs = runs.into_iter();
    let mut total = runs.next().expect("at least one run");
    for r in runs {
        let (evals, secs) = (total.info.evaluations, total.trace.last().map_or(0.0, |t| t.seconds));
        total.trace.extend(r.trace.iter().map(|t| OptIter {
            evaluations: t.evaluations + evals,
            seconds: t.seconds + secs,
            ..*t
        }));
        let info = OptInfo {
            iterations: total.info.iterations + r.info.iterations,
            evaluations: evals + r.info.evaluations,
            ..r.info
        };
        total = OptResult { x: r.x, info, trace: total.trace };
    }
    (total, stages)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::random_problem;
    use crate::gplvm::Jitter;

    /// Segments of 20 frames along a smooth 2-D curve, observed through a smooth map
    /// into `d` outputs with a little noise.
    fn data(n: usize, d: usize) -> (Vec<f64>, Vec<f64>, Vec<i64>) {
        let (_, noise) = random_problem(n, d, 2, 5);
        let times: Vec<f64> = (0..n).map(|i| (i % 20) as f64).collect();
        let segs = (0..n).map(|i| (i / 20) as i64).collect();
        let y = (0..n * d)
            .map(|idx| {
                let (i, j) = (idx / d, idx % d);
                let (t, s) = (times[i] / 20.0, (i / 20) as f64);
                let (a, b) = ((3.0 * t + 0.5 * s).cos(), (2.0 * t + s).sin());
                (a * (j as f64 + 1.0) + b * (2.0 - j as f64)).sin() + 0.02 * noise[idx]
            })
            .collect();
        (y, times, segs)
    }

    /// Initial latents are the first q columns with unit variance; a constant column is
    /// an error naming the rank problem.
    #[test]
    fn initial_latents_are_whitened_pca_columns() {
        let y = [1.0, 10.0, 5.0, -1.0, -10.0, 5.0, 3.0, 0.0, 5.0, -3.0, 0.0, 5.0f64]
            .iter()
            .map(|v| v + 1.0)
            .collect::<Vec<f64>>();
        let x = initial_latents(&y, 3, 2).unwrap();
        for k in 0..2 {
            let var: f64 = (0..4).map(|i| x[i * 2 + k].powi(2)).sum::<f64>() / 4.0;
            assert!((var - 1.0).abs() < 1e-12);
        }
        assert!((x[0] / x[4] - 1.0 / 3.0).abs() < 1e-12);
        assert!(initial_latents(&y, 3, 3).unwrap_err().to_string().contains("rank"));
    }

    /// The fit lowers the objective, keeps the data's offset, and its predictor
    /// reconstructs the training data far better than the mean does.
    #[test]
    fn fit_improves_and_reconstructs() {
        let (n, d) = (60, 5);
        let (mut y, times, segs) = data(n, d);
        y.iter_mut().enumerate().for_each(|(i, v)| *v += (i % d) as f64); // not centred
        let config = FitConfig {
            optimizer: Optimizer::Scg(ScgOptions { max_iters: 200, ..Default::default() }),
            connectivity: Some(ConnectivityParams { weight: 1e-3, ..Default::default() }),
            ..Default::default()
        };
        let mut evals = 0;
        let f = fit(FitData { y: &y, d, times: &times, segments: &segs }, &config, |_| evals += 1).unwrap();
        assert_eq!(evals, f.info.evaluations);
        assert!(f.last.value < f.initial.value - 10.0, "{} → {}", f.initial.value, f.last.value);
        assert!((f.last.value - f.info.value).abs() < 1e-9 * f.info.value.abs().max(1.0));
        assert!(f.last.dynamics != 0.0 && f.last.connectivity != 0.0);
        assert!((f.offset[3] - 3.0).abs() < 0.5);
        let (mut mu, mut sq, mut sq0) = (vec![0.0; d], 0.0, 0.0);
        for i in 0..n {
            f.predictor.mean(&f.x[i * config.q..(i + 1) * config.q], &mut mu);
            for j in 0..d {
                sq += (mu[j] + f.offset[j] - y[i * d + j]).powi(2);
                sq0 += (f.offset[j] - y[i * d + j]).powi(2);
            }
        }
        assert!(
            sq < 0.1 * sq0,
            "training reconstruction {sq} vs variance {sq0}; {:?} {:?} {:?}",
            f.hyper,
            f.info,
            f.last
        );
    }

    /// The sparse fit with both priors converges, its inducing points stay distinct and
    /// its DTC predictor reconstructs the training data about as well as the dense fit's
    /// (within 1.5 × its error, and far better than the mean); with as many inducing
    /// points as frames it reaches the dense fit's objective.
    #[test]
    fn a_sparse_fit_converges_and_reconstructs_like_the_dense_one() {
        let (n, d) = (120, 5);
        let (y, times, segs) = data(n, d);
        let data = FitData { y: &y, d, times: &times, segments: &segs };
        // The stage's noise floor and signal prior (without them this noise-free curve
        // drives σw² to its floor and neither fit converges within the cap).
        let base = FitConfig {
            connectivity: Some(ConnectivityParams { weight: 1e-3, ..Default::default() }),
            connectivity_path: ConnectivityPath::Auto { size: 3 },
            likelihood: LikelihoodConfig { white_floor: 1e-6, ..Default::default() },
            noise_floor: 1e-2,
            signal_prior_sd: 0.25,
            ..Default::default()
        };
        let sq_err = |f: &Fit| {
            let mut mu = vec![0.0; d];
            (0..n)
                .map(|i| {
                    f.predictor.mean(&f.x[i * 3..(i + 1) * 3], &mut mu);
                    (0..d).map(|j| (mu[j] + f.offset[j] - y[i * d + j]).powi(2)).sum::<f64>()
                })
                .sum::<f64>()
        };
        let dense = fit(data, &base, |_| ()).unwrap();
        let sparse = fit(data, &FitConfig { inducing: Some(30), ..base.clone() }, |_| ()).unwrap();
        assert!(dense.info.converged && sparse.info.converged, "{:?} {:?}", dense.info, sparse.info);
        assert!(sparse.predictor.is_sparse() && sparse.predictor.n() == 30 && sparse.x.len() == n * 3);
        let (e_dense, e_sparse) = (sq_err(&dense), sq_err(&sparse));
        let e_mean: f64 = (0..n * d).map(|i| (y[i] - dense.offset[i % d]).powi(2)).sum();
        eprintln!("training error: dense {e_dense:.4}, sparse M = 30 {e_sparse:.4}, mean {e_mean:.4}");
        assert!(e_sparse < 1.5 * e_dense.max(1e-3 * e_mean) && e_sparse < 0.05 * e_mean, "{e_sparse} vs {e_dense}");
        assert!(sparse.exact_connectivity && sparse.last.connectivity != 0.0);
        let full = fit(data, &FitConfig { inducing: Some(n), ..base.clone() }, |_| ()).unwrap();
        let rel = (full.minimised.value - dense.minimised.value) / dense.minimised.value.abs();
        assert!(rel.abs() < 0.02, "M = N: {} vs dense {}", full.minimised.value, dense.minimised.value);
    }

    /// `Auto` resolves by the label's size, and above 2,000 frames the subset prior has
    /// about 300 rows whatever N, and the exact prior is not built.
    #[test]
    fn the_auto_connectivity_path_keeps_its_cost_fixed_at_film_scale() {
        let auto = ConnectivityPath::Auto { size: 3 };
        assert_eq!(auto.for_frames(300), ConnectivityPath::Exact);
        assert_eq!(auto.for_frames(301), ConnectivityPath::Coarse { size: 3 });
        assert_eq!(auto.for_frames(2000), ConnectivityPath::Coarse { size: 3 });
        for n in [2001, 6000, 64_000] {
            let path = auto.for_frames(n);
            assert_eq!(path, ConnectivityPath::Sampled { rows: 300 });
            let times: Vec<f64> = (0..n).map(|i| (i % 240) as f64).collect();
            let segs: Vec<i64> = (0..n).map(|i| (i / 240) as i64).rev().collect();
            let rows = spread_rows(&times, &segs, 300);
            assert_eq!(rows.len(), 300, "{n} frames");
            assert!(rows.windows(2).all(|w| w[0] < w[1]), "distinct rows in order");
            assert!(!path.exact_for(n) && auto.for_frames(2000).exact_for(2000));
        }
        assert_eq!(spread_rows(&[0.0, 1.0], &[0, 0], 300), [0, 1]);
        assert!(ConnectivityPath::Staged { stride: 2 }.exact_for(64_000));
    }

    /// Starting inducing points: evenly spread, distinct where frames repeat a pose, and a
    /// clear refusal where the latents hold fewer distinct points than asked, or M > N.
    #[test]
    fn inducing_frames_are_distinct_or_refused_by_name() {
        // 10 frames of which 0..5 hold one pose.
        let x0: Vec<f64> = (0..10).flat_map(|i| if i < 5 { [0.0, 0.0] } else { [i as f64, 1.0] }).collect();
        let rows = inducing_rows(&x0, 2, 4).unwrap();
        let pts: Vec<&[f64]> = rows.iter().map(|&r| &x0[2 * r..2 * r + 2]).collect();
        for i in 0..4 {
            for j in 0..i {
                assert!(crate::gplvm::kernel::sq_dist(pts[i], pts[j]) > 0.0, "{pts:?}");
            }
        }
        assert!(inducing_rows(&x0, 2, 6).is_ok());
        let err = inducing_rows(&x0, 2, 7).unwrap_err().to_string();
        assert!(err.contains("only 6 distinct") && err.contains("use at most 6"), "{err}");
        let err = inducing_rows(&x0, 2, 11).unwrap_err().to_string();
        assert!(err.contains("11 inducing points for a label of 10 frames"), "{err}");
    }

    /// Under the stage's configuration (L-BFGS, the window rule, both priors) a small fit
    /// converges for the rule's reason on the coarse path and on the staged one: the
    /// measures are below the tolerances, the trace's last window really is flat, and it
    /// stops well before the cap; the coarse fit reports the exact prior at its optimum
    /// beside the one it minimised. SCG on the exact path converges by the same rule to a
    /// similar objective.
    #[test]
    fn default_fit_converges_for_the_right_reason() {
        let (n, d) = (60, 5);
        let (y, times, segs) = data(n, d);
        let rule = Convergence::default();
        let data = FitData { y: &y, d, times: &times, segments: &segs };
        let mut last = None;
        for path in [ConnectivityPath::Coarse { size: 3 }, ConnectivityPath::Staged { stride: 2 }] {
            let config = FitConfig {
                connectivity: Some(ConnectivityParams { weight: 1e-3, ..Default::default() }),
                connectivity_path: path,
                likelihood: LikelihoodConfig { white_floor: 1e-3, ..Default::default() },
                ..Default::default()
            };
            let f = fit(data, &config, |_| ()).unwrap();
            eprintln!("{path:?}: {:?} stages {:?}", f.info, f.stage_iterations);
            assert_eq!((f.info.reason, f.info.converged), (StopReason::Converged, true));
            assert_eq!(f.stage_iterations.len(), if path.ends_exact() { 2 } else { 1 });
            assert!(f.info.measures.rel_gradient <= rule.gtol && f.info.measures.rel_decrease <= rule.ftol);
            assert!(f.info.iterations < 2000, "{:?}", f.info);
            let tail = &f.trace[f.trace.len() - rule.window - 1..];
            let scale = f.info.value.abs().max((n * d) as f64);
            assert!((tail[0].value - f.info.value) / scale <= rule.window as f64 * rule.ftol);
            assert_eq!(f.trace.len(), f.info.iterations);
            assert!((f.minimised.value - f.info.value).abs() <= 1e-9 * f.info.value.abs());
            if path.ends_exact() {
                assert_eq!(f.minimised.value, f.last.value);
            } else {
                // The same point, the exact prior in place of the coarse one.
                assert_eq!(f.minimised.likelihood, f.last.likelihood);
                assert!(f.minimised.connectivity != f.last.connectivity);
                let rel = (f.minimised.connectivity - f.last.connectivity).abs() / f.last.connectivity.abs();
                // 20 nodes for 60 frames: coarser than any label the stage gives this path
                // (docs/method.md: 0.1–1.2 % from N = 200 up).
                assert!(rel < 0.1, "coarse prior {} vs exact {}", f.minimised.connectivity, f.last.connectivity);
            }
            last = Some((config, f));
        }
        let (config, f) = last.unwrap();
        let scg_config = FitConfig {
            connectivity_path: ConnectivityPath::Exact,
            optimizer: Optimizer::scg(Convergence::default(), 10_000),
            ..config
        };
        let g = fit(data, &scg_config, |_| ()).unwrap();
        eprintln!("SCG: {:?}", g.info);
        assert_eq!(g.info.reason, StopReason::Converged);
        assert!(
            (g.last.value - f.last.value).abs() < 0.05 * f.last.value.abs(),
            "{} vs {}",
            g.last.value,
            f.last.value
        );
    }

    /// The signal prior and the noise floor make the MAP well posed on smooth curves with
    /// a little noise: with ℓ fixed and the dynamics prior, the exact connectivity path
    /// and the stage's defaults s = 0.25, ε = 10⁻³, L-BFGS converges (measured: with the
    /// signal prior alone the white variance falls to its 10⁻⁶σ_f² floor, X interpolates
    /// the noise, and 5000 iterations are not enough) by the rule before the cap, σ_f² stays within a
    /// factor 20 of the data's mean variance v̄, E_S is part of the objective, and bad
    /// settings are errors.
    #[test]
    fn signal_prior_fit_converges_with_bounded_signal_variance() {
        let (n, d) = (60, 5);
        let (y, times, segs) = data(n, d);
        let config = FitConfig {
            connectivity: Some(ConnectivityParams { weight: 1e-3, ..Default::default() }),
            signal_prior_sd: 0.25,
            noise_floor: 1e-3,
            optimizer: Optimizer::lbfgs(Convergence::default(), 5000),
            ..Default::default()
        };
        let f = fit(FitData { y: &y, d, times: &times, segments: &segs }, &config, |_| ()).unwrap();
        eprintln!("{:?} {:?} {:?}", f.info, f.hyper, f.last);
        assert_eq!((f.info.reason, f.info.converged), (StopReason::Converged, true));
        let centred: Vec<f64> = y.chunks_exact(d).flat_map(|r| r.iter().zip(&f.offset).map(|(v, m)| v - m)).collect();
        let v = mean_variance(&centred, d);
        assert!(f.hyper.rbf_variance < 20.0 * v && f.hyper.rbf_variance > v / 20.0, "{:?} v̄ = {v}", f.hyper);
        assert!(f.last.signal > 0.0);
        let parts = f.last.likelihood + f.last.dynamics + f.last.connectivity + f.last.signal;
        assert!((f.last.value - parts).abs() < 1e-9 * f.last.value.abs().max(1.0));
        let bad = FitConfig { signal_prior_sd: -1.0, ..config.clone() };
        assert!(fit(FitData { y: &y, d, times: &times, segments: &segs }, &bad, |_| ()).is_err());
        let bad = FitConfig { noise_floor: f64::NAN, ..config };
        assert!(fit(FitData { y: &y, d, times: &times, segments: &segs }, &bad, |_| ()).is_err());
    }

    /// The noise floor ε becomes the absolute white floor ε·v̄ of the fit's likelihood.
    #[test]
    fn noise_floor_is_tied_to_the_data_variance() {
        let (y, _, _) = data(30, 3);
        let config = FitConfig { noise_floor: 1e-2, ..Default::default() };
        let lik = likelihood_config(&config, &y, 3);
        assert!((lik.white_min - 1e-2 * mean_variance(&y, 3)).abs() < 1e-15);
        assert_eq!(likelihood_config(&FitConfig::default(), &y, 3).white_min, 0.0);
        assert!((mean_variance(&[1.0, -1.0, 3.0, -3.0], 2) - 5.0).abs() < 1e-15);
    }

    /// A fit that cannot converge within the cap (a connectivity weight 10⁶ times the
    /// default's, 25 iterations) says so with its numbers: not converged, max-iterations,
    /// measures above the tolerances, its objective parts finite.
    #[test]
    fn capped_fit_is_not_converged() {
        let (y, times, segs) = data(40, 4);
        let config = FitConfig {
            connectivity: Some(ConnectivityParams { weight: 1e3, ..Default::default() }),
            optimizer: Optimizer::lbfgs(Convergence::default(), 25),
            ..Default::default()
        };
        let f = fit(FitData { y: &y, d: 4, times: &times, segments: &segs }, &config, |_| ()).unwrap();
        assert_eq!((f.info.reason, f.info.converged, f.info.iterations), (StopReason::MaxIterations, false, 25));
        let m = f.info.measures;
        assert!(m.rel_gradient > Convergence::default().gtol || m.rel_decrease > Convergence::default().ftol, "{m:?}");
        assert!(f.last.value.is_finite() && f.last.connectivity.is_finite());
    }

    /// Bad input: too few frames, NaN, fewer columns than q, a one-frame segment (a
    /// documented fallback: its block is the 1 × 1 matrix σ_t² + σ_tw²), and a time
    /// kernel that no jitter can factor.
    #[test]
    fn bad_input_is_an_error_or_a_documented_fallback() {
        let (y, times, segs) = data(40, 4);
        let cfg = FitConfig { optimizer: Optimizer::scg(Convergence::default(), 5), ..Default::default() };
        let few = FitData { y: &y[..4 * 4], d: 4, times: &times[..4], segments: &segs[..4] };
        assert!(fit(few, &cfg, |_| ()).unwrap_err().to_string().contains("at least 5 frames"));
        let mut bad = y.clone();
        bad[7] = f64::NAN;
        let nan = FitData { y: &bad, d: 4, times: &times, segments: &segs };
        assert_eq!(fit(nan, &cfg, |_| ()).unwrap_err(), GplvmError::NonFinite("value in Y"));
        let narrow = FitData { y: &y[..40 * 2], d: 2, times: &times, segments: &segs };
        assert!(fit(narrow, &cfg, |_| ()).unwrap_err().to_string().contains("fewer than the latent dimension"));
        let mut single = segs.clone();
        single[39] = 99;
        let ok = fit(FitData { y: &y, d: 4, times: &times, segments: &single }, &cfg, |_| ()).unwrap();
        assert!(ok.last.value.is_finite());
        let singular = FitConfig {
            dynamics: Some(DynamicsParams {
                lengthscale: 50.0,
                white_variance: 1e-300,
                jitter: Jitter::NONE,
                ..Default::default()
            }),
            ..cfg
        };
        let err = fit(FitData { y: &y, d: 4, times: &times, segments: &segs }, &singular, |_| ()).unwrap_err();
        assert!(matches!(err, GplvmError::NotPositiveDefinite { what: "K_t", .. }), "{err}");
    }
}
