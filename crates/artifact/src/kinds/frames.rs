//! `frames` and `labeled_frames`: rig-control curves, one row per frame, one Float64
//! column per control (in the order of the controls table).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `segment_id` | Int64 | (labeled only) the segment the frame belongs to |
//! | `label` | Utf8 | (labeled only) the segment's label |
//! | `clip` | Utf8 | clip (take) name |
//! | `frame` | Int64 | frame number within the clip at the pipeline rate, from 0 |
//! | `time` | Float64 | seconds from the clip's start, `frame / fps` |
//! | *control* … | Float64 | one column per rig control, in the control's unit |
//!
//! Metadata: `reprise.fps` (frames per second). Labeled frames also carry
//! `reprise.masked_controls`, a JSON list of controls the label stage removed.

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the ingest stage's frame table.
pub const FRAMES: Kind = Kind { name: "frames", version: 1 };
/// Kind of the label stage's labeled frame table.
pub const LABELED_FRAMES: Kind = Kind { name: "labeled_frames", version: 1 };
/// Column: clip name.
pub const CLIP: &str = "clip";
/// Column: frame number.
pub const FRAME: &str = "frame";
/// Column: time in seconds.
pub const TIME: &str = "time";
/// Column: segment id (labeled frames).
pub const SEGMENT_ID: &str = "segment_id";
/// Column: label (labeled frames).
pub const LABEL: &str = "label";
/// Column names a control may not take.
pub const RESERVED: [&str; 5] = [SEGMENT_ID, LABEL, CLIP, FRAME, TIME];
/// Metadata key: frames per second.
pub const KEY_FPS: &str = "reprise.fps";
/// Metadata key: JSON list of masked control names.
pub const KEY_MASKED: &str = "reprise.masked_controls";

/// Rig-control curves of many clips.
#[derive(Debug, Clone, PartialEq)]
pub struct Frames {
    /// Frames per second.
    pub fps: f64,
    /// Control names, the column order.
    pub controls: Vec<String>,
    /// Clip of each row.
    pub clip: Vec<String>,
    /// Frame number of each row.
    pub frame: Vec<i64>,
    /// Time of each row, seconds.
    pub time: Vec<f64>,
    /// Control values, row-major: `values[row * controls.len() + c]`.
    pub values: Vec<f64>,
}

impl Frames {
    /// Number of rows (frames).
    pub fn rows(&self) -> usize {
        self.clip.len()
    }
    /// The control vector of one row.
    pub fn row(&self, i: usize) -> &[f64] {
        let n = self.controls.len();
        &self.values[i * n..(i + 1) * n]
    }
    /// One control's values over all rows.
    pub fn column(&self, c: usize) -> Vec<f64> {
        let n = self.controls.len();
        (0..self.rows()).map(|r| self.values[r * n + c]).collect()
    }
    /// Each control's range, max − min over the frames (0 with no frames).
    pub fn ranges(&self) -> Vec<f64> {
        let n = self.controls.len();
        let mut lo = vec![f64::INFINITY; n];
        let mut hi = vec![f64::NEG_INFINITY; n];
        for r in 0..self.rows() {
            for (j, &v) in self.row(r).iter().enumerate() {
                lo[j] = lo[j].min(v);
                hi[j] = hi[j].max(v);
            }
        }
        lo.iter().zip(&hi).map(|(l, h)| if h >= l { h - l } else { 0.0 }).collect()
    }

    /// `cols` followed by this table's clip, frame, time and control columns.
    pub(crate) fn columns(&self, mut cols: Columns) -> Columns {
        cols = cols.str(CLIP, &self.clip).i64(FRAME, self.frame.clone()).f64(TIME, self.time.clone());
        for (c, name) in self.controls.iter().enumerate() {
            cols = cols.f64(name, self.column(c));
        }
        cols
    }

    /// Writes the frame table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        crate::table::write(path, FRAMES, self.columns(Columns::new()), provenance, &self.fps_meta())
    }

    pub(crate) fn fps_meta(&self) -> Vec<(String, String)> {
        vec![(KEY_FPS.into(), self.fps.to_string())]
    }

    /// Reads a frame table, checking kind, version, column types and finiteness, and
    /// that frames within a clip strictly increase.
    pub fn read(path: &Path) -> Result<Self> {
        let table = Table::read(path, FRAMES)?;
        Self::from_table(&table, &[])
    }

    pub(crate) fn from_table(table: &Table, skip: &[&str]) -> Result<Self> {
        let fps: f64 =
            table.meta(KEY_FPS)?.parse().map_err(|_| table.invalid(format!("metadata `{KEY_FPS}` is not a number")))?;
        let controls: Vec<String> = table
            .column_names()
            .into_iter()
            .filter(|c| !RESERVED.contains(&c.as_str()) && !skip.contains(&c.as_str()))
            .collect();
        let rows = table.rows();
        let mut values = vec![0.0; rows * controls.len()];
        for (c, name) in controls.iter().enumerate() {
            for (r, v) in table.f64(name)?.iter().enumerate() {
                values[r * controls.len() + c] = *v;
            }
        }
        let frames = Self {
            fps,
            clip: table.str(CLIP)?.into_iter().map(String::from).collect(),
            frame: table.i64(FRAME)?.to_vec(),
            time: table.f64(TIME)?.to_vec(),
            controls,
            values,
        };
        if let Some(row) =
            (1..rows).find(|&r| frames.clip[r] == frames.clip[r - 1] && frames.frame[r] <= frames.frame[r - 1])
        {
            return Err(table.invalid(format!(
                "row {row}: clip `{}` frame {} does not follow frame {}",
                frames.clip[row],
                frames.frame[row],
                frames.frame[row - 1]
            )));
        }
        Ok(frames)
    }

    /// Row ranges `(clip, first_row, end_row_exclusive)` of consecutive rows per clip.
    pub fn clip_runs(&self) -> Vec<(String, usize, usize)> {
        clip_runs(&self.clip)
    }
}

/// Row ranges `(clip, first_row, end_row_exclusive)` of consecutive equal names in `clip`.
pub fn clip_runs(clip: &[String]) -> Vec<(String, usize, usize)> {
    let mut runs: Vec<(String, usize, usize)> = Vec::new();
    for (r, name) in clip.iter().enumerate() {
        match runs.last_mut() {
            Some(last) if &last.0 == name => last.2 = r + 1,
            _ => runs.push((name.clone(), r, r + 1)),
        }
    }
    runs
}

/// Frames that carry a label and a segment, as written by the label stage.
#[derive(Debug, Clone, PartialEq)]
pub struct LabeledFrames {
    /// Segment of each row.
    pub segment_id: Vec<i64>,
    /// Label of each row.
    pub label: Vec<String>,
    /// The curves (only the controls kept after masking).
    pub frames: Frames,
    /// Controls removed by the mask.
    pub masked_controls: Vec<String>,
}

impl LabeledFrames {
    /// Writes the labeled frame table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        let cols = Columns::new().i64(SEGMENT_ID, self.segment_id.clone()).str(LABEL, &self.label);
        let mut meta = self.frames.fps_meta();
        meta.push((KEY_MASKED.into(), serde_json::to_string(&self.masked_controls).expect("strings serialise")));
        crate::table::write(path, LABELED_FRAMES, self.frames.columns(cols), provenance, &meta)
    }

    /// Row ranges `[start, end)` of consecutive rows of one segment with consecutive frames.
    pub fn segment_runs(&self) -> Vec<(usize, usize)> {
        segment_runs(&self.segment_id, &self.frames.frame)
    }

    /// Reads a labeled frame table with the same checks as [`Frames::read`].
    pub fn read(path: &Path) -> Result<Self> {
        let table = Table::read(path, LABELED_FRAMES)?;
        let masked_controls = serde_json::from_str(table.meta(KEY_MASKED)?)
            .map_err(|e| table.invalid(format!("metadata `{KEY_MASKED}`: {e}")))?;
        Ok(Self {
            segment_id: table.i64(SEGMENT_ID)?.to_vec(),
            label: table.str(LABEL)?.into_iter().map(String::from).collect(),
            frames: Frames::from_table(&table, &[])?,
            masked_controls,
        })
    }
}

/// Row ranges `[start, end)` of the maximal runs of rows with one segment id and
/// consecutive frame numbers (the motion graph's motions), for any table that has the two
/// columns.
pub fn segment_runs(segment_id: &[i64], frame: &[i64]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for r in 0..segment_id.len().min(frame.len()) {
        match runs.last_mut() {
            Some((_, e)) if segment_id[r] == segment_id[r - 1] && frame[r] == frame[r - 1].wrapping_add(1) => {
                *e = r + 1
            }
            _ => runs.push((r, r + 1)),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{write, Columns};
    use crate::ArtifactError;

    fn sample() -> Frames {
        Frames {
            fps: 24.0,
            controls: vec!["jaw_open".into(), "brow_L".into()],
            clip: vec!["a".into(), "a".into(), "b".into()],
            frame: vec![0, 1, 0],
            time: vec![0.0, 1.0 / 24.0, 0.0],
            values: vec![0.0, 1.0, 0.5, 2.0, 1.0, 3.0],
        }
    }

    fn prov() -> Provenance {
        Provenance::new("test", "0", serde_json::json!({}))
    }

    #[test]
    fn round_trip_keeps_values_and_provenance() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frames.parquet");
        sample().write(&path, &prov()).unwrap();
        assert_eq!(Frames::read(&path).unwrap(), sample());
        let table = Table::read(&path, FRAMES).unwrap();
        assert_eq!(table.provenance().unwrap().stage, "test");
        assert_eq!(sample().clip_runs(), vec![("a".into(), 0, 2), ("b".into(), 2, 3)]);
    }

    #[test]
    fn wrong_kind_and_version_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.parquet");
        sample().write(&path, &prov()).unwrap();
        let err = LabeledFrames::read(&path).unwrap_err();
        assert!(matches!(err, ArtifactError::WrongKind { .. }), "{err}");
        let newer = Kind { name: "frames", version: 99 };
        write(&path, newer, Columns::new().i64(FRAME, vec![0]), &prov(), &[]).unwrap();
        let err = Frames::read(&path).unwrap_err();
        assert!(err.to_string().contains("schema version 99"), "{err}");
    }

    #[test]
    fn non_finite_and_missing_columns_name_the_column_and_row() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.parquet");
        let mut bad = sample();
        bad.values[3] = f64::NAN;
        // Never written by reprise…
        let err = bad.write(&path, &prov()).unwrap_err().to_string();
        assert!(err.contains("column `brow_L`, row 1") && err.contains("not finite"), "{err}");
        // …and refused on reading a file from elsewhere that holds one.
        let cols =
            Columns::new().str(CLIP, &["a"]).i64(FRAME, vec![0]).f64(TIME, vec![0.0]).f64_any("brow_L", vec![f64::NAN]);
        write(&path, FRAMES, cols, &prov(), &[(KEY_FPS.into(), "24".into())]).unwrap();
        let err = Frames::read(&path).unwrap_err().to_string();
        assert!(err.contains("column `brow_L`, row 0") && err.contains("not finite"), "{err}");
        let cols = Columns::new().str(CLIP, &["a"]).f64(TIME, vec![0.0]);
        write(&path, FRAMES, cols, &prov(), &[(KEY_FPS.into(), "24".into())]).unwrap();
        let err = Frames::read(&path).unwrap_err().to_string();
        assert!(err.contains("missing column `frame`"), "{err}");
    }

    #[test]
    fn frames_must_increase_within_a_clip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.parquet");
        let mut bad = sample();
        bad.frame[1] = 0;
        bad.write(&path, &prov()).unwrap();
        let err = Frames::read(&path).unwrap_err().to_string();
        assert!(err.contains("row 1") && err.contains("does not follow"), "{err}");
    }

    /// A failed write leaves the previous artifact untouched and no temporary file.
    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.parquet");
        sample().write(&path, &prov()).unwrap();
        let before = std::fs::read(&path).unwrap();
        let err = crate::table::write_atomic(&path, |f| {
            use std::io::Write;
            f.write_all(b"half").unwrap();
            Err(ArtifactError::Invalid { path: path.clone(), message: "boom".into() })
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), before);
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn labeled_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l.parquet");
        let labeled = LabeledFrames {
            segment_id: vec![0, 0, 1],
            label: vec!["happy".into(), "happy".into(), "roar".into()],
            frames: sample(),
            masked_controls: vec!["eye_L_yaw".into()],
        };
        labeled.write(&path, &prov()).unwrap();
        assert_eq!(LabeledFrames::read(&path).unwrap(), labeled);
    }
}
