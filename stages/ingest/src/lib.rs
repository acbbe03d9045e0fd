//! The ingest stage: turns a source into the three tables every later stage starts
//! from — `frames` (one row per frame, one column per control), `controls` and `clips`.
//!
//! Sources: the built-in dragon-face generator (`--generate dragon-face`), or a curve
//! table in CSV or Parquet (`--curves FILE`), wide (a column per control) or long
//! (`clip, frame|time, control, value`), a glTF character (`--gltf FILE`) or BVH takes of
//! one skeleton (`--bvh FILE`, repeated), resampled to `--fps`.

mod curves;
mod dragon;
mod faces;
mod imported;
mod source;

use std::path::PathBuf;

use clap::{Parser, ValueEnum};
use reprise_artifact::clips::{self, Clip};
use reprise_artifact::controls::{Control, Controls, RigRef};
use reprise_artifact::frames::{Frames, RESERVED};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

/// Which built-in generator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Generator {
    /// The film-style creature face rig and its 8-label corpus (datasets/dragon-face).
    DragonFace,
}

/// Layout of a curve table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Layout {
    /// Long if the table has `control` and `value` columns, else wide.
    Auto,
    /// A column per control.
    Wide,
    /// One row per (clip, frame, control).
    Long,
}

reprise_stagekit::stage_io! {
    stage: "ingest", bin: "reprise-ingest",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: a curve table (.csv or .parquet). Give this or --generate.
        curves: optional_source "a curve table (CSV or Parquet)",
        /// Input: a glTF 2.0 character (.glb/.gltf): each named animation becomes a clip; its skins and morph targets are the rig.
        gltf: optional_source "a glTF character (.glb/.gltf)",
        /// Input: BVH motion-capture files, the flag repeated per file (one clip per file, named
        /// by its stem; the files must share one skeleton, which becomes the rig).
        bvh: sources "BVH takes of one skeleton (a file, a list or a glob)",
        /// Input: the rig of a curve table as a blendshape face: a zip of OBJ meshes,
        /// `Neutral.obj` and one per shape (e.g. the ARKit reference shapes); each curve
        /// column names a shape (any case), and shapes the table lacks hold 0.
        blendshapes: optional_source "a blendshape face (zip of OBJ meshes)",
    }
    outputs {
        /// Output: the frame table.
        frames: artifact "frames.parquet",
        /// Output: the controls table.
        controls: artifact "controls.parquet",
        /// Output: the clips table.
        clips: artifact "clips.parquet",
    }
}

/// `reprise-ingest`: sources to frames, controls and clips.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-ingest", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Run a built-in generator instead of reading a file.
    #[arg(long, value_enum)]
    pub generate: Option<Generator>,
    /// Generator seed (the corpus and rig are deterministic in it).
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Generator corpus size: every label's frame budget times this (1 = the paper's
    /// 3,745 labeled frames; 7.7 ≈ 20 minutes). Other values need their own labels file.
    #[arg(long, default_value_t = 1.0)]
    pub corpus_scale: f64,
    /// Curve table layout.
    #[arg(long, value_enum, default_value_t = Layout::Auto)]
    pub layout: Layout,
    /// Pipeline frame rate: every clip is resampled to it (frames per second, at most
    /// 1000). `--generate dragon-face` makes a 24 fps corpus and accepts only 24.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Limit: the most frames ingest makes (after resampling, all clips together). A
    /// time or frame-number typo (frame 1e9 for 100) would otherwise try to allocate it.
    #[arg(long, default_value_t = 1_000_000)]
    #[serde(skip)]
    pub max_frames: usize,
    /// Limit: the most frame-table values ingest makes (frames × controls, all clips
    /// together; 8 bytes each). A wide table of many columns over a long time span would
    /// otherwise allocate without bound.
    #[arg(long, default_value_t = 200_000_000)]
    #[serde(skip)]
    pub max_values: usize,
    /// Rate of a table's `frame` column when it has no `time` column (default: --fps).
    #[arg(long)]
    pub source_fps: Option<f64>,
    /// A column of times other than `time`/`frame`: seconds, or SMPTE timecodes
    /// `HH:MM:SS:FF[.fff]` whose frame field counts at --source-fps (e.g. Live Link Face's `Timecode`).
    #[arg(long, value_name = "COLUMN")]
    pub time_column: Option<String>,
    /// Columns of a curve table that are not controls and should be dropped (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "COLUMNS")]
    pub ignore_columns: Vec<String>,
    /// Clip name for a table without a `clip` column (default: the file's stem).
    #[arg(long)]
    pub clip: Option<String>,
    /// A rig for a curve table: an external evaluator command (program and arguments,
    /// comma-separated) speaking reprise's Arrow IPC protocol (docs/inputs.md).
    #[arg(long, value_delimiter = ',', value_name = "CMD")]
    pub external_rig: Vec<String>,
}

impl Args {
    /// The one source the flags name.
    fn source(&self) -> StageResult<Source<'_>> {
        let mut given: Vec<Source<'_>> = Vec::new();
        if let Some(p) = &self.io.curves {
            given.push(Source::Curves(p));
        }
        if !self.io.bvh.is_empty() {
            given.push(Source::Bvh(&self.io.bvh));
        }
        if let Some(p) = &self.io.gltf {
            given.push(Source::Gltf(p));
        }
        if let Some(g) = self.generate {
            given.push(Source::Generate(g));
        }
        if given.len() > 1 {
            return Err(StageError::Config(
                "give one source: --curves, --gltf, --bvh or --generate, not several".into(),
            ));
        }
        let source = given.pop().ok_or_else(|| {
            StageError::Config(
                "nothing to ingest: give --curves FILE, --gltf FILE, --bvh FILE or --generate dragon-face".into(),
            )
        })?;
        if self.io.blendshapes.is_some() && !self.external_rig.is_empty() {
            return Err(StageError::Config("give one rig for a curve table: --blendshapes or --external-rig".into()));
        }
        if (!self.external_rig.is_empty() || self.io.blendshapes.is_some()) && !matches!(source, Source::Curves(_)) {
            return Err(StageError::Config(
                "--external-rig and --blendshapes are for curve tables; this source brings its own rig".into(),
            ));
        }
        Ok(source)
    }

    fn validate(&self) -> StageResult<()> {
        self.source()?;
        if !(self.corpus_scale >= 0.1 && self.corpus_scale <= 100.0) {
            return Err(StageError::Config(format!("--corpus-scale must be in [0.1, 100], got {}", self.corpus_scale)));
        }
        for (flag, rate) in [("--fps", Some(self.fps)), ("--source-fps", self.source_fps)] {
            if let Some(r) = rate.filter(|r| !(r.is_finite() && *r > 0.0 && *r <= MAX_FPS)) {
                return Err(StageError::Config(format!(
                    "{flag} must be a positive number of frames per second, at most {MAX_FPS}, got {r}"
                )));
            }
        }
        if self.generate.is_some() && self.fps != dragon::FPS {
            return Err(StageError::Config(format!(
                "--generate dragon-face makes a {} fps corpus; --fps {} cannot be honoured (give --fps {} or leave it out)",
                dragon::FPS,
                self.fps,
                dragon::FPS
            )));
        }
        if self.max_frames == 0 || self.max_values == 0 {
            return Err(StageError::Config("--max-frames and --max-values must be at least 1".into()));
        }
        Ok(())
    }
}

/// The highest `--fps` / `--source-fps` accepted.
pub const MAX_FPS: f64 = 1000.0;

/// Where the clips come from.
enum Source<'a> {
    Curves(&'a std::path::Path),
    Bvh(&'a [PathBuf]),
    Gltf(&'a std::path::Path),
    Generate(Generator),
}

/// What ingest produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames written.
    pub frames: usize,
    /// Controls.
    pub controls: usize,
    /// Clips.
    pub clips: usize,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    // The imported rig is named by its source's content hash (the first file's, for
    // several BVH takes).
    let source_hash = || {
        let inputs = args.io.inputs();
        inputs.first().map(|(role, _)| provenance.inputs[role].blake3.clone()).unwrap_or_default()
    };
    let (frames, controls, clips) = match args.source()? {
        Source::Generate(Generator::DragonFace) => dragon::generate(args.seed, args.corpus_scale),
        Source::Curves(path) => {
            let (frames, mut controls, clips) = from_table(args, path)?;
            match &args.io.blendshapes {
                Some(face) => {
                    let blake3 = provenance.inputs["blendshapes"].blake3.clone();
                    let (frames, table) = faces::onto_shapes(frames, face, blake3, &args.ignore_columns)?;
                    controls = table;
                    (frames, controls, clips)
                }
                None => (frames, controls, clips),
            }
        }
        Source::Bvh(paths) => {
            imported::bvh(paths, args.fps, args.max_frames, source_hash()).map_err(StageError::Input)?
        }
        Source::Gltf(path) => {
            imported::gltf(path, args.fps, args.max_frames, source_hash()).map_err(StageError::Input)?
        }
    };
    frames.write(&args.io.frames, &provenance)?;
    controls.write(&args.io.controls, &provenance)?;
    clips::write(&args.io.clips, &clips, &provenance)?;
    Ok(Some(Summary { frames: frames.rows(), controls: controls.controls.len(), clips: clips.len() }))
}

fn from_table(args: &Args, path: &std::path::Path) -> StageResult<(Frames, Controls, Vec<Clip>)> {
    let table = source::RawTable::read(path)?;
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let base = curves::TimeBase {
        source_fps: args.source_fps.unwrap_or(args.fps),
        default_clip: args.clip.as_deref().unwrap_or(&stem),
        time_column: args.time_column.as_deref(),
        ignore: &args.ignore_columns,
    };
    let long = match args.layout {
        Layout::Auto => curves::is_long(&table),
        Layout::Long => true,
        Layout::Wide => false,
    };
    let curves = if long { curves::long(&table, &base)? } else { curves::wide(&table, &base)? };
    if let Some(bad) = curves.controls.iter().find(|c| RESERVED.contains(&c.as_str())) {
        return Err(StageError::Input(format!("{}: control `{bad}` uses a reserved column name", path.display())));
    }
    if table.rows() == 0 {
        return Err(StageError::Input(format!("{}: the table has no rows", path.display())));
    }
    curves::check_budget(&table, &base, &curves, args.fps, (args.max_frames, args.max_values))?;
    let frames = curves::resample(&curves, args.fps);
    let clips = curves
        .clips
        .iter()
        .map(|c| Clip {
            clip: c.name.clone(),
            frames: frames.clip.iter().filter(|n| **n == c.name).count() as i64,
            fps: args.fps,
            source: path.display().to_string(),
            source_fps: curves::source_rate(&c.times, base.source_fps),
        })
        .collect();
    let controls = (0..frames.controls.len())
        .map(|c| {
            let column = frames.column(c);
            let (min, max) =
                column.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
            Control {
                name: frames.controls[c].clone(),
                group: "default".into(),
                unit: "unknown".into(),
                default: 0.0,
                min,
                max,
                animated: dragon::moves(&frames, c),
            }
        })
        .collect();
    let rig = if args.external_rig.is_empty() {
        RigRef::None
    } else {
        RigRef::External { command: args.external_rig.clone() }
    };
    Ok((frames, Controls { controls, rig }, clips))
}

#[cfg(test)]
mod tests;
