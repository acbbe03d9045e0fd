//! `clips`: one row per ingested clip.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `clip` | Utf8 | clip name |
//! | `frames` | Int64 | frames at the pipeline rate |
//! | `fps` | Float64 | the pipeline rate |
//! | `duration` | Float64 | seconds, `(frames - 1) / fps` |
//! | `source` | Utf8 | where it came from (a file path or `dragon-face`) |
//! | `source_fps` | Float64 | the source's own rate (equal to `fps` when not resampled) |

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the clips table.
pub const CLIPS: Kind = Kind { name: "clips", version: 1 };

/// One clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Clip {
    /// Name.
    pub clip: String,
    /// Number of frames.
    pub frames: i64,
    /// Pipeline rate.
    pub fps: f64,
    /// Source.
    pub source: String,
    /// Source rate.
    pub source_fps: f64,
}

/// Writes the clips table atomically.
pub fn write(path: &Path, clips: &[Clip], provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .str("clip", &clips.iter().map(|c| c.clip.as_str()).collect::<Vec<_>>())
        .i64("frames", clips.iter().map(|c| c.frames).collect())
        .f64("fps", clips.iter().map(|c| c.fps).collect())
        .f64("duration", clips.iter().map(|c| (c.frames - 1).max(0) as f64 / c.fps).collect())
        .str("source", &clips.iter().map(|c| c.source.as_str()).collect::<Vec<_>>())
        .f64("source_fps", clips.iter().map(|c| c.source_fps).collect());
    crate::table::write(path, CLIPS, cols, provenance, &[])
}

/// Reads a clips table.
pub fn read(path: &Path) -> Result<Vec<Clip>> {
    let t = Table::read(path, CLIPS)?;
    let (clip, frames, fps, source, source_fps) =
        (t.str("clip")?, t.i64("frames")?, t.f64("fps")?, t.str("source")?, t.f64("source_fps")?);
    Ok((0..t.rows())
        .map(|i| Clip {
            clip: clip[i].into(),
            frames: frames[i],
            fps: fps[i],
            source: source[i].into(),
            source_fps: source_fps[i],
        })
        .collect())
}
