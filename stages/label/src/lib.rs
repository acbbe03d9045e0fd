//! The label stage: applies a labels file (rules, ranges, exclusions; see
//! `labels_file`) to the frame table, drops masked controls, and writes the segments
//! and the labeled frames.

mod assign;
mod labels_file;

use clap::Parser;
use globset::Glob;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::{Frames, LabeledFrames};
use reprise_artifact::segments::{self, Segment};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "label", bin: "reprise-label",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the frame table from ingest.
        frames: required "frames.parquet",
        /// Input: the controls table from ingest (needed for --mask-group).
        controls: optional "controls.parquet",
        /// Input: the labels file (.toml with rules, ranges and exclusions, or .csv clip,start,end,label).
        labels: source "a labels file (TOML or CSV)",
    }
    outputs {
        /// Output: the segments table.
        segments: artifact "segments.parquet",
        /// Output: the labeled frame table.
        labeled_frames: artifact "labeled_frames.parquet",
    }
}

/// `reprise-label`: labels, exclusions and control masks to segments and labeled frames.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-label", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Controls to leave out of every later model, by name glob (comma-separated); each must match a control.
    #[arg(long, value_delimiter = ',')]
    pub mask: Vec<String>,
    /// Control groups to leave out (comma-separated), e.g. `eyes`; needs --controls.
    #[arg(long, value_delimiter = ',')]
    pub mask_group: Vec<String>,
    /// Segments shorter than this many frames are dropped (and counted in the summary).
    #[arg(long, default_value_t = 1)]
    pub min_segment_length: usize,
}

/// Per-label counts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelCount {
    /// Label.
    pub label: String,
    /// Segments.
    pub segments: usize,
    /// Frames.
    pub frames: usize,
}

/// What labeling produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Per label, in labels-file order.
    pub labels: Vec<LabelCount>,
    /// Frames removed by exclusions.
    pub excluded_frames: usize,
    /// Frames no entry labels.
    pub unlabeled_frames: usize,
    /// Segments (and their frames) dropped as too short.
    pub dropped_segments: usize,
    /// Frames of dropped segments.
    pub dropped_frames: usize,
    /// Masked controls.
    pub masked_controls: Vec<String>,
    /// Each exclusion of the labels file: what it covers and why.
    pub exclusions: Vec<String>,
    /// Frames per second.
    pub fps: f64,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{:<14} {:>8} {:>7} {:>8}", "label", "segments", "frames", "seconds")?;
        for l in &self.labels {
            writeln!(f, "{:<14} {:>8} {:>7} {:>8.1}", l.label, l.segments, l.frames, l.frames as f64 / self.fps)?;
        }
        let total: usize = self.labels.iter().map(|l| l.frames).sum();
        writeln!(
            f,
            "{:<14} {:>8} {:>7} {:>8.1}",
            "total",
            self.labels.iter().map(|l| l.segments).sum::<usize>(),
            total,
            total as f64 / self.fps
        )?;
        for line in &self.exclusions {
            writeln!(f, "excluded {line}")?;
        }
        write!(
            f,
            "excluded {} frames, {} unlabeled, dropped {} short segments ({} frames); masked {} controls",
            self.excluded_frames,
            self.unlabeled_frames,
            self.dropped_segments,
            self.dropped_frames,
            self.masked_controls.len()
        )
    }
}

impl Args {
    fn validate(&self) -> StageResult<()> {
        if !self.mask_group.is_empty() && self.io.controls.is_none() {
            return Err(StageError::Config(
                "--mask-group needs --controls (the controls table names the groups)".into(),
            ));
        }
        if self.min_segment_length == 0 {
            return Err(StageError::Config("--min-segment-length must be at least 1".into()));
        }
        for pattern in &self.mask {
            Glob::new(pattern).map_err(|e| StageError::Config(format!("--mask `{pattern}`: {e}")))?;
        }
        Ok(())
    }
}

/// Controls to mask: every glob and every group must match at least one control.
fn masked(args: &Args, frames: &Frames) -> StageResult<Vec<String>> {
    let mut out: Vec<String> = Vec::new();
    for pattern in &args.mask {
        let glob = Glob::new(pattern).map_err(|e| StageError::Config(e.to_string()))?.compile_matcher();
        let hits: Vec<&String> = frames.controls.iter().filter(|c| glob.is_match(c.as_str())).collect();
        if hits.is_empty() {
            return Err(StageError::Config(format!("--mask `{pattern}` matches no control")));
        }
        out.extend(hits.into_iter().cloned());
    }
    if let Some(path) = args.io.controls.as_ref().filter(|_| !args.mask_group.is_empty()) {
        let controls = Controls::read(path)?;
        for group in &args.mask_group {
            let hits: Vec<&str> =
                controls.controls.iter().filter(|c| &c.group == group).map(|c| c.name.as_str()).collect();
            if hits.is_empty() {
                return Err(StageError::Config(format!(
                    "--mask-group `{group}`: no control of {} is in that group",
                    path.display()
                )));
            }
            out.extend(hits.into_iter().map(String::from));
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let labels = labels_file::LabelsFile::read(&args.io.labels)?;
    let frames = Frames::read(&args.io.frames)?;
    let provenance = args.io.provenance(args)?;
    let masked = masked(args, &frames)?;
    let assignment = assign::assign(&frames, &labels, &args.io.labels, args.min_segment_length)?;
    let labeled = labeled_frames(&frames, &assignment.segments, &assignment.rows, masked.clone());
    segments::write(&args.io.segments, &assignment.segments, &provenance)?;
    labeled.write(&args.io.labeled_frames, &provenance)?;
    let labels_file = labels;
    let labels = labels_file
        .labels
        .iter()
        .map(|l| {
            let mine: Vec<&Segment> = assignment.segments.iter().filter(|s| &s.label == l).collect();
            LabelCount {
                label: l.clone(),
                segments: mine.len(),
                frames: mine.iter().map(|s| s.frames() as usize).sum(),
            }
        })
        .collect();
    let exclusions = labels_file_exclusions(&labels_file);
    Ok(Some(Summary {
        exclusions,
        labels,
        excluded_frames: assignment.excluded_frames,
        unlabeled_frames: assignment.unlabeled_frames,
        dropped_segments: assignment.dropped_segments,
        dropped_frames: assignment.dropped_frames,
        masked_controls: masked,
        fps: frames.fps,
    }))
}

fn labels_file_exclusions(file: &labels_file::LabelsFile) -> Vec<String> {
    file.entries
        .iter()
        .filter(|e| e.label.is_none())
        .map(|e| {
            let range = e.range.map(|(a, b)| format!(" frames {a}..={b}")).unwrap_or_default();
            let reason = if e.reason.is_empty() { "no reason given" } else { &e.reason };
            format!("{}{range}: {reason}", e.target.describe())
        })
        .collect()
}

/// The rows of every segment, in segment order, without the masked controls.
fn labeled_frames(frames: &Frames, segments: &[Segment], rows: &[Vec<usize>], masked: Vec<String>) -> LabeledFrames {
    let keep: Vec<usize> = (0..frames.controls.len()).filter(|&c| !masked.contains(&frames.controls[c])).collect();
    let mut out = Frames {
        fps: frames.fps,
        controls: keep.iter().map(|&c| frames.controls[c].clone()).collect(),
        clip: Vec::new(),
        frame: Vec::new(),
        time: Vec::new(),
        values: Vec::new(),
    };
    let (mut segment_id, mut label) = (Vec::new(), Vec::new());
    for (segment, rows) in segments.iter().zip(rows) {
        for &r in rows {
            segment_id.push(segment.segment_id);
            label.push(segment.label.clone());
            out.clip.push(frames.clip[r].clone());
            out.frame.push(frames.frame[r]);
            out.time.push(frames.time[r]);
            let row = frames.row(r);
            out.values.extend(keep.iter().map(|&c| row[c]));
        }
    }
    LabeledFrames { segment_id, label, frames: out, masked_controls: masked }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod generative;
