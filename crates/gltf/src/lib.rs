//! glTF 2.0 characters for reprise: every animation as a clip of rig-control curves
//! ([`ingest`]), and the character as a rig evaluator from controls to mesh vertices
//! ([`GltfRig`]), and clips of curves written back into a copy of the file as new
//! animations ([`export`]).
//!
//! Conventions (all public items follow them):
//! * Rotation controls `<node>.rx/.ry/.rz` are a rotation vector `v` (axis · angle, radians)
//!   relative to the node's rest rotation: `R = R_rest · exp([v]×)`, continuous across frames.
//! * Translation controls `<node>.tx/.ty/.tz` are metres added to the rest translation; scale
//!   controls `<node>.sx/.sy/.sz` are ratios to the rest scale; morph controls
//!   `<node>.morph.<target>` are morph-target weights.
//! * Control order: by node index, then rx, ry, rz, tx, ty, tz, sx, sy, sz, then morphs.
//! * Vertices: xyz interleaved, world space of the default scene, metres.
//!
//! Only the file's JSON, its buffers and nothing else are read: no images are decoded and
//! nothing is downloaded. Required extensions that change geometry or animation data
//! (Draco, meshopt, mesh quantization, …) are refused by name.

mod channels;
pub mod controls;
mod error;
mod export;
mod ingest;
mod load;
mod mesh;
mod rig;
pub mod rotation;
pub mod sample;
pub mod scene;

pub use controls::ControlInfo;
pub use error::GltfError;
pub use export::{export, ExportClip};
pub use ingest::{ingest, ingest_limited, ClipCurves, GltfCurves, MAX_FRAMES};
pub use rig::GltfRig;
pub use scene::{NodeInfo, SceneGraph};
