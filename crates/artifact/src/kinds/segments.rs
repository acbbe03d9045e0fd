//! `segments`: one row per labeled, contiguous frame range.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `segment_id` | Int64 | 0, 1, 2, … in (label, clip, start) order |
//! | `label` | Utf8 | label |
//! | `clip` | Utf8 | clip name |
//! | `start` | Int64 | first frame, inclusive |
//! | `end` | Int64 | last frame, inclusive |
//! | `frames` | Int64 | `end - start + 1` |

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the segments table.
pub const SEGMENTS: Kind = Kind { name: "segments", version: 1 };

/// One segment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Segment {
    /// Id.
    pub segment_id: i64,
    /// Label.
    pub label: String,
    /// Clip.
    pub clip: String,
    /// First frame, inclusive.
    pub start: i64,
    /// Last frame, inclusive.
    pub end: i64,
}

impl Segment {
    /// Number of frames.
    pub fn frames(&self) -> i64 {
        self.end - self.start + 1
    }
}

/// Writes the segments table atomically.
pub fn write(path: &Path, segments: &[Segment], provenance: &Provenance) -> Result<()> {
    let s = segments;
    let cols = Columns::new()
        .i64("segment_id", s.iter().map(|s| s.segment_id).collect())
        .str("label", &s.iter().map(|s| s.label.as_str()).collect::<Vec<_>>())
        .str("clip", &s.iter().map(|s| s.clip.as_str()).collect::<Vec<_>>())
        .i64("start", s.iter().map(|s| s.start).collect())
        .i64("end", s.iter().map(|s| s.end).collect())
        .i64("frames", s.iter().map(Segment::frames).collect());
    crate::table::write(path, SEGMENTS, cols, provenance, &[])
}

/// Reads a segments table, checking `start <= end`.
pub fn read(path: &Path) -> Result<Vec<Segment>> {
    let t = Table::read(path, SEGMENTS)?;
    let (id, label, clip, start, end) =
        (t.i64("segment_id")?, t.str("label")?, t.str("clip")?, t.i64("start")?, t.i64("end")?);
    (0..t.rows())
        .map(|i| {
            if start[i] > end[i] {
                return Err(t.invalid(format!("row {i}: start {} after end {}", start[i], end[i])));
            }
            Ok(Segment {
                segment_id: id[i],
                label: label[i].into(),
                clip: clip[i].into(),
                start: start[i],
                end: end[i],
            })
        })
        .collect()
}
