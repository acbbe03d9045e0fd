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

use super::params::JitterUsed;
use super::{
    ConnectivityParams, ConnectivityPrior, DynamicsParams, DynamicsPrior, EvalInfo, GplvmError, Hyper, Likelihood,
    LikelihoodConfig, Objective, Predictor,
};
use crate::scg::{scg, ScgInfo, ScgIter, ScgOptions};

/// Everything a fit needs besides the data.
#[derive(Debug, Clone, PartialEq)]
pub struct FitConfig {
    /// Latent dimension $q$ (the paper: 3).
    pub q: usize,
    /// Initial $\sigma_w^2 / \sigma_f^2$ (default 0.05).
    pub init_white_ratio: f64,
    /// Numerical settings of the likelihood (jitter, white floor, parallelism).
    pub likelihood: LikelihoodConfig,
    /// The dynamics prior's fixed hyperparameters, or `None` to leave it out.
    pub dynamics: Option<DynamicsParams>,
    /// The connectivity prior's parameters, or `None` to leave it out.
    pub connectivity: Option<ConnectivityParams>,
    /// The optimiser.
    pub scg: ScgOptions,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            q: 3,
            init_white_ratio: 0.05,
            likelihood: LikelihoodConfig::default(),
            dynamics: Some(DynamicsParams::default()),
            connectivity: Some(ConnectivityParams::default()),
            scg: ScgOptions::default(),
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
    /// The optimiser's summary.
    pub scg: ScgInfo,
    /// The optimiser's per-iteration trace.
    pub trace: Vec<ScgIter>,
    /// The objective's parts at the start.
    pub initial: EvalInfo,
    /// The objective's parts at the optimum.
    pub last: EvalInfo,
    /// Jitter the dynamics prior's blocks needed (`None` without the prior).
    pub dynamics_jitter: Option<JitterUsed>,
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

/// The starting hyperparameters for centred data `y` (see the module docs).
pub fn initial_hyper(y: &[f64], d: usize, white_ratio: f64) -> Hyper {
    let n = (y.len() / d).max(1) as f64;
    let var = y.iter().map(|v| v * v).sum::<f64>() / (n * d as f64);
    let var = if var > 0.0 && var.is_finite() { var } else { 1.0 };
    Hyper { rbf_variance: var, lengthscale: 1.0, white_variance: white_ratio * var }
}

/// Fits one GPLVM. `on_evaluation` is called after every objective evaluation with the
/// value (for progress reporting).
pub fn fit(data: FitData<'_>, config: &FitConfig, mut on_evaluation: impl FnMut(f64)) -> Result<Fit, GplvmError> {
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
    let offset = column_means(data.y, d);
    let y: Vec<f64> = data.y.chunks_exact(d).flat_map(|r| r.iter().zip(&offset).map(|(v, m)| v - m)).collect();
    let x0 = initial_latents(&y, d, q)?;
    let hyper0 = initial_hyper(&y, d, config.init_white_ratio);
    let likelihood = Likelihood::new(&y, d, q, config.likelihood)?;
    let dynamics = config.dynamics.map(|p| DynamicsPrior::new(data.times, data.segments, q, p)).transpose()?;
    let dynamics_jitter = dynamics.as_ref().map(DynamicsPrior::jitter_used);
    let connectivity = config.connectivity.map(|p| ConnectivityPrior::new(n, q, p)).transpose()?;
    let mut objective = Objective::new(likelihood, dynamics, connectivity)?;
    let layout = objective.layout();
    let p0 = layout.pack(&x0, &hyper0);
    let mut grad = vec![0.0; p0.len()];
    let initial = objective.try_evaluate(&p0, &mut grad)?;
    let result = scg(
        |p, g| {
            let v = objective.evaluate(p, g);
            on_evaluation(v);
            v
        },
        &p0,
        &config.scg,
    );
    // The optimiser's last call may have been a rejected trial: evaluate the returned point.
    let last = objective.try_evaluate(&result.x, &mut grad)?;
    let hyper = layout.hyper(&result.x);
    let x = layout.x(&result.x).to_vec();
    let predictor = Predictor::new(&x, &y, d, hyper, &config.likelihood)?;
    Ok(Fit { x, hyper, offset, predictor, scg: result.info, trace: result.trace, initial, last, dynamics_jitter })
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
            scg: ScgOptions { max_iters: 200, ..Default::default() },
            connectivity: Some(ConnectivityParams { weight: 1e-3, ..Default::default() }),
            ..Default::default()
        };
        let mut evals = 0;
        let f = fit(FitData { y: &y, d, times: &times, segments: &segs }, &config, |_| evals += 1).unwrap();
        assert_eq!(evals, f.scg.evaluations);
        assert!(f.last.value < f.initial.value - 10.0, "{} → {}", f.initial.value, f.last.value);
        assert!((f.last.value - f.scg.value).abs() < 1e-9 * f.scg.value.abs().max(1.0));
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
            f.scg,
            f.last
        );
    }

    /// Bad input: too few frames, NaN, fewer columns than q, a one-frame segment (a
    /// documented fallback: its block is the 1 × 1 matrix σ_t² + σ_tw²), and a time
    /// kernel that no jitter can factor.
    #[test]
    fn bad_input_is_an_error_or_a_documented_fallback() {
        let (y, times, segs) = data(40, 4);
        let cfg = FitConfig { scg: ScgOptions { max_iters: 5, ..Default::default() }, ..Default::default() };
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
