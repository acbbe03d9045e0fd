//! The gplvm stage (Bailey et al. 2016 §4.3): per label, a GPLVM mapping a $q$-dimensional
//! latent space to the label's scaled-PCA coordinates, with the dynamics prior (a GP over
//! each segment's frame times, fixed hyperparameters) and the connectivity prior, fitted
//! by MAP with SCG from the whitened first $q$ PCA coordinates. Labels are fitted in
//! parallel (one rayon task and one progress bar per label; each fit is sequential).
//!
//! Optionally (`--heldout-every K`), a held-out check per label (`heldout`): every K-th
//! frame is left out, a PCA basis and a second model are fitted on the rest, and each
//! held-out frame is reconstructed through its best latent point, beside PCAs of the same
//! training frames with $q$ and $d$ components; and a generative check, held-out frames
//! between two training frames from the midpoint of their latents, beside linear
//! interpolation. All as RMS mesh errors.

mod heldout;
pub mod summary;

use std::collections::HashMap;
use std::time::Instant;

use clap::Parser;
use rayon::prelude::*;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::gplvm::{self, FitSummary, GplvmModel, Latents, Trace};

use reprise_artifact::pca::{self, SCALED};
use reprise_numerics::gplvm::{
    ConnectivityParams, ConnectivityPath, DynamicsParams, Fit, FitConfig, FitData, Jitter, LikelihoodConfig, Optimizer,
};
use reprise_numerics::lbfgs::LbfgsOptions;
use reprise_numerics::optim::{Convergence, StopReason};
use reprise_numerics::scg::ScgOptions;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

/// Which optimiser fits the labels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OptimizerKind {
    /// Limited-memory BFGS.
    Lbfgs,
    /// Netlab's scaled conjugate gradients.
    Scg,
}

/// When the optimiser stops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopRule {
    /// The convergence rule of `reprise_numerics::optim`.
    Converged,
    /// Netlab's step tests (SCG only).
    Netlab,
}

/// How the connectivity prior enters the fit (see `ConnectivityPath`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PathKind {
    /// The exact prior throughout.
    Exact,
    /// The subset prior to convergence, then the exact prior to convergence.
    Staged,
    /// The subset prior throughout.
    Subset,
    /// The coarse-graph prior throughout (runs of --connectivity-stride frames as one node).
    Coarse,
    /// Exact for labels of at most 300 frames, coarse up to 2,000, the subset prior on 300
    /// frames spread evenly over the label above (`sampled`).
    Auto,
}

/// Which labels get the sparse GPLVM (see `Args::inducing_for`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SparseRule {
    /// Labels of more than --dense-max-frames frames.
    Auto,
    /// None: a label of more than --dense-max-frames frames is an error.
    Never,
    /// Every label.
    Always,
}

/// The latent dimension q when `--q` is not given: the paper's 3.
pub const DEFAULT_Q: usize = 3;

/// The largest label the dense GPLVM fits by default: the paper trains labels of a few
/// hundred frames, and the dense fit stays the reference up to here; above, one dense
/// evaluation costs more than ten sparse ones at the default M (`reprise-bench --sparse`).
pub const DEFAULT_DENSE_MAX_FRAMES: usize = 1000;

/// Inducing points of a sparse fit by default (GPmat's FGPLVM uses 100 active points).
pub const DEFAULT_INDUCING: usize = 100;

reprise_stagekit::stage_io! {
    stage: "gplvm", bin: "reprise-gplvm",
    partition: Label { by: "labeled_frames" },
    derived: [],
    inputs {
        /// Input: per-frame PCA coordinates (the `scaled` variant is modelled).
        coords: required "pca_coords.parquet",
        /// Input: the labeled frames (frame rate; the held-out check's original poses).
        labeled_frames: required "labeled_frames.parquet",
        /// Input (held-out check only): the PCA models.
        pca_models: optional "pca_models.parquet",
        /// Input (held-out check only): the scales.
        scales: optional "scales.parquet",
        /// Input (held-out check only): the controls table, naming the rig.
        controls: optional "controls.parquet",
    }
    outputs {
        /// Output: latent points per frame.
        latents: artifact "gplvm_latents.parquet",
        /// Output: the models (hyperparameters, latents, K⁻¹Y, offsets).
        models: artifact "gplvm_models.parquet",
        /// Output: the optimisation trace.
        trace: artifact "gplvm_trace.parquet",
        /// Output: one summary row per label.
        fits: artifact "gplvm_fits.parquet",
    }
}

/// `reprise-gplvm`: one GPLVM per label.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-gplvm", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,

    /// Latent dimension q (the paper: 3).
    #[arg(long, default_value_t = DEFAULT_Q)]
    pub q: usize,
    /// The optimiser: `lbfgs` or `scg` (Netlab's, the paper's).
    #[arg(long, value_enum, default_value_t = OptimizerKind::Lbfgs)]
    pub optimizer: OptimizerKind,
    /// When to stop: `converged` (relative decrease over a window AND scaled gradient,
    /// see reprise_numerics::optim) or `netlab` (SCG only: Netlab's --xtol AND --ftol on
    /// one step, the setting before convergence was defined).
    #[arg(long, value_enum, default_value_t = StopRule::Converged)]
    pub stop: StopRule,
    /// Iteration cap per label: a safety net; a fit that reaches it is reported as NOT
    /// converged.
    #[arg(long, default_value_t = 10_000)]
    pub max_iters: usize,
    /// Optimise the latents whitened by the dynamics prior, X = L_t Z per segment (the same
    /// objective and optimum; its conditioning is what lets the fits converge).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub whiten: bool,
    /// L-BFGS: correction pairs kept (its memory).
    #[arg(long, default_value_t = 30)]
    pub lbfgs_memory: usize,
    /// `converged`: window W of accepted iterations for the relative-decrease test.
    #[arg(long, default_value_t = 10)]
    pub window: usize,
    /// `converged`: largest mean relative decrease of E per iteration over the window.
    #[arg(long, default_value_t = 1e-9)]
    pub rel_ftol: f64,
    /// `converged`: largest scaled gradient max_i |g_i| max(|p_i|, 1) / max(|E|, N·d).
    #[arg(long, default_value_t = 1e-5)]
    pub rel_gtol: f64,
    /// `netlab`: tolerance on the largest parameter change of an accepted step (Netlab options(2)).
    #[arg(long, default_value_t = 1e-4)]
    pub xtol: f64,
    /// `netlab`: tolerance on the objective change of an accepted step (Netlab options(3));
    /// Netlab stops when both the x and f tests pass.
    #[arg(long, default_value_t = 1e-4)]
    pub ftol: f64,
    /// Keep the RBF length scale ℓ at 1 (a choice of units for the latents): with ℓ free the
    /// dynamics prior shrinks X and ℓ together without end and no fit converges.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub fix_lengthscale: bool,
    /// Initial white variance relative to the RBF variance (which starts at var(Y)).
    #[arg(long, default_value_t = 0.05)]
    pub init_white_ratio: f64,
    /// Floor on σ_w² relative to σ_f².
    #[arg(long, default_value_t = 1e-6)]
    pub white_floor: f64,
    /// Noise floor ε: σ_w² ≥ ε · (mean per-dimension variance of the label's PCA
    /// coordinates Y), a floor tied to the data, not to σ_f² (0: off). Without it a fit
    /// can interpolate the noise (σ_w² on its 1e-6 σ_f² floor) and never converge.
    #[arg(long, default_value_t = 1e-2)]
    pub noise_floor: f64,
    /// Signal prior: standard deviation of log σ_f² under a Gaussian prior centred on the
    /// log of the mean per-dimension variance of Y (0: off). With ℓ fixed it removes the
    /// ridge X → 0, σ_f² → ∞ along which no fit converged (docs/method.md, "The GPLVM fit").
    #[arg(long, default_value_t = 0.25)]
    pub signal_prior_sd: f64,
    /// Jitter always added to the diagonal of K (GPy: 1e-8).
    #[arg(long, default_value_t = 1e-8)]
    pub jitter: f64,
    /// Escalations of the jitter (×10 from 1e-6 × mean diagonal) before a Cholesky failure is an error.
    #[arg(long, default_value_t = 5)]
    pub jitter_retries: u32,

    /// Use the dynamics prior.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub dynamics: bool,
    /// Dynamics prior: RBF variance σ_t².
    #[arg(long, default_value_t = 1.0)]
    pub dynamics_variance: f64,
    /// Dynamics prior: time length scale ℓ_t, seconds.
    #[arg(long, default_value_t = 0.2)]
    pub dynamics_lengthscale: f64,
    /// Dynamics prior: white variance σ_tw².
    #[arg(long, default_value_t = 1e-4)]
    pub dynamics_white: f64,
    /// Dynamics prior: weight on its log density.
    #[arg(long, default_value_t = 1.0)]
    pub dynamics_weight: f64,

    /// Use the connectivity prior.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub connectivity: bool,
    /// Connectivity prior: exponent p of the weights ‖xᵢ − xⱼ‖⁻ᵖ.
    #[arg(long, default_value_t = 4.0)]
    pub connectivity_power: f64,
    /// Connectivity prior: diffusion time β (× N/400 with --connectivity-scale-with-n).
    #[arg(long, default_value_t = 1.0)]
    pub connectivity_beta: f64,
    /// Connectivity prior: weight w_c (× (500/N)² with --connectivity-scale-with-n).
    #[arg(long, default_value_t = 1e-3)]
    pub connectivity_weight: f64,
    /// Scale β and w_c with N as GPCM does.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub connectivity_scale_with_n: bool,
    /// How the connectivity prior enters the fit: `exact` throughout; `staged` (the prior
    /// on every --connectivity-stride-th frame to convergence, then the exact prior to
    /// convergence); `subset` (the subset prior throughout, exact only reported);
    /// `coarse` (the prior of the graph whose nodes are runs of --connectivity-stride
    /// consecutive frames, every frame keeping its own weights: ≈ stride⁻³ of the exact
    /// cost, value within about 1 % of it; exact also reported); `auto` (exact for labels
    /// of at most 300 frames, coarse above).
    #[arg(long, value_enum, default_value_t = PathKind::Auto)]
    pub connectivity_path: PathKind,
    /// Stride of the subset for `staged` and `subset`; frames per node for `coarse`/`auto`.
    #[arg(long, default_value_t = 3)]
    pub connectivity_stride: usize,

    /// Which labels get the sparse (DTC) GPLVM: `auto` those of more than
    /// --dense-max-frames frames, `never` none (a larger label is then an error),
    /// `always` every label.
    #[arg(long, value_enum, default_value_t = SparseRule::Auto)]
    pub sparse: SparseRule,
    /// The largest label `--sparse auto` fits with the dense GPLVM (the paper's; one
    /// evaluation costs O(N³) time and several N × N matrices).
    #[arg(long, default_value_t = DEFAULT_DENSE_MAX_FRAMES)]
    pub dense_max_frames: usize,
    /// Inducing points M of a sparse fit (one evaluation costs O(N M²)).
    #[arg(long, default_value_t = DEFAULT_INDUCING)]
    pub inducing: usize,
    /// The sparse objective: Titsias's collapsed variational bound (true), or the DTC
    /// likelihood without its trace term (false).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub sparse_bound: bool,

    /// Held-out check: leave out every K-th frame of each label (0: off).
    #[arg(long, default_value_t = 0)]
    pub heldout_every: usize,
    /// Worker threads for the labels (0: one per core).
    #[arg(long, default_value_t = 0)]
    #[serde(skip)]
    pub threads: usize,
}

impl Args {
    /// The fit configuration for frame times in seconds.
    pub fn fit_config(&self) -> FitConfig {
        FitConfig {
            q: self.q,
            init_white_ratio: self.init_white_ratio,
            fix_lengthscale: self.fix_lengthscale,
            likelihood: LikelihoodConfig {
                jitter: Jitter { base: self.jitter, max_retries: self.jitter_retries, ..Jitter::GPY },
                white_floor: self.white_floor,
                ..Default::default()
            },
            noise_floor: self.noise_floor,
            signal_prior_sd: self.signal_prior_sd,
            dynamics: self.dynamics.then_some(DynamicsParams {
                rbf_variance: self.dynamics_variance,
                lengthscale: self.dynamics_lengthscale,
                white_variance: self.dynamics_white,
                weight: self.dynamics_weight,
                ..Default::default()
            }),
            connectivity: self.connectivity.then_some(ConnectivityParams {
                power: self.connectivity_power,
                beta: self.connectivity_beta,
                weight: self.connectivity_weight,
                scale_beta_with_n: self.connectivity_scale_with_n,
                scale_weight_with_n: self.connectivity_scale_with_n,
                ..Default::default()
            }),
            connectivity_path: match self.connectivity_path {
                PathKind::Exact => ConnectivityPath::Exact,
                PathKind::Staged => ConnectivityPath::Staged { stride: self.connectivity_stride },
                PathKind::Subset => ConnectivityPath::Subset { stride: self.connectivity_stride },
                PathKind::Coarse => ConnectivityPath::Coarse { size: self.connectivity_stride },
                PathKind::Auto => ConnectivityPath::Auto { size: self.connectivity_stride },
            },
            optimizer: self.optimizer(),
            whiten: self.whiten,
            inducing: None,
            sparse_bound: self.sparse_bound,
        }
    }

    /// The inducing points of a label of `frames` frames under the per-label rule
    /// (`None`: the dense fit), or why the label cannot be fitted.
    pub fn inducing_for(&self, label: &str, frames: usize) -> StageResult<Option<usize>> {
        let sparse = match self.sparse {
            SparseRule::Never if frames > self.dense_max_frames => {
                return Err(StageError::Config(format!(
                    "label `{label}` has {frames} frames, more than --dense-max-frames {}, and --sparse never: \
                     the dense fit would hold several {frames} × {frames} matrices ({:.1} GB each) and take O(N³) \
                     per evaluation; use --sparse auto (or raise --dense-max-frames)",
                    self.dense_max_frames,
                    (frames * frames * 8) as f64 / 1e9
                )))
            }
            SparseRule::Never => false,
            SparseRule::Auto => frames > self.dense_max_frames,
            SparseRule::Always => true,
        };
        if sparse && self.inducing > frames {
            return Err(StageError::Config(format!(
                "label `{label}` has {frames} frames, fewer than --inducing {}: a sparse fit has at most one \
                 inducing point per frame; lower --inducing or use --sparse auto",
                self.inducing
            )));
        }
        Ok(sparse.then_some(self.inducing))
    }

    fn optimizer(&self) -> Optimizer {
        let convergence = Convergence { window: self.window, ftol: self.rel_ftol, gtol: self.rel_gtol, f_typical: 1.0 };
        match (self.optimizer, self.stop) {
            (OptimizerKind::Lbfgs, _) => Optimizer::Lbfgs(LbfgsOptions {
                memory: self.lbfgs_memory,
                max_iters: self.max_iters,
                convergence,
                ..Default::default()
            }),
            (OptimizerKind::Scg, StopRule::Converged) => Optimizer::scg(convergence, self.max_iters),
            (OptimizerKind::Scg, StopRule::Netlab) => Optimizer::Scg(ScgOptions {
                max_iters: self.max_iters,
                xtol: self.xtol,
                ftol: self.ftol,
                convergence,
                ..Default::default()
            }),
        }
    }

    fn validate(&self) -> StageResult<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let checks: [(bool, &str); 16] = [
            (self.inducing >= 1, "--inducing must be at least 1"),
            (
                self.sparse != SparseRule::Auto || self.inducing <= self.dense_max_frames + 1,
                "--inducing must be at most --dense-max-frames + 1 (the smallest label --sparse auto fits sparse)",
            ),
            (self.q >= 1, "--q must be at least 1"),
            (self.max_iters >= 1, "--max-iters must be at least 1"),
            ((1..=1000).contains(&self.lbfgs_memory), "--lbfgs-memory must be between 1 and 1000"),
            (pos(self.xtol) && pos(self.ftol), "--xtol and --ftol must be positive"),
            (
                self.window >= 1 && pos(self.rel_ftol) && pos(self.rel_gtol),
                "--window, --rel-ftol and --rel-gtol must be positive",
            ),
            (self.connectivity_stride >= 1, "--connectivity-stride must be at least 1"),
            (
                !(self.stop == StopRule::Netlab && self.optimizer == OptimizerKind::Lbfgs),
                "--stop netlab is SCG's step test: use it with --optimizer scg",
            ),
            (pos(self.init_white_ratio), "--init-white-ratio must be positive"),
            (
                self.white_floor.is_finite()
                    && self.white_floor >= 0.0
                    && self.noise_floor.is_finite()
                    && self.noise_floor >= 0.0,
                "--white-floor and --noise-floor must be >= 0",
            ),
            (self.signal_prior_sd.is_finite() && self.signal_prior_sd >= 0.0, "--signal-prior-sd must be >= 0"),
            (self.jitter.is_finite() && self.jitter >= 0.0, "--jitter must be >= 0"),
            (
                pos(self.dynamics_variance) && pos(self.dynamics_lengthscale) && pos(self.dynamics_white),
                "--dynamics-variance, --dynamics-lengthscale and --dynamics-white must be positive",
            ),
            (
                pos(self.connectivity_power) && pos(self.connectivity_beta) && self.connectivity_weight >= 0.0,
                "--connectivity-power and --connectivity-beta must be positive, --connectivity-weight >= 0",
            ),
            (self.heldout_every != 1, "--heldout-every 1 would leave nothing to train on; use 0 (off) or >= 2"),
        ];
        if let Some((_, msg)) = checks.iter().find(|(ok, _)| !ok) {
            return Err(StageError::Config((*msg).into()));
        }
        if self.heldout_every >= 2
            && (self.io.pca_models.is_none() || self.io.scales.is_none() || self.io.controls.is_none())
        {
            return Err(StageError::Config(
                "--heldout-every needs --pca-models, --scales and --controls (to reconstruct poses and evaluate meshes)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// One label's training data, gathered from the PCA coordinates.
#[derive(Debug, Clone)]
pub struct LabelData {
    /// The label.
    pub label: String,
    /// PCA dimension $d$ of the label.
    pub d: usize,
    /// Row-major `N × d`.
    pub y: Vec<f64>,
    /// Seconds from the segment's first frame.
    pub times: Vec<f64>,
    /// Segment id of each row.
    pub segments: Vec<i64>,
    /// Clip of each row.
    pub clips: Vec<String>,
    /// Frame number (in its clip) of each row.
    pub frames: Vec<i64>,
}

impl LabelData {
    /// Number of frames $N$.
    pub fn n(&self) -> usize {
        self.frames.len()
    }

    /// The rows `keep` only.
    pub fn subset(&self, keep: &[usize]) -> Self {
        let d = self.d;
        Self {
            label: self.label.clone(),
            d,
            y: keep.iter().flat_map(|&i| self.y[i * d..(i + 1) * d].to_vec()).collect(),
            times: keep.iter().map(|&i| self.times[i]).collect(),
            segments: keep.iter().map(|&i| self.segments[i]).collect(),
            clips: keep.iter().map(|&i| self.clips[i].clone()).collect(),
            frames: keep.iter().map(|&i| self.frames[i]).collect(),
        }
    }

    /// As the fit's input.
    pub fn fit_data(&self) -> FitData<'_> {
        FitData { y: &self.y, d: self.d, times: &self.times, segments: &self.segments }
    }
}

/// Every label's training data from the `pca_coords` and `labeled_frames` artifacts (for
/// tools that fit single labels outside the stage, e.g. `examples/gplvm_diagnose.rs`).
pub fn read_labels(coords: &std::path::Path, labeled_frames: &std::path::Path) -> StageResult<Vec<LabelData>> {
    let pc = pca::read_coords(coords)?;
    let labeled = LabeledFrames::read(labeled_frames)?;
    gather(&pc, labeled.frames.fps, coords)
}

/// Per label, in first-appearance order: the scaled coordinates, with frame times in
/// seconds from each segment's first frame at `fps`.
fn gather(coords: &pca::PcaCoords, fps: f64, path: &std::path::Path) -> StageResult<Vec<LabelData>> {
    let mut out: Vec<LabelData> = Vec::new();
    let mut seg_start: std::collections::HashMap<i64, i64> = std::collections::HashMap::new();
    for r in (0..coords.label.len()).filter(|&r| coords.variant[r] == SCALED) {
        let e = seg_start.entry(coords.segment_id[r]).or_insert(coords.frame[r]);
        *e = (*e).min(coords.frame[r]);
    }
    for r in (0..coords.label.len()).filter(|&r| coords.variant[r] == SCALED) {
        let label = &coords.label[r];
        let i = match out.iter().position(|l| &l.label == label) {
            Some(i) => i,
            None => {
                out.push(LabelData {
                    label: label.clone(),
                    d: coords.y[r].len(),
                    y: vec![],
                    times: vec![],
                    segments: vec![],
                    clips: vec![],
                    frames: vec![],
                });
                out.len() - 1
            }
        };
        let l = &mut out[i];
        if coords.y[r].len() != l.d {
            return Err(StageError::Input(format!(
                "{}: row {r}: label `{label}` has {} coordinates here but {} on its first row",
                path.display(),
                coords.y[r].len(),
                l.d
            )));
        }
        l.y.extend_from_slice(&coords.y[r]);
        l.times.push((coords.frame[r] - seg_start[&coords.segment_id[r]]) as f64 / fps);
        l.segments.push(coords.segment_id[r]);
        l.clips.push(coords.clip[r].clone());
        l.frames.push(coords.frame[r]);
    }
    if out.is_empty() {
        return Err(StageError::Input(format!("{}: no `scaled` coordinates to model", path.display())));
    }
    Ok(out)
}

/// Fits one label, reporting each evaluation and its objective to `bar` as `name` (the
/// label, or the label's held-out refit: each fit has a bar of its own).
pub(crate) fn fit_label(
    data: &LabelData,
    config: &FitConfig,
    bar: &reprise_stagekit::ProgressBar,
    name: &str,
) -> StageResult<Fit> {
    let report = |objective: f64| {
        bar.inc(1);
        bar.set_message(format!("{name} objective {objective:.1}"));
    };
    let fit = reprise_numerics::gplvm::fit(data.fit_data(), config, report).map_err(|e| {
        StageError::Numerical(format!("label `{}` ({} frames, d = {}): {e}", data.label, data.n(), data.d))
    })?;
    if fit.info.reason == StopReason::NonFiniteStart {
        let why = fit.last.error.as_ref().map_or("non-finite value or gradient".to_string(), |e| e.to_string());
        return Err(StageError::Numerical(format!("label `{}`: the objective at the start: {why}", data.label)));
    }
    Ok(fit)
}

/// Runs the stage (or only validates, with `--check`). Returns the per-label summaries.
pub fn run(args: &Args) -> StageResult<Option<Vec<FitSummary>>> {
    use reprise_stagekit::wiring;
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let coords = pca::read_coords(&args.io.coords)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let labels = gather(&coords, labeled.frames.fps, &args.io.coords)?;
    let mut labels = wiring::only_partition(labels, |l| &l.label, args.io.partition.as_deref(), &args.io.coords)?;
    let config = args.fit_config();
    // The per-label rule, for every label before any fit starts.
    let inducing: HashMap<String, Option<usize>> = labels
        .iter()
        .map(|l| Ok((l.label.clone(), args.inducing_for(&l.label, l.n())?)))
        .collect::<StageResult<_>>()?;
    let checker = (args.heldout_every >= 2).then(|| heldout::Checker::open(args, &labeled)).transpose()?;
    // Largest first, so that two workers finish together.
    labels.sort_by_key(|l| std::cmp::Reverse(l.n()));
    let multi = reprise_stagekit::multi_progress();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| StageError::Config(format!("thread pool: {e}")))?;
    let results: Vec<StageResult<(Fit, FitSummary)>> = pool.install(|| {
        labels
            .par_iter()
            .map(|l| {
                let config = FitConfig { inducing: inducing[&l.label], ..config.clone() };
                let config = &config;
                // A fit stops when it converges: the bar counts evaluations, with no total.
                let bar = reprise_stagekit::counter_in(&multi, &l.label, "objective evaluations");
                let held_name = format!("{} held-out refit", l.label);
                let held_bar =
                    checker.as_ref().map(|_| reprise_stagekit::counter_in(&multi, &held_name, "objective evaluations"));
                // The fit and the held-out refit are independent: two tasks, so that the
                // largest label's pair can take both cores.
                let (fit, held) = rayon::join(
                    || {
                        let start = Instant::now();
                        fit_label(l, config, &bar, &l.label).map(|f| (f, start.elapsed().as_secs_f64()))
                    },
                    || {
                        let (c, b) = (checker.as_ref()?, held_bar.as_ref()?);
                        Some(c.check(l, config, args.heldout_every, b, &held_name))
                    },
                );
                let ((fit, seconds), held) = (fit?, held.transpose()?);
                bar.finish_and_clear();
                if let Some(b) = &held_bar {
                    b.finish_and_clear();
                }
                let summary = FitSummary {
                    label: l.label.clone(),
                    frames: l.n() as i64,
                    d: l.d as i64,
                    q: config.q as i64,
                    inducing_points: config.inducing.unwrap_or(0) as i64,
                    optimizer: config.optimizer.name().into(),
                    connectivity_path: config.connectivity_path.for_frames(l.n()).name().into(),
                    stage_iterations: fit.stage_iterations.iter().map(|&i| i as i64).collect(),
                    iterations: fit.info.iterations as i64,
                    evaluations: fit.info.evaluations as i64,
                    initial_objective: fit.initial.value,
                    objective: fit.minimised.value,
                    neg_log_likelihood: fit.minimised.likelihood,
                    dynamics: fit.minimised.dynamics,
                    connectivity: fit.minimised.connectivity,
                    signal: fit.minimised.signal,
                    connectivity_exact: fit.exact_connectivity.then_some(fit.last.connectivity),
                    grad_norm: fit.info.grad_norm,
                    rel_decrease: fit.info.measures.rel_decrease,
                    rel_gradient: fit.info.measures.rel_gradient,
                    jitter: fit.minimised.jitter.added,
                    dynamics_jitter: fit.dynamics_jitter.map_or(0.0, |j| j.added),
                    converged: fit.info.converged,
                    stop_reason: fit.info.reason.name().into(),
                    seconds,
                    heldout_gplvm_mesh_rmse: held.and_then(|h| h.gplvm_rmse),
                    heldout_pca_q_mesh_rmse: held.and_then(|h| h.pca_q_rmse),
                    heldout_pca_d_mesh_rmse: held.and_then(|h| h.pca_d_rmse),
                    heldout_d: held.map_or(0, |h| h.d as i64),
                    heldout_frames: held.map_or(0, |h| h.frames as i64),
                    generative_gplvm_mesh_rmse: held.and_then(|h| h.generative_gplvm_rmse),
                    generative_interp_mesh_rmse: held.and_then(|h| h.generative_interp_rmse),
                    generative_interp_d_mesh_rmse: held.and_then(|h| h.generative_interp_d_rmse),
                    generative_frames: held.map_or(0, |h| h.generative_frames as i64),
                };
                Ok((fit, summary))
            })
            .collect()
    });
    let results: Vec<(Fit, FitSummary)> = results.into_iter().collect::<StageResult<_>>()?;
    // Outputs in the labels' original (first-appearance) order.
    let mut order: Vec<usize> = (0..labels.len()).collect();
    order.sort_by_key(|&i| coords.label.iter().position(|l| *l == labels[i].label));
    let (mut latents, mut trace, mut models, mut summaries) = (Latents::default(), Trace::default(), vec![], vec![]);
    for i in order {
        let (l, (fit, summary)) = (&labels[i], &results[i]);
        let q = config.q;
        for r in 0..l.n() {
            latents.label.push(l.label.clone());
            latents.segment_id.push(l.segments[r]);
            latents.clip.push(l.clips[r].clone());
            latents.frame.push(l.frames[r]);
            latents.time.push(l.times[r]);
            latents.x.push(fit.x[r * q..(r + 1) * q].to_vec());
        }
        for (k, it) in fit.trace.iter().enumerate() {
            trace.label.push(l.label.clone());
            trace.iteration.push(k as i64 + 1);
            trace.value.push(it.value);
            trace.grad_norm.push(it.grad_norm);
            trace.beta.push(it.beta);
            trace.accepted.push(it.accepted);
            trace.evaluations.push(it.evaluations as i64);
            trace.seconds.push(it.seconds);
        }
        models.push(GplvmModel {
            label: l.label.clone(),
            q,
            d: l.d,
            rbf_variance: fit.hyper.rbf_variance,
            lengthscale: fit.hyper.lengthscale,
            white_variance: fit.hyper.white_variance,
            white_variance_used: fit.predictor.white_variance_used(),
            jitter: fit.predictor.jitter_used().added,
            x: fit.x.clone(),
            inducing: if fit.predictor.is_sparse() { fit.predictor.x().to_vec() } else { vec![] },
            kinv_y: fit.predictor.kinv_y().to_vec(),
            offset: fit.offset.clone(),
        });
        summaries.push(summary.clone());
    }
    gplvm::write_latents(&args.io.latents, &latents, &provenance)?;
    gplvm::write_models(&args.io.models, &models, &provenance)?;
    gplvm::write_trace(&args.io.trace, &trace, &provenance)?;
    gplvm::write_fits(&args.io.fits, &summaries, &provenance)?;
    Ok(Some(summaries))
}
