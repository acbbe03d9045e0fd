//! Semi-supervised facial retargeting (Bouaziz and Pauly,
//! `shared/papers/bouaziz-semi-supervised-facial-retargeting.md`): the pieces of a shared
//! GPLVM over a source space (capture) and a target space (a character's controls).
//!
//! - [`align`]: semi-supervised manifold alignment (Ham et al. 2005), the latents' start.
//! - [`baselines`]: ridge regression and GPR on the labelled pairs alone.
//! - [`lle`]: the locally-linear-embedding prior over the shared latents (Eq. 5–8).
//! - [`model`]: a fitted model over a training set, and [`model::Mapper`], which maps
//!   one frame at a time.
//! - [`pose`]: a full pose from a few fixed controls (the paper's Fig. 8).
//! - [`protocol`]: the paper's comparison on a blocked split: RMS against label count for
//!   every method over random draws of the labelled frames.
//! - [`shared`]: the shared GPLVM over index sets (Eq. 1–5): objective and gradient, an
//!   initialisation, the L-BFGS fit, and each space's GP mean (Eq. 16, 18).
//! - [`source`]: the per-frame source solve with the temporal term and missing markers
//!   (Eq. 12–17).
//! - [`target`]: a character's controls as the target space (scaled by their effect on
//!   the mesh, reduced by PCA).
//!
//! Data are row-major: `n` rows of `d` values.

pub mod align;
pub mod baselines;
pub mod lle;
pub mod model;
pub mod pose;
pub mod protocol;
pub mod shared;
pub mod source;
pub mod target;
