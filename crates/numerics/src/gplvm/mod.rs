//! The GPLVM of Bailey et al. 2016 §4.3: an RBF + white Gaussian-process latent variable
//! model with a dynamics prior and a connectivity prior, as value-and-gradient functions
//! for a MAP fit (see [`crate::scg`]) and the predictive map used after the fit.
//!
//! Conventions (`../shared/method.md` §1–§3):
//! - $Y \in \mathbb R^{N\times D}$ (centred; one row per frame) and
//!   $X \in \mathbb R^{N\times q}$ are row-major slices.
//! - Every function returns an *energy* to be minimised, never a log density:
//!   the negative log likelihood $-\log p(Y\mid X)$ ([`Likelihood`]), the negative log
//!   priors $-\psi_D$ ([`DynamicsPrior`]) and $-\psi_C$ ([`ConnectivityPrior`]), and their
//!   sum $E$ ([`Objective`]). Gradients are gradients of that energy.
//! - Kernel: $k(x, x') = \sigma_f^2 \exp(-\lVert x-x'\rVert^2/(2\ell^2)) + \sigma_w^2\delta$
//!   ([`Hyper`]). The optimiser sees the positive hyperparameters in log space:
//!   $(\log\sigma_f^2, \log\ell, \log\sigma_w^2)$ — scale-free and what GPmat's current
//!   `exp` transform does; GPy's softplus differs only far from 0 (method.md §1.2). The
//!   flat parameter vector is described by [`Layout`].
//! - Jitter ([`Jitter`]): a fixed amount is always added to the diagonal of $K$ (default
//!   $10^{-8}$, GPy's), escalated ×10 on Cholesky failure up to a cap; the amount actually
//!   used is reported with every evaluation.
//! - White-variance floor: the kernel uses $\max(\sigma_w^2, r\,\sigma_f^2)$ with
//!   $r$ = [`LikelihoodConfig::white_floor`] (method.md §1.6), and the gradient is that of
//!   the clamped function.
//! - Parallelism is a parameter ([`faer::Par`]); the default is sequential, so that
//!   labels can be fitted in parallel by an outer rayon loop.
//!
//! Module map: [`params`] (hyperparameters, jitter, layout), [`kernel`] (the RBF kernel),
//! [`likelihood`], [`dynamics`], [`connectivity`], [`objective`] (their sum), [`predict`]
//! (posterior mean, its Jacobian and variance), [`mod@fit`] (initialisation and the MAP fit),
//! [`latent`] (latent density, best latent point for an output), [`model`] (latent
//! point → PCA coordinates → rig controls).

pub mod connectivity;
pub mod dynamics;
pub mod fit;
pub mod kernel;
pub mod latent;
pub mod likelihood;
pub mod model;
pub mod objective;
pub mod params;
pub mod predict;
pub mod sparse;

#[cfg(test)]
pub(crate) mod testutil;

pub use connectivity::{
    coarse_groups, spread_rows, subset_rows, ConnectivityEval, ConnectivityParams, ConnectivityPrior,
};
pub use dynamics::{DynamicsParams, DynamicsPrior};
pub use fit::{fit, fit_observed, ConnectivityPath, Evaluation, Fit, FitConfig, FitData, Optimizer};
pub use latent::{best_latent, LatentDensity, ProjectOptions, Projection};
pub use likelihood::{Likelihood, LikelihoodConfig, LikelihoodEval};
pub use model::{LatentModel, RigMap};
pub use objective::{EvalInfo, Objective, SignalPrior};
pub use params::{Hyper, HyperGrad, Jitter, Layout};
pub use predict::{MeanPredictor, Predictor};
pub use sparse::{infer_latent, SparseLikelihood};

/// Why a GPLVM computation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GplvmError {
    /// Slices of the wrong length, or empty problems.
    #[error("gplvm shape: {0}")]
    Shape(String),
    /// Invalid parameters (non-positive variances, non-finite values …).
    #[error("gplvm parameters: {0}")]
    Params(String),
    /// A covariance matrix stayed indefinite after the last jitter escalation.
    #[error("gplvm: {what} is not positive definite even with jitter {jitter:e} added to its diagonal")]
    NotPositiveDefinite {
        /// Which matrix (`"K"` or `"K_t"`).
        what: &'static str,
        /// The largest jitter tried.
        jitter: f64,
    },
    /// The symmetric eigendecomposition of the connectivity prior did not converge.
    #[error("gplvm: the eigendecomposition of the connectivity prior did not converge")]
    Eigen,
    /// A value or gradient came out NaN or infinite.
    #[error("gplvm: non-finite {0}")]
    NonFinite(&'static str),
    /// The objective or its gradient became NaN during a fit.
    #[error("gplvm: the fit diverged at iteration {iteration} (evaluation {evaluations}): {cause}")]
    Diverged {
        /// Iterations completed.
        iteration: usize,
        /// Evaluations made.
        evaluations: usize,
        /// What failed.
        cause: String,
    },
}
