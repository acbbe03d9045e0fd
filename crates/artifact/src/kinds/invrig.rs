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
//!
//! `invrig_errors`: what applying a mapping did, one row per (method, clip, frame).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `method` | Utf8 | how the controls were found (`reprise_invrig::mapping::Method`) |
//! | `clip`, `frame` | Utf8, Int64 | the frame of the positions table |
//! | `joint_error` | Float64 | mean over points of $\lVert f(y)_k - x_{*k}\rVert^2$, length unit² |
//! | `joint_distance` | Float64 | mean over points of $\lVert f(y)_k - x_{*k}\rVert$, length unit |
//! | `truth_error` | Float64, null | mean over controls of $(y_j - y^{true}_j)^2$ where the curves are known |
//! | `iterations` | Int64 | refinement steps (0 without refinement) |
//! | `evaluations` | Int64 | rig evaluations the method made |
//! | `ms` | Float64 | wall time of the method for this frame, milliseconds |
//! | `stop` | Utf8 | why the refinement stopped (`converged`, `max-iters`, `no-progress`), empty without one |

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

/// Kind of the per-frame errors of applying a mapping.
pub const INVRIG_ERRORS: Kind = Kind { name: "invrig_errors", version: 1 };

/// One frame found by one method.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameError {
    /// The method's name.
    pub method: String,
    /// Clip.
    pub clip: String,
    /// Frame.
    pub frame: i64,
    /// Mean squared point distance, length unit².
    pub joint_error: f64,
    /// Mean point distance, length unit.
    pub joint_distance: f64,
    /// Mean squared control error, where the curves are known.
    pub truth_error: Option<f64>,
    /// Refinement steps.
    pub iterations: i64,
    /// Rig evaluations.
    pub evaluations: i64,
    /// Milliseconds.
    pub ms: f64,
    /// Why the refinement stopped, or empty.
    pub stop: String,
}

/// Writes the per-frame errors atomically.
pub fn write_errors(path: &Path, rows: &[FrameError], provenance: &Provenance) -> Result<()> {
    let s = |f: fn(&FrameError) -> &str| rows.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .str("method", &s(|r| &r.method))
        .str("clip", &s(|r| &r.clip))
        .i64("frame", rows.iter().map(|r| r.frame).collect())
        .f64("joint_error", rows.iter().map(|r| r.joint_error).collect())
        .f64("joint_distance", rows.iter().map(|r| r.joint_distance).collect())
        .f64_opt("truth_error", rows.iter().map(|r| r.truth_error).collect())
        .i64("iterations", rows.iter().map(|r| r.iterations).collect())
        .i64("evaluations", rows.iter().map(|r| r.evaluations).collect())
        .f64("ms", rows.iter().map(|r| r.ms).collect())
        .str("stop", &s(|r| &r.stop));
    crate::table::write(path, INVRIG_ERRORS, cols, provenance, &[])
}

/// Reads the per-frame errors.
pub fn read_errors(path: &Path) -> Result<Vec<FrameError>> {
    let t = Table::read(path, INVRIG_ERRORS)?;
    let (method, clip, frame) = (t.str("method")?, t.str("clip")?, t.i64("frame")?);
    let (je, jd, te) = (t.f64("joint_error")?, t.f64("joint_distance")?, t.f64_opt("truth_error")?);
    let (it, ev, ms, stop) = (t.i64("iterations")?, t.i64("evaluations")?, t.f64("ms")?, t.str("stop")?);
    Ok((0..t.rows())
        .map(|i| FrameError {
            method: method[i].into(),
            clip: clip[i].into(),
            frame: frame[i],
            joint_error: je[i],
            joint_distance: jd[i],
            truth_error: te[i],
            iterations: it[i],
            evaluations: ev[i],
            ms: ms[i],
            stop: stop[i].into(),
        })
        .collect())
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
        let rows = vec![FrameError {
            method: "gpr".into(),
            clip: "t".into(),
            frame: 2,
            joint_error: 0.5,
            joint_distance: 0.7,
            truth_error: None,
            iterations: 0,
            evaluations: 1,
            ms: 0.25,
            stop: String::new(),
        }];
        let path = dir.path().join("e.parquet");
        write_errors(&path, &rows, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read_errors(&path).unwrap(), rows);
    }
}
