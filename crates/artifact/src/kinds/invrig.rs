//! `invrig`: a fitted inverse rig mapping (Holden et al. 2017): the animator's poses the
//! regression was fitted on, in the order the subsampling took them, and its settings.
//!
//! The columns are a `frames` table's (`clip`, `frame`, `time`, one Float64 column per
//! control, see [`crate::frames`]): the poses taken, by clip and frame; the rig's rest pose
//! is clip [`REST_CLIP`].
//! The positions the regression reads are the rig's, evaluated at these controls on
//! [`Mapping::points`], so the table and the rig together are the whole mapping.
//!
//! Metadata: `reprise.fps` and `reprise.invrig`, the JSON of [`Mapping`].

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::frames::Frames;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the inverse-rig-mapping table.
pub const INVRIG: Kind = Kind { name: "invrig", version: 1 };
/// The clip name of the rig's rest pose among the poses.
pub const REST_CLIP: &str = "(rest pose)";
/// Metadata key: the mapping's settings.
pub const KEY_MAPPING: &str = "reprise.invrig";

/// How the mapping was fitted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mapping {
    /// The points (vertex indices of the rig's mesh) whose positions the mapping reads.
    pub points: Vec<i64>,
    /// The multiquadric's $\theta_0$, in the rig's length unit.
    pub theta0: f64,
    /// The Tikhonov term $\theta_1$.
    pub theta1: f64,
    /// Controls the training poses move (the others are held by the refinement).
    pub free_controls: Vec<String>,
    /// The cross-validation: `(theta0, mean validation error)` per candidate.
    pub cross_validation: Vec<(f64, f64)>,
    /// Training frames the poses were taken from.
    pub training_frames: usize,
    /// Clips left out of training.
    pub held_out_clips: Vec<String>,
}

/// A fitted mapping: its poses and settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Invrig {
    /// The poses taken, by clip and frame.
    pub samples: Frames,
    /// The settings.
    pub mapping: Mapping,
}

impl Invrig {
    /// Writes the table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        let mut meta = self.samples.fps_meta();
        meta.push((KEY_MAPPING.into(), serde_json::to_string(&self.mapping).expect("the mapping serialises")));
        crate::table::write(path, INVRIG, self.samples.columns(Columns::new()), provenance, &meta)
    }

    /// Reads the table, checking its kind and that every free control is a column.
    pub fn read(path: &Path) -> Result<Self> {
        let table = Table::read(path, INVRIG)?;
        let mapping: Mapping = serde_json::from_str(table.meta(KEY_MAPPING)?)
            .map_err(|e| table.invalid(format!("metadata `{KEY_MAPPING}`: {e}")))?;
        let samples = Frames::from_table(&table, &[])?;
        if let Some(c) = mapping.free_controls.iter().find(|c| !samples.controls.contains(c)) {
            return Err(table.invalid(format!("free control `{c}` is not a column")));
        }
        if samples.rows() == 0 || mapping.points.is_empty() {
            return Err(table.invalid("a mapping needs at least one pose and one point"));
        }
        Ok(Self { samples, mapping })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.parquet");
        let m = Invrig {
            samples: Frames {
                fps: 24.0,
                controls: vec!["a".into(), "b".into()],
                clip: vec!["t".into(), "t".into()],
                frame: vec![3, 5],
                time: vec![0.125, 5.0 / 24.0],
                values: vec![1.0, 2.0, 3.0, 4.0],
            },
            mapping: Mapping {
                points: vec![0, 7],
                theta0: 0.5,
                theta1: 1e-5,
                free_controls: vec!["b".into()],
                cross_validation: vec![(0.5, 0.1), (1.0, 0.2)],
                training_frames: 10,
                held_out_clips: vec!["roar".into()],
            },
        };
        m.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert_eq!(Invrig::read(&path).unwrap(), m);
    }
}
