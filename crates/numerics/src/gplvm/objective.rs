//! The MAP objective $E = -\log p(Y\mid X,\theta) - \psi_D(X) - \psi_C(X)$ over the flat
//! parameter vector of [`Layout`] ($X$ row-major, then
//! $\log\sigma_f^2, \log\ell, \log\sigma_w^2$), in the shape [`crate::scg::scg`] wants.
//!
//! The likelihood is the dense one ([`Likelihood`]) or the sparse DTC one
//! ([`SparseLikelihood`], over $M$ inducing points tied to $M$ of the latents), with the
//! same white-variance floors. Only the likelihood and the optional [`SignalPrior`] depend on
//! the hyperparameters; each prior is optional.

use super::likelihood::Floor;
use super::params::JitterUsed;
use super::sparse::{SparseLikelihood, JITTER};
use super::{ConnectivityPrior, DynamicsPrior, GplvmError, Hyper, Layout, Likelihood, LikelihoodConfig};

/// The parts of one evaluation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EvalInfo {
    /// $E$ (the sum of the three parts; $+\infty$ after a failure).
    pub value: f64,
    /// $-\log p(Y\mid X,\theta)$.
    pub likelihood: f64,
    /// $-\psi_D$ (0 without the prior).
    pub dynamics: f64,
    /// $-\psi_C$ (0 without the prior).
    pub connectivity: f64,
    /// $E_S$, the [`SignalPrior`] term (0 without it).
    pub signal: f64,
    /// Jitter added to $K$.
    pub jitter: JitterUsed,
    /// The white variance the kernel used (after the floor).
    pub white_variance_used: f64,
    /// Whether the white-variance floor was active.
    pub white_clamped: bool,
    /// Why the evaluation failed, if it did.
    pub error: Option<GplvmError>,
}

/// A Gaussian prior on $u = \log\sigma_f^2$ (a log-normal prior on the RBF variance, as a
/// density over the optimiser's own coordinate):
/// $$E_S = \frac{(\log\sigma_f^2 - \log m)^2}{2s^2},\qquad
/// \frac{\partial E_S}{\partial\log\sigma_f^2} = \frac{\log\sigma_f^2 - \log m}{s^2},$$
/// with median $m$ (units of $Y^2$) and log standard deviation $s$ (natural log).
/// [`super::fit()`] centres it on the data: $m = \bar v$, the mean per-dimension variance of $Y$.
/// With $\ell$ fixed it removes the flat-limit ridge of the likelihood ($X \to 0$,
/// $\sigma_f^2 \to \infty$ at a fixed $\sigma_w^2/\sigma_f^2$) along which no fit converges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalPrior {
    /// Median $m > 0$ of $\sigma_f^2$.
    pub median: f64,
    /// Standard deviation $s > 0$ of $\log\sigma_f^2$.
    pub log_sd: f64,
}

impl SignalPrior {
    /// $E_S$ and $\partial E_S/\partial\log\sigma_f^2$ at $\log\sigma_f^2$ = `log_rbf`.
    pub fn value_grad(&self, log_rbf: f64) -> (f64, f64) {
        let z = (log_rbf - self.median.ln()) / self.log_sd;
        (0.5 * z * z, z / self.log_sd)
    }

    fn check(&self) -> Result<(), GplvmError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if pos(self.median) && pos(self.log_sd) {
            Ok(())
        } else {
            Err(GplvmError::Params(format!("signal prior needs a positive median and log sd, got {self:?}")))
        }
    }
}

/// The likelihood part: dense, or sparse over inducing points.
#[derive(Debug)]
enum Data {
    Dense(Box<Likelihood>),
    /// The sparse likelihood with its inducing points tied to these rows of $X$ (GPmat's
    /// `fixInducing`): $U = X_S$, no parameters of their own.
    Sparse(SparseLikelihood, LikelihoodConfig, Vec<usize>),
}

/// Likelihood plus optional priors, evaluated together.
#[derive(Debug)]
pub struct Objective {
    layout: Layout,
    likelihood: Data,
    dynamics: Option<DynamicsPrior>,
    connectivity: Option<ConnectivityPrior>,
    signal: Option<SignalPrior>,
    last: EvalInfo,
}

impl Objective {
    /// Combines the parts; every prior must be for the likelihood's $N$ (and $q$).
    pub fn new(
        likelihood: Likelihood,
        dynamics: Option<DynamicsPrior>,
        connectivity: Option<ConnectivityPrior>,
    ) -> Result<Self, GplvmError> {
        let layout = Layout::new(likelihood.n(), likelihood.q());
        Self::with_priors(layout, Data::Dense(Box::new(likelihood)), dynamics, connectivity)
    }

    /// The sparse objective: the DTC `likelihood` with its inducing points tied to the
    /// latents of `rows` ($U = X_S$; $\partial E/\partial U$ adds into those rows'
    /// gradient), its white variance floored by `config` as the dense one's is.
    pub fn sparse(
        likelihood: SparseLikelihood,
        rows: Vec<usize>,
        config: LikelihoodConfig,
        dynamics: Option<DynamicsPrior>,
        connectivity: Option<ConnectivityPrior>,
    ) -> Result<Self, GplvmError> {
        let (n, q) = (likelihood.n(), likelihood.q());
        if rows.is_empty() || rows.len() > n || rows.iter().any(|&r| r >= n) {
            return Err(GplvmError::Shape(format!(
                "{} inducing rows for {n} latent points: 1 to {n}, each below {n}",
                rows.len()
            )));
        }
        Self::with_priors(Layout::new(n, q), Data::Sparse(likelihood, config, rows), dynamics, connectivity)
    }

    fn with_priors(
        layout: Layout,
        likelihood: Data,
        dynamics: Option<DynamicsPrior>,
        connectivity: Option<ConnectivityPrior>,
    ) -> Result<Self, GplvmError> {
        let n = layout.n;
        if dynamics.as_ref().is_some_and(|d| d.n() != n) || connectivity.as_ref().is_some_and(|c| c.n() != n) {
            return Err(GplvmError::Shape(format!("every prior must cover the likelihood's N = {n} points")));
        }
        Ok(Self { layout, likelihood, dynamics, connectivity, signal: None, last: EvalInfo::default() })
    }

    /// The same objective with the [`SignalPrior`] `prior` on $\sigma_f^2$ (or none).
    pub fn with_signal_prior(mut self, prior: Option<SignalPrior>) -> Result<Self, GplvmError> {
        prior.as_ref().map(SignalPrior::check).transpose()?;
        self.signal = prior;
        Ok(self)
    }

    /// The parameter layout.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// The dense likelihood part (none for the sparse objective).
    pub fn likelihood(&mut self) -> Option<&mut Likelihood> {
        match &mut self.likelihood {
            Data::Dense(l) => Some(l),
            Data::Sparse(..) => None,
        }
    }

    /// The dynamics prior, if any.
    pub fn dynamics(&mut self) -> Option<&mut DynamicsPrior> {
        self.dynamics.as_mut()
    }

    /// The connectivity prior, if any.
    pub fn connectivity(&mut self) -> Option<&mut ConnectivityPrior> {
        self.connectivity.as_mut()
    }

    /// Replaces the connectivity prior (it must cover the same $N$ rows), returning the
    /// old one.
    pub fn set_connectivity(&mut self, prior: Option<ConnectivityPrior>) -> Option<ConnectivityPrior> {
        assert!(prior.as_ref().is_none_or(|c| c.n() == self.layout.n), "the prior must cover N rows");
        std::mem::replace(&mut self.connectivity, prior)
    }

    /// The parts of the last [`Objective::evaluate`].
    pub fn last(&self) -> &EvalInfo {
        &self.last
    }

    /// $E$ and its gradient (written into `grad`, same layout as `params`).
    pub fn try_evaluate(&mut self, params: &[f64], grad: &mut [f64]) -> Result<EvalInfo, GplvmError> {
        let layout = self.layout;
        if params.len() != layout.len() || grad.len() != layout.len() {
            return Err(GplvmError::Shape(format!(
                "params and grad need {} values, got {} and {}",
                layout.len(),
                params.len(),
                grad.len()
            )));
        }
        let o = layout.hyper_offset();
        if params[o..].iter().any(|v| !v.is_finite()) {
            return Err(GplvmError::NonFinite("log hyperparameter"));
        }
        let hyper = layout.hyper(params);
        let nq = layout.n * layout.q;
        let (gxu, gh) = grad.split_at_mut(o);
        let lik = match &mut self.likelihood {
            Data::Dense(l) => {
                let e = l.evaluate(layout.x(params), &hyper, &mut gxu[..nq])?;
                gh.copy_from_slice(&e.grad_hyper_log(&hyper).to_array());
                e
            }
            Data::Sparse(l, config, rows) => {
                let (q, x) = (layout.q, layout.x(params));
                let u: Vec<f64> = rows.iter().flat_map(|&r| x[r * q..(r + 1) * q].iter().copied()).collect();
                let mut gu = vec![0.0; u.len()];
                let e = sparse_eval(l, config, x, &u, &hyper, &mut gxu[..nq], &mut gu, gh)?;
                for (k, &r) in rows.iter().enumerate() {
                    gxu[r * q..(r + 1) * q].iter_mut().zip(&gu[k * q..(k + 1) * q]).for_each(|(g, d)| *g += d);
                }
                e
            }
        };
        let (x, gx) = (layout.x(params), &mut gxu[..nq]);
        let dynamics = match self.dynamics.as_mut() {
            Some(d) => d.value_grad_add(x, gx)?,
            None => 0.0,
        };
        let connectivity = match self.connectivity.as_mut() {
            Some(c) => c.value_grad_add(x, gx)?.value,
            None => 0.0,
        };
        let signal = match self.signal {
            Some(prior) => {
                let (v, g) = prior.value_grad(params[o]);
                gh[0] += g;
                v
            }
            None => 0.0,
        };
        Ok(EvalInfo {
            value: lik.value + dynamics + connectivity + signal,
            likelihood: lik.value,
            dynamics,
            connectivity,
            signal,
            jitter: lik.jitter,
            white_variance_used: lik.white_variance_used,
            white_clamped: lik.white_clamped,
            error: None,
        })
    }

    /// $E$ and its gradient for an optimiser: a domain failure (indefinite $K$ after every
    /// jitter escalation, an eigensolver failure) returns $+\infty$ with a zero gradient,
    /// which the optimisers treat as a rejected step; a non-finite computed value or
    /// gradient ([`GplvmError::NonFinite`]) returns NaN, which stops them.
    /// [`Objective::last`] says why.
    pub fn evaluate(&mut self, params: &[f64], grad: &mut [f64]) -> f64 {
        match self.try_evaluate(params, grad) {
            Ok(info) => {
                self.last = info;
            }
            Err(e) => {
                grad.fill(0.0);
                let value = if matches!(e, GplvmError::NonFinite(_)) { f64::NAN } else { f64::INFINITY };
                self.last = EvalInfo { value, error: Some(e), ..EvalInfo::default() };
            }
        }
        self.last.value
    }
}

/// The sparse likelihood at the floored white variance, as [`super::LikelihoodEval`] with
/// the log-space hyperparameter gradient written into `gh`: the floor's dependence moves
/// to $\sigma_f^2$ (relative floor) or vanishes (absolute floor), as the dense one's does.
#[allow(clippy::too_many_arguments)]
fn sparse_eval(
    l: &SparseLikelihood,
    config: &LikelihoodConfig,
    x: &[f64],
    u: &[f64],
    hyper: &Hyper,
    gx: &mut [f64],
    gu: &mut [f64],
    gh: &mut [f64],
) -> Result<super::LikelihoodEval, GplvmError> {
    let (white, floor) = config.white(hyper);
    let used = Hyper { white_variance: white, ..*hyper };
    let e = l.evaluate(x, u, &used, gx, gu)?;
    let mut g = e.grad_hyper;
    match floor {
        Floor::None => {}
        Floor::Relative => {
            g.rbf_variance += g.white_variance * config.white_floor;
            g.white_variance = 0.0;
        }
        Floor::Absolute => g.white_variance = 0.0,
    }
    gh.copy_from_slice(&g.to_log(hyper).to_array());
    Ok(super::LikelihoodEval {
        value: e.value,
        grad_hyper: g,
        jitter: JitterUsed { added: JITTER * hyper.rbf_variance, retries: 0 },
        white_variance_used: white,
        white_clamped: floor != Floor::None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};
    use crate::gplvm::{ConnectivityParams, DynamicsParams, Hyper, LikelihoodConfig};

    fn objective(n: usize, d: usize, q: usize, priors: bool) -> (Objective, Vec<f64>) {
        let (x, y) = random_problem(n, d, q, 31);
        let lik = Likelihood::new(&y, d, q, LikelihoodConfig::default()).unwrap();
        let (dyn_prior, conn) = if priors {
            let times: Vec<f64> = (0..n).map(|i| (i % 9) as f64).collect();
            let seg: Vec<usize> = (0..n).map(|i| i / 9).collect();
            let dp = DynamicsParams { lengthscale: 2.0, white_variance: 1e-2, weight: 0.5, ..Default::default() };
            let cp = ConnectivityParams { weight: 0.3, ..Default::default() };
            (Some(DynamicsPrior::new(&times, &seg, q, dp).unwrap()), Some(ConnectivityPrior::new(n, q, cp).unwrap()))
        } else {
            (None, None)
        };
        let signal = priors.then_some(SignalPrior { median: 0.4, log_sd: 0.7 });
        let obj = Objective::new(lik, dyn_prior, conn).unwrap().with_signal_prior(signal).unwrap();
        let p = obj.layout().pack(&x, &Hyper { rbf_variance: 0.9, lengthscale: 1.1, white_variance: 0.02 });
        (obj, p)
    }

    /// The full gradient (latent block and log hyperparameters, with all three priors) equals
    /// central differences of the value, and the value is the sum of its parts.
    #[test]
    fn gradient_matches_finite_differences() {
        for priors in [false, true] {
            let (mut obj, p) = objective(27, 5, 3, priors);
            let mut g = vec![0.0; p.len()];
            let v = obj.evaluate(&p, &mut g);
            let info = obj.last().clone();
            assert!(info.error.is_none());
            assert!((v - (info.likelihood + info.dynamics + info.connectivity + info.signal)).abs() < 1e-12 * v.abs());
            assert_eq!(priors, info.dynamics != 0.0 && info.connectivity != 0.0 && info.signal != 0.0);
            let mut scratch = vec![0.0; p.len()];
            let fd = central_diff(&p, 1e-4, |pp| obj.evaluate(pp, &mut scratch));
            let err = max_rel_err(&g, &fd);
            eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
            assert!(err < 1e-7, "priors {priors}: {err:e}");
        }
    }

    /// The sparse objective's full gradient (latents, some of them the inducing points, log
    /// hyperparameters, every prior) against central differences, above and below the
    /// white-variance floor; and with every latent an inducing point, its value is the
    /// dense objective's.
    #[test]
    fn the_sparse_objective_matches_differences_and_the_dense_one() {
        let (n, d, q) = (27, 5, 3);
        let (x, y) = random_problem(n, d, q, 31);
        let times: Vec<f64> = (0..n).map(|i| (i % 9) as f64).collect();
        let seg: Vec<usize> = (0..n).map(|i| i / 9).collect();
        let dp = DynamicsParams { lengthscale: 2.0, white_variance: 1e-2, weight: 0.5, ..Default::default() };
        let config = LikelihoodConfig { white_floor: 0.05, ..LikelihoodConfig::default() };
        let rows: Vec<usize> = (0..n).step_by(3).collect();
        let mut obj = Objective::sparse(
            SparseLikelihood::new(&y, d, q).unwrap(),
            rows,
            config,
            Some(DynamicsPrior::new(&times, &seg, q, dp).unwrap()),
            Some(ConnectivityPrior::new(n, q, ConnectivityParams { weight: 0.3, ..Default::default() }).unwrap()),
        )
        .unwrap()
        .with_signal_prior(Some(SignalPrior { median: 0.4, log_sd: 0.7 }))
        .unwrap();
        // σw² = 0.02 is below the relative floor 0.05 σf² = 0.045; 0.08 is above it.
        for white in [0.02, 0.08] {
            let p = obj.layout().pack(&x, &Hyper { rbf_variance: 0.9, lengthscale: 1.1, white_variance: white });
            let mut g = vec![0.0; p.len()];
            obj.evaluate(&p, &mut g);
            assert!(obj.last().error.is_none(), "{:?}", obj.last().error);
            assert_eq!(obj.last().white_clamped, white < 0.045);
            let mut scratch = vec![0.0; p.len()];
            let fd = central_diff(&p, 1e-5, |pp| obj.evaluate(pp, &mut scratch));
            let err = max_rel_err(&g, &fd);
            assert!(err < 1e-6, "σw² {white}: {err:e}");
        }
        let dense_config = LikelihoodConfig { jitter: crate::gplvm::Jitter::NONE, ..config };
        let mut dense = Objective::new(Likelihood::new(&y, d, q, dense_config).unwrap(), None, None).unwrap();
        let all: Vec<usize> = (0..n).collect();
        let mut sparse = Objective::sparse(SparseLikelihood::new(&y, d, q).unwrap(), all, config, None, None).unwrap();
        let h = Hyper { rbf_variance: 0.9, lengthscale: 1.1, white_variance: 0.08 };
        let (pd, ps) = (dense.layout().pack(&x, &h), sparse.layout().pack(&x, &h));
        let (vd, vs) = (dense.evaluate(&pd, &mut vec![0.0; pd.len()]), sparse.evaluate(&ps, &mut vec![0.0; ps.len()]));
        assert!((vd - vs).abs() < 1e-5 * vd.abs(), "dense {vd} vs sparse {vs}");
        let beyond = vec![0, n];
        assert!(Objective::sparse(SparseLikelihood::new(&y, d, q).unwrap(), beyond, config, None, None).is_err());
    }

    /// A non-finite input is NaN (it stops the optimisers) with a zero gradient and a
    /// recorded reason, not a panic; an indefinite K (no jitter allowed) is +∞.
    #[test]
    fn failure_is_nan_or_infinite() {
        let (mut obj, mut p) = objective(10, 3, 2, false);
        let n = p.len();
        p[n - 2] = f64::NAN;
        let mut g = vec![1.0; n];
        assert!(obj.evaluate(&p, &mut g).is_nan());
        assert!(g.iter().all(|v| *v == 0.0));
        assert!(matches!(obj.last().error, Some(GplvmError::NonFinite(_))));
        let (x, y) = random_problem(4, 2, 1, 3);
        let config = LikelihoodConfig { jitter: crate::gplvm::Jitter::NONE, white_floor: 0.0, ..Default::default() };
        let mut obj = Objective::new(Likelihood::new(&y, 2, 1, config).unwrap(), None, None).unwrap();
        let same: Vec<f64> = x.iter().map(|_| 0.5).collect();
        let p = obj.layout().pack(&same, &Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 1e-300 });
        let mut g = vec![1.0; p.len()];
        assert_eq!(obj.evaluate(&p, &mut g), f64::INFINITY);
        assert!(g.iter().all(|v| *v == 0.0));
        assert!(obj.last().error.is_some());
    }
}

#[cfg(test)]
mod signal_tests {
    use super::SignalPrior;

    /// Known answers: zero at the median; one log sd away it is ½ with slope 1/s; the
    /// slope matches central differences.
    #[test]
    fn signal_prior_known_values() {
        let p = SignalPrior { median: 2.0, log_sd: 0.5 };
        assert_eq!(p.value_grad(2f64.ln()), (0.0, 0.0));
        let (v, g) = p.value_grad(2f64.ln() + 0.5);
        assert!((v - 0.5).abs() < 1e-15 && (g - 2.0).abs() < 1e-14, "{v} {g}");
        let u = 1.3;
        let h = 1e-5;
        let fd = (p.value_grad(u + h).0 - p.value_grad(u - h).0) / (2.0 * h);
        assert!((fd - p.value_grad(u).1).abs() < 1e-9);
        assert!(SignalPrior { median: 0.0, log_sd: 1.0 }.check().is_err());
    }
}
