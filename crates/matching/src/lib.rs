//! Motion-matching and crossfade transition baselines in rig space (method.md §7,
//! Clavet 2016 as implemented in Holden's `orangeduck/Motion-Matching`). No I/O.
//!
//! Each module's docs give its math and conventions; everything is re-exported at the root.
//!
//! - [`Database`]: training frames as scaled controls $z_t\in\mathbb R^C$, one label and one
//!   segment (take) per frame, the frame rate.
//! - [`FeatureDb`]: per frame, group-normalised features from caller-supplied low-dimensional
//!   coordinates $y_t\in\mathbb R^q$ (top PCA scores): $y_t$, $y_{t+4}$, $y_{t+8}$, $y_{t+12}$,
//!   $\dot y_t$ ([`features`] module docs); the searchable frames (12 frames of continuation
//!   in their segment, or, for a label whose segments are all shorter, the most they allow:
//!   [`FeatureDb::continuation_of`]); block bounding boxes.
//! - [`search`]: [`FeatureDb::search`] (AABB-accelerated) and [`FeatureDb::search_brute`]
//!   return the same [`Match`] over a [`FrameSet`] of allowed frames.
//! - [`spring`]: [`Inertializer`], one critically damped spring per control
//!   ([`decay_spring`]).
//! - [`controller`]: [`Controller`] / [`transition`] play the database, search the requested
//!   label on a 0.1 s cadence and inertialize each jump (timeline, query and switch rule in
//!   the module docs); the output is a [`Playback`].
//! - [`crossfade`](mod@crossfade): the floor — nearest target pose in $z$, then the Motion
//!   Graphs ease over `blend_frames` (fewer for a label whose segments are all shorter:
//!   [`crossfade_blend`]).
//!
//! ```
//! use reprise_matching::*;
//! // Two takes at 24 fps: label 0 then label 1, one control, y = z.
//! let z: Vec<f64> = (0..80).map(|t| (f64::from(t) * 0.2).sin()).collect();
//! let labels: Vec<u32> = (0..80).map(|t| u32::from(t >= 40)).collect();
//! let db = Database::new(z.clone(), 1, labels.clone(), &labels, 24.0)?;
//! let feats = FeatureDb::build(&db, &z, 1, &FeatureParams::default())?;
//! let request = TransitionRequest { start: 10, target: 1, first_search: 1, frames: 30 };
//! let out = transition(&db, &feats, &request, &ControllerSettings::default())?;
//! assert_eq!(out.latency, Some(1));
//! let floor = crossfade(&db, 10, 1, 12, 30)?;
//! assert_eq!(floor.latency, Some(0));
//! # Ok::<(), MatchError>(())
//! ```
#![warn(missing_docs)]

pub mod controller;
pub mod crossfade;
pub mod database;
pub mod error;
pub mod features;
pub mod playback;
pub mod search;
pub mod spring;
#[cfg(test)]
mod testutil;

pub use controller::{transition, Controller, ControllerSettings, StepInfo, TransitionRequest};
pub use crossfade::{crossfade, crossfade_blend, crossfade_candidates, nearest_pose, Crossfader, FadeFrame};
pub use database::{Database, FrameSet};
pub use error::{MatchError, Result};
pub use features::{FeatureDb, FeatureGroup, FeatureParams, GroupKind};
pub use playback::Playback;
pub use search::{Exclusion, Match};
pub use spring::{decay_spring, spring_rate, Inertializer};

#[cfg(test)]
mod tests {
    /// Models, settings and errors can cross threads (a stage may search in parallel).
    #[test]
    fn autotraits() {
        fn check<T: Send + Sync + Unpin>() {}
        check::<crate::Database>();
        check::<crate::FeatureDb>();
        check::<crate::FrameSet>();
        check::<crate::Controller<'_>>();
        check::<crate::Playback>();
        check::<crate::MatchError>();
        check::<crate::Inertializer>();
    }
}
