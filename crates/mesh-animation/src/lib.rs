//! A mesh's animation, for characters whose rig no viewer knows (the dragon face's 742
//! controls, a blendshape face): every frame's vertices, baked to a mean mesh plus a few
//! morph targets, with per-frame weights.
//!
//! - [`mod@bake`]: the morph targets as principal components of the frames' vertex offsets,
//!   shared by several tracks (e.g. a retargeted take and the known take), and the RMS
//!   vertex error they leave.
//! - [`glb`]: a glTF 2.0 binary of the baked tracks, one node each, side by side, one
//!   animation of their morph weights; Blender or any glTF viewer plays it.
//! - [`player`]: a standalone HTML page that draws the tracks side by side (front view,
//!   flat shaded) with play, pause and a frame slider.
//!
//! Vertices are `x0, y0, z0, x1, …` per frame, in the rig's length unit.

pub mod bake;
pub mod glb;
pub mod player;

pub use bake::{bake, BakeError, Baked};
