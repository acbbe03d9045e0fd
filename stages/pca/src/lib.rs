//! The pca stage (Bailey et al. 2016 §4.2): per label, PCA of the scaled controls
//! $z = W(p - \bar p) + \bar p$ over the controls the scale stage marked `used`, the
//! number of components set by an explained-variance threshold within bounds; the
//! per-frame coordinates $Y$; and, for the scaling ablation, the same PCA of the
//! unscaled controls with both variants' reconstruction errors in rig and mesh space at
//! the chosen $d$ and at fixed small $d$.

mod errors;

use clap::Parser;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::pca::{self, PcaCoords, SCALED, UNSCALED};
use reprise_artifact::scales::{self, Scale};
use reprise_label_models::Scaling;
use reprise_numerics::pca::{Pca, PcaParams};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "pca", bin: "reprise-pca",
    partition: Label { by: "labeled_frames" },
    derived: [],
    inputs {
        /// Input: the labeled frames.
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the scales table.
        scales: required "scales.parquet",
        /// Input: the controls table (names the rig, for mesh-space errors).
        controls: required "controls.parquet",
    }
    outputs {
        /// Output: the PCA models.
        models: artifact "pca_models.parquet",
        /// Output: per-frame coordinates Y.
        coords: artifact "pca_coords.parquet",
        /// Output: reconstruction errors, scaled against unscaled.
        errors: artifact "pca_errors.parquet",
    }
}

/// `reprise-pca`: per-label PCA of the scaled rig controls.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-pca", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Keep the fewest components explaining this share of the variance (the paper: 0.85).
    #[arg(long, default_value_t = 0.85)]
    pub variance: f64,
    /// At least this many components.
    #[arg(long, default_value_t = 3)]
    pub min_components: usize,
    /// At most this many components.
    #[arg(long, default_value_t = 64)]
    pub max_components: usize,
    /// Fixed small dimensions at which to also measure reconstruction error (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = vec![3, 10])]
    pub fixed_d: Vec<usize>,
    /// Also write the unscaled models and coordinates (the ablation's inputs).
    #[arg(long, default_value_t = false, action = clap::ArgAction::Set)]
    pub write_unscaled: bool,
    /// Measure mesh-space errors through the rig (needs a rig; off for plain curve tables).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub mesh_errors: bool,
}

impl Args {
    fn params(&self) -> PcaParams {
        PcaParams { variance: self.variance, min_components: self.min_components, max_components: self.max_components }
    }
    fn validate(&self) -> StageResult<()> {
        let p = self.params();
        if !(p.variance > 0.0 && p.variance <= 1.0) || p.min_components == 0 || p.min_components > p.max_components {
            return Err(StageError::Config(format!(
                "need 0 < --variance <= 1 and 1 <= --min-components <= --max-components, got {}, {}, {}",
                p.variance, p.min_components, p.max_components
            )));
        }
        if self.fixed_d.contains(&0) {
            return Err(StageError::Config("--fixed-d values must be at least 1".into()));
        }
        Ok(())
    }
}

/// One label's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelSummary {
    /// Label.
    pub label: String,
    /// Frames.
    pub frames: usize,
    /// Controls used.
    pub controls: usize,
    /// Chosen d (scaled) and its explained share.
    pub d: usize,
    /// Explained share at d.
    pub explained: f64,
    /// Chosen d of the unscaled variant.
    pub d_unscaled: usize,
}

/// What the stage produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Per label.
    pub labels: Vec<LabelSummary>,
    /// The error rows written.
    pub errors: Vec<pca::PcaError>,
}

/// The stage's summary: per label its frames, controls, chosen d and explained share (and
/// the unscaled variant's d), then the mesh RMS error of scaled against unscaled PCA at
/// d = 3, 10 and the chosen d ("-" where not measured).
impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{:<14} {:>6} {:>8} {:>3} {:>9} {:>10}",
            "label", "frames", "controls", "d", "explained", "d unscaled"
        )?;
        for l in &self.labels {
            writeln!(
                f,
                "{:<14} {:>6} {:>8} {:>3} {:>9.3} {:>10}",
                l.label, l.frames, l.controls, l.d, l.explained, l.d_unscaled
            )?;
        }
        writeln!(f, "mesh RMS error (scaled / unscaled) at the same d:")?;
        for l in &self.labels {
            let at = |variant: &str, d: i64| {
                self.errors
                    .iter()
                    .find(|e| e.label == l.label && e.variant == variant && e.d == d)
                    .and_then(|e| e.mesh_rmse)
            };
            let cells: Vec<String> = [3, 10, l.d as i64]
                .iter()
                .map(|&d| match (at("scaled", d), at("unscaled", d)) {
                    (Some(a), Some(b)) => format!("d={d}: {a:.4} / {b:.4}"),
                    _ => format!("d={d}: -"),
                })
                .collect();
            writeln!(f, "  {:<12} {}", l.label, cells.join("   "))?;
        }
        Ok(())
    }
}

/// One label's frames and its scaling.
pub(crate) struct LabelData {
    /// Row indices into the labeled frames.
    pub(crate) rows: Vec<usize>,
    /// The label, its used controls and their transform.
    pub(crate) scaling: Scaling,
}

impl LabelData {
    /// The label's frames restricted to used controls, scaled or not (row-major).
    pub(crate) fn matrix(&self, labeled: &LabeledFrames, scaled: bool) -> Vec<f64> {
        self.rows.iter().flat_map(|&r| self.scaling.values(labeled.frames.row(r), scaled)).collect()
    }
}

fn label_data(labeled: &LabeledFrames, scales: &[Scale], path: &std::path::Path) -> StageResult<Vec<LabelData>> {
    let controls = &labeled.frames.controls;
    let mut out: Vec<LabelData> = Vec::new();
    for (r, l) in labeled.label.iter().enumerate() {
        match out.iter_mut().find(|d| &d.scaling.label == l) {
            Some(d) => d.rows.push(r),
            None => out.push(LabelData { rows: vec![r], scaling: Scaling::new(l, controls, scales, path)? }),
        }
    }
    Ok(out)
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    reprise_artifact::provenance::check_made_from(&args.io.scales, &provenance)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let scales = scales::read(&args.io.scales)?;
    let rig = if args.mesh_errors {
        Some(reprise_stagekit::rig::open_rig(&Controls::read(&args.io.controls)?, &labeled.frames.controls)?)
    } else {
        None
    };
    let data = reprise_stagekit::wiring::only_partition(
        label_data(&labeled, &scales, &args.io.scales)?,
        |d| &d.scaling.label,
        args.io.partition.as_deref(),
        &args.io.labeled_frames,
    )?;
    let (mut models, mut coords, mut error_rows, mut labels) =
        (Vec::new(), PcaCoords::default(), Vec::new(), Vec::new());
    let bar = reprise_stagekit::progress(data.len() as u64, "pca");
    for d in &data {
        let fit = |scaled: bool| {
            Pca::fit(&d.matrix(&labeled, scaled), d.scaling.used.len(), &args.params())
                .map_err(|e| StageError::Numerical(format!("label `{}`: {e}", d.scaling.label)))
        };
        let (scaled, unscaled) = (fit(true)?, fit(false)?);
        for (variant, pca) in [(SCALED, &scaled), (UNSCALED, &unscaled)] {
            if variant == UNSCALED && !args.write_unscaled {
                continue;
            }
            models.push(d.scaling.pca_model(pca, variant));
            let z = d.matrix(&labeled, variant == SCALED);
            let u = d.scaling.used.len();
            for (i, &r) in d.rows.iter().enumerate() {
                coords.label.push(d.scaling.label.clone());
                coords.variant.push(variant.into());
                coords.segment_id.push(labeled.segment_id[r]);
                coords.clip.push(labeled.frames.clip[r].clone());
                coords.frame.push(labeled.frames.frame[r]);
                coords.y.push(pca.project(&z[i * u..(i + 1) * u], pca.kept));
            }
        }
        error_rows.extend(errors::measure(&labeled, d, &scaled, &unscaled, &args.fixed_d, rig.as_ref())?);
        labels.push(LabelSummary {
            label: d.scaling.label.clone(),
            frames: d.rows.len(),
            controls: d.scaling.used.len(),
            d: scaled.kept,
            explained: scaled.cumulative_explained()[scaled.kept - 1],
            d_unscaled: unscaled.kept,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    pca::write_models(&args.io.models, &labeled.frames.controls, &models, &provenance)?;
    pca::write_coords(&args.io.coords, &coords, &provenance)?;
    pca::write_errors(&args.io.errors, &error_rows, &provenance)?;
    Ok(Some(Summary { labels, errors: error_rows }))
}

#[cfg(test)]
mod summary_tests {
    /// A line per label, then its errors at d = 3, 10 and its own d, "-" where a variant
    /// was not measured.
    #[test]
    fn the_summary_compares_scaled_and_unscaled() {
        let l = super::LabelSummary {
            label: "happy".into(),
            frames: 300,
            controls: 700,
            d: 5,
            explained: 0.86,
            d_unscaled: 7,
        };
        let err = |variant: &str, d, mesh| reprise_artifact::pca::PcaError {
            label: "happy".into(),
            variant: variant.into(),
            d,
            which: "fixed".into(),
            explained: 0.5,
            rig_rmse: 1.0,
            mesh_rmse: Some(mesh),
        };
        let s = super::Summary { labels: vec![l], errors: vec![err("scaled", 3, 0.25), err("unscaled", 3, 0.5)] };
        let text = s.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4, "{text}");
        assert!(lines[1].starts_with("happy") && lines[1].contains("0.860"), "{text}");
        assert_eq!(lines[3], "  happy        d=3: 0.2500 / 0.5000   d=10: -   d=5: -");
    }
}
