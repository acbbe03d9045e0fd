//! BVH motion capture for reprise: a hand-written, line-numbered parser
//! ([`read`], [`parse`]), ingest of the motion as rig-control curves at a fixed frame rate
//! ([`ingest`]), and a forward-kinematics rig over the same controls ([`BvhRig`]).
//!
//! # Conventions
//! - **Controls** (same list, same order for ingest and rig; group "joints"): per joint in
//!   hierarchy order, `<joint>.tx .ty .tz` (unit "bvh", i.e. file units) if it has any
//!   position channel, then `<joint>.rx .ry .rz` (unit "rad") if it has any rotation
//!   channel. Defaults are 0. Duplicate joint names get `#2`, `#3`, … appended.
//! - **Rotations**: the Euler channels in their declared order, intrinsic, degrees in the
//!   file: `Zrotation Xrotation Yrotation` means `R = Rz · Rx · Ry` (column vectors). The
//!   control is its rotation vector (axis · angle in radians), continuous across frames.
//! - **Translations**: position channels REPLACE the OFFSET of their joint (root or not),
//!   the usual reading for the root; FK uses `world = parent · T(t) · R`, where `t` is the
//!   position channels (or the OFFSET for joints without them). Axes a joint has no
//!   position channel for carry the OFFSET's component in the ingested curves.
//! - **Lengths** stay in file units (CMU files: CMU units, not metres).
//! - **Time**: the source rate is `1 / Frame Time`, snapped to an integer rate when within
//!   a relative 1e-4 (`.0083333` → 120 fps).

mod error;
mod ingest;
mod parse;
mod rig;
pub mod rotation;
mod skeleton;

pub use error::BvhError;
pub use ingest::{ingest, ingest_limited, resample, resample_limited, BvhCurves, ControlInfo, MAX_FRAMES};
pub use parse::{parse, read, MAX_DEPTH};
pub use rig::BvhRig;
pub use skeleton::{Bvh, Channel, ControlKind, ControlSpec, Node, OFFSET_TOLERANCE};
