//! The scale stage (Bailey et al. 2016 §4.1): for every label and every control, the
//! weight $w_i$ of Eq. 3 from rig evaluations at the label's mean pose $\bar p$ and at
//! $\bar p + n\sigma_i\mathbf e_i$, $n \in$ `--steps` (see `reprise_numerics::scaling`).
//! Controls with zero variance in a label, or that move no vertex, are flagged and left
//! out — never divided by.

use clap::Parser;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::scales::{self, Scale};
use reprise_numerics::scaling::{fit_weight, DEFAULT_STEPS};
use reprise_numerics::stats::mean_std;
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::{ProgressBar, StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "scale", bin: "reprise-scale",
    partition: Label { by: "labeled_frames" },
    derived: [],
    inputs {
        /// Input: the labeled frames.
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the controls table (names the rig).
        controls: required "controls.parquet",
    }
    outputs {
        /// Output: the scales table.
        scales: artifact "scales.parquet",
    }
}

/// `reprise-scale`: per-label, per-control scaling weights from the rig.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-scale", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Steps n, in standard deviations, at which the rig is evaluated (comma-separated, nonzero).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_values_t = DEFAULT_STEPS.to_vec())]
    pub steps: Vec<f64>,
    /// A control whose standard deviation in a label is at most this is `constant` there.
    #[arg(long, default_value_t = 1e-9)]
    pub min_std: f64,
    /// A control whose largest displacement (mesh units) is at most this is `no-effect`.
    #[arg(long, default_value_t = 1e-9)]
    pub min_displacement: f64,
    /// Controls evaluated per rig batch (memory: batch · steps · 3V values).
    #[arg(long, default_value_t = 32)]
    pub batch: usize,
}

impl Args {
    fn validate(&self) -> StageResult<()> {
        if self.steps.is_empty() || self.steps.iter().any(|n| *n == 0.0 || !n.is_finite()) {
            return Err(StageError::Config(format!("--steps must be finite and nonzero, got {:?}", self.steps)));
        }
        let non_negative = |x: f64| x >= 0.0; // false for NaN too
        if self.batch == 0 || !non_negative(self.min_std) || !non_negative(self.min_displacement) {
            return Err(StageError::Config("--batch must be positive, --min-std and --min-displacement >= 0".into()));
        }
        Ok(())
    }
}

/// Per-label counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// (label, used controls, constant, no-effect).
    pub labels: Vec<(String, usize, usize, usize)>,
    /// Rig evaluations made.
    pub evaluations: usize,
    /// Seconds spent evaluating.
    pub seconds: f64,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    reprise_artifact::provenance::check_made_from(&args.io.labeled_frames, &provenance)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let controls = Controls::read(&args.io.controls)?;
    let (rig, layout) = reprise_stagekit::rig::open_rig(&controls, &labeled.frames.controls)?;
    let labels = reprise_stagekit::wiring::only_partition(
        label_order(&labeled),
        String::as_str,
        args.io.partition.as_deref(),
        &args.io.labeled_frames,
    )?;
    let n = labeled.frames.controls.len();
    let bar = reprise_stagekit::progress((labels.len() * n) as u64, "scale");
    let started = std::time::Instant::now();
    let mut rows = Vec::new();
    let mut summary = Summary { labels: Vec::new(), evaluations: 0, seconds: 0.0 };
    for label in &labels {
        let values: Vec<f64> = (0..labeled.frames.rows())
            .filter(|&r| &labeled.label[r] == label)
            .flat_map(|r| labeled.frames.row(r).iter().copied())
            .collect();
        let (mean, std) = mean_std(&values, n);
        let fits = label_weights(rig.as_ref(), &layout, &mean, &std, args, &bar)?;
        summary.evaluations += 1 + args.steps.len() * fits.iter().filter(|f| f.is_some()).count();
        let mut counts = (label.clone(), 0, 0, 0);
        for c in 0..n {
            let (weight, residual, reason) = match fits[c] {
                None => (0.0, 0.0, "constant"),
                Some(fit) if fit.weight * std[c] * max_abs(&args.steps) <= args.min_displacement => {
                    (0.0, fit.residual, "no-effect")
                }
                Some(fit) => (fit.weight, fit.residual, ""),
            };
            match reason {
                "" => counts.1 += 1,
                "constant" => counts.2 += 1,
                _ => counts.3 += 1,
            }
            rows.push(Scale {
                label: label.clone(),
                control: labeled.frames.controls[c].clone(),
                mean: mean[c],
                std: std[c],
                weight,
                residual,
                used: reason.is_empty(),
                reason: reason.into(),
            });
        }
        if counts.1 == 0 {
            return Err(StageError::Input(format!(
                "{}: label `{label}`: no control both varies and moves the mesh; nothing to model",
                args.io.labeled_frames.display()
            )));
        }
        summary.labels.push(counts);
    }
    bar.finish_and_clear();
    summary.seconds = started.elapsed().as_secs_f64();
    scales::write(&args.io.scales, &rows, &provenance)?;
    Ok(Some(summary))
}

fn max_abs(steps: &[f64]) -> f64 {
    steps.iter().fold(0.0, |m, s| m.max(s.abs()))
}

/// Labels in the order their first frame appears.
fn label_order(labeled: &LabeledFrames) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for l in &labeled.label {
        if out.last() != Some(l) && !out.contains(l) {
            out.push(l.clone());
        }
    }
    out
}

/// Eq. 3 for every control of one label (`None` for constant controls), evaluating the
/// rig in batches of `args.batch` controls × `args.steps` poses.
fn label_weights(
    rig: &dyn Rig,
    layout: &PoseLayout,
    mean: &[f64],
    std: &[f64],
    args: &Args,
    bar: &ProgressBar,
) -> StageResult<Vec<Option<reprise_numerics::scaling::WeightFit>>> {
    let rig_err = |e: reprise_rig::RigError| StageError::Input(e.to_string());
    let centre = layout.full(mean);
    let base = rig.evaluate(&centre).map_err(rig_err)?;
    let m = base.len();
    let varying: Vec<usize> = (0..mean.len()).filter(|&c| std[c] > args.min_std).collect();
    let mut fits = vec![None; mean.len()];
    let (k, rig_n) = (args.steps.len(), centre.len());
    for chunk in varying.chunks(args.batch) {
        let mut poses = Vec::with_capacity(chunk.len() * k * rig_n);
        for &c in chunk {
            for n in &args.steps {
                let mut row = mean.to_vec();
                row[c] += n * std[c];
                poses.extend(layout.full(&row));
            }
        }
        let mut out = vec![0.0; chunk.len() * k * m];
        rig.evaluate_batch(&poses, &mut out).map_err(rig_err)?;
        for (i, &c) in chunk.iter().enumerate() {
            let d: Vec<f64> = (0..k)
                .map(|s| {
                    let mesh = &out[(i * k + s) * m..(i * k + s + 1) * m];
                    mesh.iter().zip(&base).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt()
                })
                .collect();
            fits[c] = Some(fit_weight(std[c], &args.steps, &d));
        }
        bar.inc(chunk.len() as u64);
    }
    bar.inc((mean.len() - varying.len()) as u64);
    Ok(fits)
}
