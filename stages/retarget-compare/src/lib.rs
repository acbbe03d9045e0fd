//! The retarget-compare stage: protocol A of Bouaziz and Pauly (their Fig. 4) on a capture
//! whose targets are known, e.g. a face take posed on the ARKit shapes and read back as
//! noisy landmark markers, with the shape weights as the targets.
//!
//! The capture's frames (in table order) are split in blocks: the first `--train` share
//! trains (its frames are labelled or left unlabelled), the last `--test` share is mapped,
//! and the frames between are left out, because neighbouring frames of a 60 fps take are
//! nearly copies. For each label count, `--draws` random draws of the labelled frames (and
//! of the unlabelled ones) are scored for every method of
//! [`reprise_retarget::protocol::Method`] by the same code: the RMS over test frames and
//! target dimensions of the error, in target units.

pub mod chart;
pub mod report;

use std::collections::HashMap;

use clap::Parser;
use reprise_artifact::frames::Frames;
use reprise_artifact::positions::Positions;
use reprise_artifact::retarget::{write_comparison, Comparison};
use reprise_retarget::model::Init;
use reprise_retarget::protocol::{compare, Config};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "retarget-compare", bin: "reprise-retarget-compare",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the capture, marker positions per frame.
        capture: required "positions.parquet",
        /// Input: the known targets of the capture's frames (a frame table named by the
        /// capture's clip and frame).
        truth: required "frames.parquet",
    }
    outputs {
        /// Output: RMS per (label count, method).
        comparison: artifact "retarget_comparison.parquet",
        /// Output: the report.
        report: report "retarget-compare.md",
        /// Output: the chart the report shows.
        chart: report "retarget-compare.svg",
    }
}

/// `reprise-retarget-compare`: protocol A.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-retarget-compare", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// The capture system's noise σc: standard deviation of a marker coordinate, capture units.
    #[arg(long)]
    pub capture_noise: Option<f64>,
    /// Label counts (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "5,10,20")]
    pub labels: Vec<usize>,
    /// Random draws per label count.
    #[arg(long, default_value_t = 20)]
    pub draws: usize,
    /// Unlabelled frames of each space.
    #[arg(long, default_value_t = 100)]
    pub unlabelled: usize,
    /// Share of the frames, from the first, that trains.
    #[arg(long, default_value_t = 0.70)]
    pub train: f64,
    /// Share of the frames, to the last, that is mapped.
    #[arg(long, default_value_t = 0.25)]
    pub test: f64,
    /// Latent dimension (the paper: 8).
    #[arg(long, default_value_t = 8)]
    pub q: usize,
    /// LLE and alignment neighbours (the paper: 8).
    #[arg(long, default_value_t = 8)]
    pub k: usize,
    /// Ridge penalty, normalised units.
    #[arg(long, default_value_t = 1e-3)]
    pub ridge: f64,
    /// Where the latents start: `alignment` (the paper's) or `pca`.
    #[arg(long, default_value = "alignment")]
    pub init: String,
    /// L-BFGS iterations of each fit.
    #[arg(long, default_value_t = 300)]
    pub iterations: usize,
    /// Seed of the draws.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Frame rate of a capture without `reprise.fps` metadata.
    #[arg(long)]
    pub fps: Option<f64>,
}

/// Limit: capture frames the comparison reads (every fit is cubic in its rows, and a draw
/// fits four models per label count).
pub const MAX_FRAMES: usize = 20_000;

impl Args {
    fn config(&self) -> StageResult<Config> {
        let noise = reprise_retarget::model::capture_noise(self.capture_noise).map_err(StageError::Config)?;
        let share = |v: f64| v.is_finite() && v > 0.0 && v < 1.0;
        if !(share(self.train) && share(self.test) && self.train + self.test <= 1.0) {
            return Err(StageError::Config(format!(
                "--train {} and --test {} must be shares in (0, 1) with a sum of at most 1",
                self.train, self.test
            )));
        }
        if self.labels.is_empty() || self.labels.iter().any(|&l| l < 2) || self.draws == 0 {
            return Err(StageError::Config("--labels needs counts of at least 2, and --draws at least 1".into()));
        }
        if self.q == 0 || self.q > 64 || self.k == 0 || !(self.ridge.is_finite() && self.ridge > 0.0) {
            return Err(StageError::Config(
                "--q must be in 1..=64, --k at least 1, --ridge finite and positive".into(),
            ));
        }
        let mut labels = self.labels.clone();
        labels.sort_unstable();
        labels.dedup();
        let init = Init::parse(&self.init).map_err(StageError::Config)?;
        Ok(Config {
            labels,
            draws: self.draws,
            unlabelled: self.unlabelled,
            q: self.q,
            k: self.k,
            alpha: self.ridge,
            capture_noise: noise,
            init,
            max_iters: self.iterations,
            seed: self.seed,
        })
    }
}

/// The known target of every capture frame, in the capture's order.
///
/// # Errors
/// A capture frame the table holds no row for.
pub fn targets(truth: &Frames, path: &std::path::Path, capture: &Positions) -> StageResult<Vec<f64>> {
    let index: HashMap<(&str, i64), usize> =
        (0..truth.rows()).map(|r| ((truth.clip[r].as_str(), truth.frame[r]), r)).collect();
    let mut out = Vec::with_capacity(capture.frames() * truth.controls.len());
    for f in 0..capture.frames() {
        let r = index.get(&(capture.clip[f].as_str(), capture.frame[f])).ok_or_else(|| {
            StageError::Input(format!(
                "{}: holds no target for the capture's clip `{}` frame {}",
                path.display(),
                capture.clip[f],
                capture.frame[f]
            ))
        })?;
        out.extend_from_slice(truth.row(*r));
    }
    Ok(out)
}

/// What the stage measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The table.
    pub rows: Vec<Comparison>,
    /// Frames of the training and test blocks.
    pub blocks: (std::ops::Range<usize>, std::ops::Range<usize>),
    /// Target dimensions.
    pub targets: usize,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let cfg = args.config()?;
    if args.fps.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
        return Err(StageError::Config("--fps must be finite and positive".into()));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let capture = Positions::read(&args.io.capture, args.fps)?;
    if capture.frames() > MAX_FRAMES {
        return Err(StageError::Input(format!(
            "{}: {} frames; protocol A reads at most {MAX_FRAMES}",
            args.io.capture.display(),
            capture.frames()
        )));
    }
    let truth = Frames::read(&args.io.truth)?;
    let y = targets(&truth, &args.io.truth, &capture)?;
    let n = capture.frames();
    let train = 0..(n as f64 * args.train).floor() as usize;
    let test = (n - (n as f64 * args.test).floor() as usize)..n;
    if test.is_empty() {
        return Err(StageError::Input(format!(
            "{}: {n} frames leave no frame to map with --test {}",
            args.io.capture.display(),
            args.test
        )));
    }
    let rows = compare(&capture.values, capture.width(), &y, truth.controls.len(), train.clone(), test.clone(), &cfg)
        .map_err(|e| StageError::Input(format!("{}: {e}", args.io.capture.display())))?;
    let table: Vec<Comparison> = rows
        .iter()
        .map(|r| Comparison {
            labels: r.labels as i64,
            method: r.method.name().into(),
            rms: r.rms,
            sd: r.sd,
            draws: cfg.draws as i64,
        })
        .collect();
    write_comparison(&args.io.comparison, &table, &provenance)?;
    let summary = Summary { rows: table, blocks: (train, test), targets: truth.controls.len() };
    let chart_name = args.io.chart.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let md = report::markdown(&summary, &cfg, capture.points.len(), &chart_name);
    let marker = reprise_artifact::provenance::output_marker(WIRING.stage, provenance.pipeline.as_deref());
    write_text(&args.io.report, &format!("{md}\n<!-- {marker} -->\n"))?;
    write_text(&args.io.chart, &chart::rms_against_labels(&summary.rows))?;
    Ok(Some(summary))
}

fn write_text(path: &std::path::Path, text: &str) -> StageResult<()> {
    reprise_artifact::table::write_atomic(path, |f| {
        use std::io::Write as _;
        f.write_all(text.as_bytes()).map_err(|e| reprise_artifact::ArtifactError::io(path, e))
    })?;
    Ok(())
}
