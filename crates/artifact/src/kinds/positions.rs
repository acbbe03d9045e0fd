//! `positions`: points of a character over time, without rig curves: joints, mesh vertices
//! or markers, one row per (clip, frame, point). What inverse rig mapping reads.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `clip` | Utf8 | clip (take) name |
//! | `frame` | Int64 | frame number within the clip, from 0 |
//! | `point` | Int64 | the point: the index of the vertex (joint, for a skeleton) in the rig's evaluated mesh |
//! | `x`, `y`, `z` | Float64 | its position, in the rig's length unit |
//!
//! Every frame holds the same points in the same order; frames within a clip strictly
//! increase. Metadata: `reprise.fps`. A table a user writes is read the same way: any
//! integer or float type for `frame` and `point`, any numeric type for `x, y, z`, and
//! `reprise.fps` (or the reader's `fps`) for the rate.

use std::path::Path;

use crate::error::{ArtifactError, Result};
use crate::frames::KEY_FPS;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the positions table.
pub const POSITIONS: Kind = Kind { name: "positions", version: 1 };
/// Most points a frame may hold (a bound on what a user's table can make us allocate).
pub const MAX_POINTS: usize = 1 << 20;

/// Points of many clips over time.
#[derive(Debug, Clone, PartialEq)]
pub struct Positions {
    /// Frames per second.
    pub fps: f64,
    /// The points, in the order of every frame's values.
    pub points: Vec<i64>,
    /// Clip of each frame.
    pub clip: Vec<String>,
    /// Frame number of each frame.
    pub frame: Vec<i64>,
    /// Positions, `3 · points.len()` per frame (`x0, y0, z0, x1, …`), frame-major.
    pub values: Vec<f64>,
}

impl Positions {
    /// Frames.
    pub fn frames(&self) -> usize {
        self.clip.len()
    }

    /// Position values per frame, `3 · points`.
    pub fn width(&self) -> usize {
        3 * self.points.len()
    }

    /// One frame's positions.
    pub fn row(&self, i: usize) -> &[f64] {
        let w = self.width();
        &self.values[i * w..(i + 1) * w]
    }

    /// Row ranges `(clip, first, end_exclusive)` of consecutive frames per clip.
    pub fn clip_runs(&self) -> Vec<(String, usize, usize)> {
        crate::frames::clip_runs(&self.clip)
    }

    /// Writes the table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        let p = self.points.len();
        let n = self.frames() * p;
        let mut clip = Vec::with_capacity(n);
        let mut frame = Vec::with_capacity(n);
        let mut point = Vec::with_capacity(n);
        let mut xyz = [Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n)];
        for f in 0..self.frames() {
            for (k, &pt) in self.points.iter().enumerate() {
                clip.push(self.clip[f].as_str());
                frame.push(self.frame[f]);
                point.push(pt);
                for (a, axis) in xyz.iter_mut().enumerate() {
                    axis.push(self.values[f * 3 * p + 3 * k + a]);
                }
            }
        }
        let [x, y, z] = xyz;
        let cols = Columns::new()
            .str("clip", &clip)
            .i64("frame", frame)
            .i64("point", point)
            .f64("x", x)
            .f64("y", y)
            .f64("z", z);
        crate::table::write(path, POSITIONS, cols, provenance, &[(KEY_FPS.into(), self.fps.to_string())])
    }

    /// Reads a positions table: one this crate wrote or a user's (see the module). `fps`
    /// is used when the table has no `reprise.fps`.
    ///
    /// # Errors
    /// A missing column, a null or non-finite value (naming the row and column), a frame
    /// whose points differ from the first frame's, frames out of order within a clip, no
    /// rate, or more than [`MAX_POINTS`] points.
    pub fn read(path: &Path, fps: Option<f64>) -> Result<Self> {
        let table = Table::read_any(path)?;
        let rate = match table.metadata().get(KEY_FPS) {
            Some(v) => v.parse::<f64>().map_err(|_| table.invalid(format!("metadata `{KEY_FPS}` is not a number")))?,
            None => fps.ok_or_else(|| {
                table.invalid(format!("no `{KEY_FPS}` metadata: give the frame rate (the stage's --fps)"))
            })?,
        };
        if !(rate.is_finite() && rate > 0.0) {
            return Err(table.invalid(format!("frame rate {rate} must be positive")));
        }
        let clip = table.strings("clip")?;
        let integers = |name: &str| -> Result<Vec<i64>> {
            let v = table.numbers(name)?;
            match v.iter().position(|x| x.fract() != 0.0 || x.abs() > 9.0e15) {
                Some(row) => Err(table.invalid(format!("row {row}, column `{name}`: {} is not an integer", v[row]))),
                None => Ok(v.into_iter().map(|x| x as i64).collect()),
            }
        };
        let (frame, point) = (integers("frame")?, integers("point")?);
        let xyz = [table.numbers("x")?, table.numbers("y")?, table.numbers("z")?];
        if table.rows() == 0 {
            return Err(table.invalid("no rows"));
        }
        // The first frame's points.
        let first = (1..clip.len()).find(|&r| clip[r] != clip[0] || frame[r] != frame[0]).unwrap_or(clip.len());
        if first > MAX_POINTS {
            return Err(table.invalid(format!("the first frame has {first} points; at most {MAX_POINTS}")));
        }
        let points: Vec<i64> = point[..first].to_vec();
        if let Some(row) = points.iter().position(|&p| p < 0) {
            return Err(table.invalid(format!("row {row}, column `point`: {} is negative", points[row])));
        }
        if clip.len() % first != 0 {
            return Err(
                table.invalid(format!("{} rows are not whole frames of the first frame's {first} points", clip.len()))
            );
        }
        let frames = clip.len() / first;
        let mut out = Self {
            fps: rate,
            points,
            clip: Vec::with_capacity(frames),
            frame: Vec::with_capacity(frames),
            values: Vec::with_capacity(3 * clip.len()),
        };
        for f in 0..frames {
            let r0 = f * first;
            for k in 0..first {
                let r = r0 + k;
                if clip[r] != clip[r0] || frame[r] != frame[r0] || point[r] != out.points[k] {
                    return Err(table.invalid(format!(
                        "row {r}: expected point {} of clip `{}` frame {} (every frame holds the first frame's points \
                         in its order), found point {} of clip `{}` frame {}",
                        out.points[k], clip[r0], frame[r0], point[r], clip[r], frame[r]
                    )));
                }
                out.values.extend(xyz.iter().map(|axis| axis[r]));
            }
            if f > 0 && clip[r0] == out.clip[f - 1] && frame[r0] <= out.frame[f - 1] {
                return Err(table.invalid(format!(
                    "row {r0}: clip `{}` frame {} does not follow frame {}",
                    clip[r0],
                    frame[r0],
                    out.frame[f - 1]
                )));
            }
            out.clip.push(clip[r0].clone());
            out.frame.push(frame[r0]);
        }
        Ok(out)
    }
}

/// The error for positions whose points are not the ones a mapping or rig expects.
pub fn point_mismatch(path: &Path, expected: &[i64], found: &[i64]) -> ArtifactError {
    let first = expected.iter().zip(found).position(|(a, b)| a != b).unwrap_or(expected.len().min(found.len()));
    ArtifactError::Invalid {
        path: path.to_path_buf(),
        message: format!(
            "holds {} points per frame where {} are expected; they first differ at position {first} \
             (point {} where {} was expected)",
            found.len(),
            expected.len(),
            found.get(first).map_or("none".into(), |p| p.to_string()),
            expected.get(first).map_or("none".into(), |p| p.to_string()),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Positions {
        Positions {
            fps: 24.0,
            points: vec![4, 1],
            clip: vec!["a".into(), "a".into(), "b".into()],
            frame: vec![0, 1, 0],
            values: (0..18).map(f64::from).collect(),
        }
    }

    #[test]
    fn round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.parquet");
        let p = sample();
        p.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        let back = Positions::read(&path, None).unwrap();
        assert_eq!(back, p);
        assert_eq!(back.row(2), &[12.0, 13.0, 14.0, 15.0, 16.0, 17.0]);
        assert_eq!(back.clip_runs(), vec![("a".into(), 0, 2), ("b".into(), 2, 3)]);
    }

    #[test]
    fn a_frame_with_other_points_or_a_nan_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.parquet");
        let prov = Provenance::new("test", "0", serde_json::json!({}));
        // The writer refuses non-finite values; a user's table may hold them.
        let cols = Columns::new()
            .str("clip", &["a", "a"])
            .i64("frame", vec![0, 0])
            .i64("point", vec![4, 1])
            .f64_any("x", vec![0.0, f64::NAN])
            .f64("y", vec![0.0, 0.0])
            .f64("z", vec![0.0, 0.0]);
        crate::table::write(&path, POSITIONS, cols, &prov, &[(KEY_FPS.into(), "24".into())]).unwrap();
        let err = Positions::read(&path, None).unwrap_err().to_string();
        assert!(err.contains("`x`") && err.contains("row 1"), "{err}");
        let cols = Columns::new()
            .str("clip", &["a", "a", "a", "a"])
            .i64("frame", vec![0, 0, 1, 1])
            .i64("point", vec![4, 1, 4, 2])
            .f64("x", vec![0.0; 4])
            .f64("y", vec![0.0; 4])
            .f64("z", vec![0.0; 4]);
        crate::table::write(&path, POSITIONS, cols, &prov, &[]).unwrap();
        let err = Positions::read(&path, Some(30.0)).unwrap_err().to_string();
        assert!(err.contains("row 3") && err.contains("found point 2"), "{err}");
        let err = Positions::read(&path, None).unwrap_err().to_string();
        assert!(err.contains("frame rate"), "{err}");
    }
}
