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
//! Metadata: `reprise.fps`, and `reprise.resolution` where the controls were stored to a
//! [`Resolution`].

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::provenance::Provenance;
use crate::stream::{TableStream, TableWriter, ROW_GROUP_ROWS};
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

/// The relative resolution of the transition benchmark's curves (`--resolution` of
/// `transitions` and `motion-match`): a millionth of each control's training range — far
/// below what the measures resolve, and 3× smaller tables than exact values (#26).
pub const BENCHMARK_RESOLUTION: f64 = 1e-6;

/// Controls stored to a resolution relative to their range: control $j$ is rounded to the
/// nearest multiple of $g_j = 2^{\lfloor \log_2(\varepsilon r_j) \rfloor}$, where $r_j$ is
/// its range (max − min) in a reference — the training frames — and $\varepsilon$ the
/// relative resolution. The error is at most $g_j / 2 \le \varepsilon r_j / 2$ in the
/// control's own units. A control that does not vary in the reference ($r_j = 0$), or
/// $\varepsilon = 0$, is stored exactly. A multiple of a power of two has its low mantissa
/// bits zero, which the byte-stream-split encoding stores in a fraction of the space.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolution {
    /// The relative resolution $\varepsilon$.
    pub relative: f64,
    /// $g_j$ per control (0: exact).
    grid: Vec<f64>,
}

impl Resolution {
    /// The resolution $\varepsilon$ of each control's range `ranges` ($\varepsilon$ and the
    /// ranges finite and not negative; anything else stores that control exactly).
    pub fn relative(relative: f64, ranges: &[f64]) -> Self {
        let grid = ranges
            .iter()
            .map(|&r| {
                let step = relative * r;
                if step.is_finite() && step > 0.0 {
                    2f64.powi(step.log2().floor() as i32)
                } else {
                    0.0
                }
            })
            .collect();
        Self { relative, grid }
    }

    /// Control `j`'s value `v` as stored.
    pub fn round(&self, j: usize, v: f64) -> f64 {
        match self.grid.get(j) {
            Some(&g) if g > 0.0 => (v / g).round() * g,
            _ => v,
        }
    }

    /// The grid $g_j$ of control `j` (0: stored exactly).
    pub fn grid(&self, j: usize) -> f64 {
        self.grid.get(j).copied().unwrap_or(0.0)
    }
}

/// Writes curves atomically. Every row's latent point has the same dimension (0: none).
pub fn write(path: &Path, c: &Curves, provenance: &Provenance) -> Result<()> {
    let mut w = Writer::create(path, c.fps, &c.controls, provenance);
    w.write(c)?;
    w.finish()
}

/// Curves written a few thousand rows at a time ([`ROW_GROUP_ROWS`]), so a stage that
/// plays many scripts never holds them all: push scripts in order, then
/// [`Writer::finish`]. The first row fixes the latent dimension (no row: none). Nothing
/// appears at the path before `finish`; an error or a drop before it leaves the old file
/// as it was.
pub struct Writer {
    path: PathBuf,
    provenance: Provenance,
    /// How the controls are stored (`None`: exactly).
    resolution: Option<Resolution>,
    /// The open file and its rows' latent dimension, from the first rows written.
    table: Option<(TableWriter, usize)>,
    /// Rows not yet written (fps and controls as the table's).
    buf: Curves,
    /// Rows written so far (for error messages).
    written: usize,
}

impl Writer {
    /// A curves file of `controls` at `fps`, to be filled.
    pub fn create(path: &Path, fps: f64, controls: &[String], provenance: &Provenance) -> Self {
        let buf = Curves { fps, controls: controls.to_vec(), ..Default::default() };
        Self { path: path.into(), provenance: provenance.clone(), resolution: None, table: None, buf, written: 0 }
    }

    /// Stores the controls to `resolution` (one grid per control of the writer's) instead
    /// of exactly: for tables read only by measures whose precision is far coarser.
    pub fn with_resolution(mut self, resolution: Resolution) -> Self {
        self.resolution = Some(resolution);
        self
    }

    /// Appends one script played frame by frame (see [`Curves::push_script`]).
    pub fn push_script<'a>(&mut self, script: &str, frames: impl IntoIterator<Item = Frame<'a>>) -> Result<()> {
        self.buf.push_script(script, frames);
        if self.buf.script.len() >= ROW_GROUP_ROWS {
            self.flush()?;
        }
        Ok(())
    }

    /// Appends every row of `c` (its controls must be the writer's).
    pub fn write(&mut self, c: &Curves) -> Result<()> {
        if c.controls != self.buf.controls {
            return Err(crate::error::ArtifactError::Invalid {
                path: self.path.clone(),
                message: "curves appended with other controls than the file's (internal error)".into(),
            });
        }
        self.flush()?;
        self.append(c)
    }

    fn flush(&mut self) -> Result<()> {
        if self.buf.script.is_empty() {
            return Ok(());
        }
        let (fps, controls) = (self.buf.fps, self.buf.controls.clone());
        let rows = std::mem::replace(&mut self.buf, Curves { fps, controls, ..Default::default() });
        self.append(&rows)
    }

    fn append(&mut self, c: &Curves) -> Result<()> {
        let q = c.x.first().map(Vec::len);
        let (table, q) = match &mut self.table {
            Some((t, q)) => (t, *q),
            None if q.is_none() => return Ok(()),
            None => {
                let q = q.unwrap_or(0);
                let t = self.open(q)?;
                let (t, _) = self.table.insert((t, q));
                (t, q)
            }
        };
        table.write(columns(c, q, self.written, &self.path, self.resolution.as_ref())?)?;
        self.written += c.script.len();
        Ok(())
    }

    fn open(&self, q: usize) -> Result<TableWriter> {
        let empty = Curves { fps: self.buf.fps, controls: self.buf.controls.clone(), ..Default::default() };
        let mut meta = vec![("reprise.fps".into(), self.buf.fps.to_string())];
        if let Some(r) = &self.resolution {
            meta.push(("reprise.resolution".into(), format!("{} of each control's training range", r.relative)));
        }
        TableWriter::create(&self.path, CURVES, columns(&empty, q, 0, &self.path, None)?, &self.provenance, &meta)
    }

    /// Writes the rest and puts the file in place.
    pub fn finish(mut self) -> Result<()> {
        self.flush()?;
        match self.table.take() {
            Some((t, _)) => t.finish(),
            None => self.open(0)?.finish(),
        }
    }
}

/// The columns of `c`'s rows (file rows `first_row…`), each with a `q`-d latent point, the
/// controls to `resolution` (`None`: exactly).
fn columns(c: &Curves, q: usize, first_row: usize, path: &Path, resolution: Option<&Resolution>) -> Result<Columns> {
    if let Some(r) = c.x.iter().position(|x| x.len() != q) {
        return Err(crate::error::ArtifactError::Invalid {
            path: path.into(),
            message: format!("row {} has a {}-d latent point where row 0 has {q}", first_row + r, c.x[r].len()),
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
        let values = c.values.iter().skip(j).step_by(n.max(1));
        cols = cols.f64(
            name,
            match resolution {
                Some(r) => values.map(|&v| r.round(j, v)).collect(),
                None => values.copied().collect(),
            },
        );
    }
    Ok(cols)
}

/// Reads curves whole.
pub fn read(path: &Path) -> Result<Curves> {
    from_table(&Table::read(path, CURVES)?)
}

/// The curves of a table (a whole file or a chunk of one).
fn from_table(t: &Table) -> Result<Curves> {
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

/// One script's rows, as [`Scripts`] yields them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Script {
    /// The script's name.
    pub name: String,
    /// Frame per row.
    pub frame: Vec<i64>,
    /// Model label per row.
    pub model: Vec<String>,
    /// Command per row.
    pub command: Vec<i64>,
    /// Latent point per row.
    pub x: Vec<Vec<f64>>,
    /// Controls per row (row-major, `rows × controls`).
    pub values: Vec<f64>,
}

impl Script {
    /// Rows `r` of `c` appended.
    fn extend(&mut self, c: &Curves, r: std::ops::Range<usize>) {
        let n = c.controls.len();
        self.frame.extend_from_slice(&c.frame[r.clone()]);
        self.model.extend_from_slice(&c.model[r.clone()]);
        self.command.extend_from_slice(&c.command[r.clone()]);
        self.x.extend_from_slice(&c.x[r.clone()]);
        self.values.extend_from_slice(&c.values[r.start * n..r.end * n]);
    }
}

/// A curves file read script by script (rows of one script are consecutive, as every
/// stage writes them; a script whose rows are split comes out once per run of rows), a
/// few thousand rows in memory at a time. The content hash is checked after the last
/// script: use nothing derived from the scripts if the iteration ends in an error.
pub struct Scripts {
    stream: TableStream,
    /// Frame rate.
    pub fps: f64,
    /// Control names.
    pub controls: Vec<String>,
    chunk: Curves,
    cursor: usize,
    partial: Option<Script>,
    failed: bool,
}

impl Scripts {
    /// Opens `path` (a `curves` artifact).
    pub fn open(path: &Path) -> Result<Self> {
        let mut stream = TableStream::open(path, CURVES, ROW_GROUP_ROWS)?;
        let first = stream.next_chunk()?;
        let chunk = match &first {
            Some(t) => from_table(t)?,
            None => from_table(&Table::read(path, CURVES)?)?,
        };
        Ok(Self {
            stream,
            fps: chunk.fps,
            controls: chunk.controls.clone(),
            chunk,
            cursor: 0,
            partial: None,
            failed: false,
        })
    }

    fn next_script(&mut self) -> Result<Option<Script>> {
        loop {
            if self.cursor == self.chunk.script.len() {
                match self.stream.next_chunk()? {
                    Some(t) => {
                        self.chunk = from_table(&t)?;
                        self.cursor = 0;
                        continue;
                    }
                    None => return Ok(self.partial.take()),
                }
            }
            let name = &self.chunk.script[self.cursor];
            if self.partial.as_ref().is_some_and(|p| &p.name != name) {
                return Ok(self.partial.take());
            }
            let end = (self.cursor..self.chunk.script.len()).find(|&r| &self.chunk.script[r] != name);
            let end = end.unwrap_or(self.chunk.script.len());
            let p = self.partial.get_or_insert_with(|| Script { name: name.clone(), ..Script::default() });
            p.extend(&self.chunk, self.cursor..end);
            self.cursor = end;
            if end < self.chunk.script.len() {
                return Ok(self.partial.take());
            }
        }
    }
}

impl Iterator for Scripts {
    type Item = Result<Script>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        let next = self.next_script().transpose();
        self.failed = matches!(next, Some(Err(_)));
        next
    }
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

    /// The grid is the largest power of two within ε of the range; values land on it,
    /// within half a step; a still control, ε = 0 and a non-finite range store exactly;
    /// a table written to a resolution says so and reads back rounded.
    #[test]
    fn controls_are_stored_to_a_power_of_two_grid_of_their_range() {
        let r = Resolution::relative(1e-6, &[3.0, 0.0, 1.0, f64::NAN]);
        assert_eq!(r.grid(0), 2f64.powi(-19), "2^-19 = 1.9e-6 <= 3e-6 < 2^-18");
        assert_eq!(r.grid(2), 2f64.powi(-20), "2^-20 = 9.5e-7 <= 1e-6");
        assert_eq!((r.grid(1), r.grid(3), r.grid(9)), (0.0, 0.0, 0.0));
        for v in [0.1, -2.71, 1.0 / 3.0, 70.0 + 1e-9] {
            let q = r.round(0, v);
            assert!((q - v).abs() <= r.grid(0) / 2.0, "{v} -> {q}");
            assert_eq!(q / r.grid(0), (q / r.grid(0)).round(), "a multiple of the grid");
            assert_eq!(r.round(1, v), v);
        }
        assert_eq!(Resolution::relative(0.0, &[3.0]).round(0, 0.1), 0.1);

        let dir = tempfile::tempdir().unwrap();
        let controls = vec!["jaw".to_string(), "brow".to_string()];
        let pv = Provenance::new("t", "0", serde_json::json!({}));
        let path = dir.path().join("c.parquet");
        let mut w =
            Writer::create(&path, 24.0, &controls, &pv).with_resolution(Resolution::relative(0.01, &[1.0, 0.0]));
        w.push_script("r0", [Frame::plain("a", &[0.123456, 0.123456])]).unwrap();
        w.finish().unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back.values, [0.125, 0.123456], "jaw to 2^-7 of its range; brow (still) exact");
        let meta = crate::table::metadata_of(&path).unwrap();
        assert_eq!(meta["reprise.resolution"], "0.01 of each control's training range");
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

    /// Scripts streamed through a [`Writer`] across several row groups (one script
    /// straddling a boundary) read back whole and script by script as pushed; the file's
    /// content hash is the one a whole write gives, so both readers check it.
    #[test]
    fn streamed_scripts_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let controls = vec!["jaw".to_string(), "brow".to_string()];
        let lens = [3, ROW_GROUP_ROWS - 2, 7, 1, ROW_GROUP_ROWS + 5];
        let pv = Provenance::new("t", "0", serde_json::json!({}));
        let path = dir.path().join("c.parquet");
        let mut w = Writer::create(&path, 24.0, &controls, &pv);
        let mut whole = Curves { fps: 24.0, controls: controls.clone(), ..Default::default() };
        for (s, &len) in lens.iter().enumerate() {
            let rows: Vec<[f64; 2]> = (0..len).map(|f| [s as f64, f as f64 * 0.5]).collect();
            let x = [s as f64 / 10.0];
            let frames = || rows.iter().map(|c| Frame { model: "m", controls: c, x: &x, command: s as i64 });
            w.push_script(&format!("r{s}"), frames()).unwrap();
            whole.push_script(&format!("r{s}"), frames());
        }
        w.finish().unwrap();
        assert_eq!(read(&path).unwrap(), whole);
        let again = dir.path().join("whole.parquet");
        write(&again, &whole, &pv).unwrap();
        let hash = |p: &Path| crate::table::metadata_of(p).unwrap()[crate::provenance::KEY_CONTENT].clone();
        assert_eq!(hash(&path), hash(&again));
        let scripts: Vec<Script> = Scripts::open(&path).unwrap().collect::<Result<_>>().unwrap();
        assert_eq!(scripts.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(), ["r0", "r1", "r2", "r3", "r4"]);
        assert_eq!(scripts.iter().map(|s| s.frame.len()).collect::<Vec<_>>(), lens);
        let s4 = &scripts[4];
        assert_eq!((s4.values[2 * 9], s4.values[2 * 9 + 1], s4.x[9][0], s4.command[9]), (4.0, 4.5, 0.4, 4));
        assert_eq!(s4.frame.last(), Some(&(ROW_GROUP_ROWS as i64 + 4)));
    }

    /// A writer dropped before `finish` (a stage failing half-way) leaves nothing at its
    /// path and no temporary file; an old file there is untouched.
    #[test]
    fn an_unfinished_writer_leaves_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let pv = Provenance::new("t", "0", serde_json::json!({}));
        let path = dir.path().join("c.parquet");
        let old = Curves { fps: 24.0, controls: vec!["jaw".into()], ..Default::default() };
        write(&path, &old, &pv).unwrap();
        let before = std::fs::read(&path).unwrap();
        let mut w = Writer::create(&path, 30.0, &["jaw".to_string()], &pv);
        w.push_script("s", (0..ROW_GROUP_ROWS + 1).map(|_| Frame::plain("a", &[1.0]))).unwrap();
        drop(w);
        assert_eq!(std::fs::read(&path).unwrap(), before);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");
    }
}
