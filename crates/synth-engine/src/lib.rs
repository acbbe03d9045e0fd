//! Synthesis of new animation in GPLVM latent spaces (Bailey et al. 2016 §5): the
//! constrained particle ([`particle`]), its smooth random force ([`random`]), paths
//! ([`path`]), and the command engine that turns a script of MOVE / IDLE / TRANSITION /
//! PLAY commands into per-frame latent points and rig controls ([`engine`], [`script`]).
#![warn(missing_docs)]

pub mod engine;
pub mod method;
pub mod particle;
pub mod path;
pub mod random;
pub mod script;
