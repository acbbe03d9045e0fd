//! reprise's numerics, with no I/O. Conventions: `f64` throughout; matrices of samples
//! are row-major `N × D` slices (one row per frame) unless a type says otherwise.
//!
//! - [`scaling`]: the per-control weights of Bailey et al. 2016, Eq. 3.
//! - [`pca`]: principal component analysis by a dense thin SVD (faer).
//! - [`gplvm`]: the RBF + white GPLVM likelihood, dynamics and connectivity priors, their
//!   gradients, and prediction; [`scg`]: the Netlab scaled conjugate gradient optimiser;
//!   [`lbfgs`]: limited-memory BFGS; [`optim`]: their shared convergence rule and results.
//! - [`stats`], [`vector`]: column statistics and Euclidean lengths.
#![warn(missing_docs)]

pub mod gplvm;
pub mod lbfgs;
pub mod optim;
pub mod pca;
pub mod scaling;
pub mod scg;
pub mod stats;
pub mod vector;
