//! `curves` — synthesized animation: one row per (script, frame).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `script` | Utf8 | the script's name |
//! | `frame` | Int64 | 0, 1, … |
//! | `time` | Float64 | seconds, `(frame + 1) / fps` (the state after the frame's step) |
//! | `model` | Utf8 | the label whose model produced the frame |
//! | `command` | Int64 | the script command (from 0) that produced it |
//! | `x0…` | Float64 | the particle's latent point |
//! | *one per control* | Float64 | rig controls (blended across model switches) |
//!
//! Metadata: `reprise.fps`.

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the curves table.
pub const CURVES: Kind = Kind { name: "curves", version: 1 };

/// Synthesized curves of one or more scripts.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Curves {
    /// Frame rate.
    pub fps: f64,
    /// Control names.
    pub controls: Vec<String>,
    /// Script per row.
    pub script: Vec<String>,
    /// Frame per row.
    pub frame: Vec<i64>,
    /// Seconds per row.
    pub time: Vec<f64>,
    /// Model label per row.
    pub model: Vec<String>,
    /// Command per row.
    pub command: Vec<i64>,
    /// Latent point per row.
    pub x: Vec<Vec<f64>>,
    /// Controls per row (row-major, `rows × controls`).
    pub values: Vec<f64>,
}

/// One played frame, as [`Curves::push_script`] takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame<'a> {
    /// The label whose model (or clip) produced the frame.
    pub model: &'a str,
    /// Rig controls, in the table's control order.
    pub controls: &'a [f64],
    /// The latent point (empty: the system has none).
    pub x: &'a [f64],
    /// The script command (from 0) that produced it.
    pub command: i64,
}

impl<'a> Frame<'a> {
    /// A frame with no latent point, of command 0.
    pub fn plain(model: &'a str, controls: &'a [f64]) -> Self {
        Self { model, controls, x: &[], command: 0 }
    }
}

impl Curves {
    /// Appends one script played frame by frame, frames numbered from 0 at `fps`.
    pub fn push_script<'a>(&mut self, script: &str, frames: impl IntoIterator<Item = Frame<'a>>) {
        for (f, frame) in frames.into_iter().enumerate() {
            self.script.push(script.to_string());
            self.frame.push(f as i64);
            self.time.push(f as f64 / self.fps);
            self.model.push(frame.model.to_string());
            self.command.push(frame.command);
            self.x.push(frame.x.to_vec());
            self.values.extend_from_slice(frame.controls);
        }
    }
}

/// Writes curves atomically. Every row's latent point has the same dimension (0: none).
pub fn write(path: &Path, c: &Curves, provenance: &Provenance) -> Result<()> {
    let q = c.x.first().map_or(0, Vec::len);
    if let Some(r) = c.x.iter().position(|x| x.len() != q) {
        return Err(crate::error::ArtifactError::Invalid {
            path: path.into(),
            message: format!("row {r} has a {}-d latent point where row 0 has {q}", c.x[r].len()),
        });
    }
    let mut cols = Columns::new()
        .str("script", &c.script)
        .i64("frame", c.frame.clone())
        .f64("time", c.time.clone())
        .str("model", &c.model)
        .i64("command", c.command.clone());
    for k in 0..q {
        cols = cols.f64(&format!("x{k}"), c.x.iter().map(|x| x[k]).collect());
    }
    let n = c.controls.len();
    for (j, name) in c.controls.iter().enumerate() {
        cols = cols.f64(name, c.values.iter().skip(j).step_by(n.max(1)).copied().collect());
    }
    crate::table::write(path, CURVES, cols, provenance, &[("reprise.fps".into(), c.fps.to_string())])
}

/// Reads curves.
pub fn read(path: &Path) -> Result<Curves> {
    let t = Table::read(path, CURVES)?;
    let fps: f64 = t.meta("reprise.fps")?.parse().map_err(|_| t.invalid("reprise.fps is not a number"))?;
    let xs: Vec<String> = (0..).map(|k| format!("x{k}")).take_while(|n| t.has_column(n)).collect();
    let fixed = ["script", "frame", "time", "model", "command"];
    let controls: Vec<String> =
        t.column_names().into_iter().filter(|c| !fixed.contains(&c.as_str()) && !xs.contains(c)).collect();
    let xcols = xs.iter().map(|n| t.f64(n)).collect::<Result<Vec<_>>>()?;
    let ccols = controls.iter().map(|n| t.f64(n)).collect::<Result<Vec<_>>>()?;
    Ok(Curves {
        fps,
        script: t.strings("script")?,
        frame: t.i64("frame")?.to_vec(),
        time: t.f64("time")?.to_vec(),
        model: t.strings("model")?,
        command: t.i64("command")?.to_vec(),
        x: (0..t.rows()).map(|r| xcols.iter().map(|c| c[r]).collect()).collect(),
        values: (0..t.rows()).flat_map(|r| ccols.iter().map(move |c| c[r])).collect(),
        controls,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Curves come back as written.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let c = Curves {
            fps: 24.0,
            controls: vec!["jaw".into(), "brow".into()],
            script: vec!["s".into(), "s".into()],
            frame: vec![0, 1],
            time: vec![1.0 / 24.0, 2.0 / 24.0],
            model: vec!["a".into(), "b".into()],
            command: vec![0, 1],
            x: vec![vec![0.1, 0.2], vec![0.3, 0.4]],
            values: vec![1.0, 2.0, 3.0, 4.0],
        };
        let path = dir.path().join("c.parquet");
        write(&path, &c, &Provenance::new("t", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read(&path).unwrap(), c);
    }

    /// Latent points of different dimensions in one table are refused, nothing written.
    #[test]
    fn ragged_latent_points_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut c = Curves { fps: 24.0, controls: vec!["jaw".into()], ..Default::default() };
        let x = [0.5, 0.25];
        c.push_script("s", [Frame { model: "a", controls: &[1.0], x: &x, command: 2 }, Frame::plain("a", &[2.0])]);
        assert_eq!((c.x[0].len(), c.command[0], c.x[1].len()), (2, 2, 0));
        let path = dir.path().join("c.parquet");
        let err = write(&path, &c, &Provenance::new("t", "0", serde_json::json!({}))).unwrap_err();
        assert!(err.to_string().contains("row 1 has a 0-d latent point where row 0 has 2"), "{err}");
        assert!(!path.exists());
    }
}
