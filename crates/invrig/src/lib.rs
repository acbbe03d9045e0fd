//! Inverse rig mapping (Holden, Saito and Komura 2017, `shared/papers/holden2017-…`):
//! from positions a rig produces (joints, vertices, markers) back to the rig's controls,
//! learned from the animator's own poses.
//!
//! - [`gpr`]: Gaussian-process regression with the multiquadric kernel
//!   $k(x, x') = \sqrt{\lVert x - x'\rVert^2 + \theta_0^2}$ (Eq. 1–6), solved with a
//!   symmetric-indefinite factorization (the kernel is only conditionally positive
//!   definite), and $\theta_0$ by the paper's cross-validated line search (§4.1.1).
//! - [`subsample`]: the training set: the rest pose, farthest points, then the points the
//!   regression gets most wrong (Eq. 7–12).
//! - [`refine`]: damped least squares on the rig's Jacobian (Eq. 13), with a
//!   finite-difference Jacobian evaluated in one batch of poses.
//!
//! - [`mapping`]: a fitted mapping and the ways of applying it (the paper's Table 1).
//! - [`points`]: which mesh points the mapping reads.
//!
//! Data are row-major: `n` rows of `d` position coordinates (`x`) or `c` controls (`y`).
//! Units are the caller's; nothing here rescales.

pub mod error;
pub mod gpr;
pub mod mapping;
pub mod points;
pub mod refine;
pub mod subsample;

pub use error::{InvrigError, Result};
