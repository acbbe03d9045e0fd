//! The artifact contract of reprise: every table a stage writes or reads, with its
//! columns, schema version and typed, checked read/write. No math lives here.
//!
//! | artifact | module | producer | consumers |
//! |---|---|---|---|
//! | `frames` | [`frames`] | ingest | label |
//! | `controls` | [`controls`] | ingest | label, scale, every mesh-space stage |
//! | `clips` | [`clips`] | ingest | label |
//! | `segments` | [`segments`] | label | pca, gplvm, synthesize, motion-graph |
//! | `labeled_frames` | [`frames`] | label | scale, pca, motion-graph, evaluate |
//! | `scales` | [`scales`] | scale | pca, bridges, synthesize |
//! | `pca_models`, `pca_coords`, `pca_errors` | [`pca`] | pca | gplvm, bridges, evaluate |
//! | `gplvm_latents`, `gplvm_models`, `gplvm_trace`, `gplvm_fits` | [`gplvm`] | gplvm | bridges, synthesize, evaluate |
//! | `bridges` | [`bridges`] | bridges | synthesize, evaluate |
//! | `curves` | [`curves`] | synthesize | evaluate, glTF export |
//! | `mg_nodes`, `mg_edges` | [`motion_graph`] | motion-graph | transitions |
//! | `transition_requests` | [`transitions`] | transitions | evaluate |
//! | `positions` | [`positions`] | positions (or a user) | invrig-apply, retarget-fit, retarget |
//! | `invrig`, `invrig_errors` | [`invrig`] | invrig-fit, invrig-apply | positions, invrig-apply |
//! | `retarget`, `retarget_frames` | [`retarget`] | retarget-fit, retarget | retarget |
//!
//! Every file carries provenance ([`provenance`]) in its Parquet key-value metadata and
//! is written atomically ([`table::write_atomic`]).
#![warn(missing_docs)]

pub mod contain;
pub mod content;
pub mod error;
pub mod input;
pub mod partition;
pub mod provenance;
pub mod stream;
pub mod table;
mod kinds {
    pub mod bridges;
    pub mod clips;
    pub mod controls;
    pub mod curves;
    pub mod frames;
    pub mod gplvm;
    pub mod invrig;
    pub mod motion_graph;
    pub mod pca;
    pub mod positions;
    pub mod retarget;
    pub mod scales;
    pub mod segments;
    pub mod transitions;
}
pub use kinds::{
    bridges, clips, controls, curves, frames, gplvm, invrig, motion_graph, pca, positions, retarget, scales, segments,
    transitions,
};

pub use error::{ArtifactError, Result};
pub use provenance::Provenance;
pub use table::{Columns, Kind, Table};
