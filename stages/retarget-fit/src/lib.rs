//! The retarget-fit stage: learns how a capture (marker positions) maps onto a character's
//! rig from a few labelled pairs, by the semi-supervised shared GPLVM of Bouaziz and Pauly
//! (`reprise_retarget`).
//!
//! - **Source**: the capture's frames (`positions`: markers per frame), normalised.
//! - **Target**: the character's controls scaled by their effect on the mesh (the `scales`
//!   artifact's weights averaged over labels) and rotated by PCA over the labelled poses
//!   and any unlabelled ones ([`reprise_retarget::target`]). A control the corpus never
//!   moves has weight 0 and is held at its mean; the stage warns when the pairs move one.
//! - **Rows**: every labelled pair (a frame of `pairs`, named by the capture's clip and
//!   frame, holding the character's pose for it), `--source-frames` other capture frames
//!   spread evenly over the capture, and `--target-poses` corpus frames spread evenly over
//!   the corpus (none by default: see the option).
//! - **Start**: the paper's semi-supervised manifold alignment (Ham et al.), the capture's
//!   neighbourhoods taken with its noise removed.
//! - **Noise**: $\sigma_c$ is `--capture-noise` (the capture system's, capture units);
//!   $\sigma_t$ is the capture's RMS step between consecutive frames less the part the
//!   noise explains ([`reprise_retarget::model::temporal_noise`]).
//!
//! The model ([`reprise_artifact::retarget`]) holds everything `retarget-apply` needs
//! besides the capture to map.

use std::collections::{BTreeMap, HashMap};
use std::time::Instant;

use clap::Parser;
use reprise_artifact::frames::Frames;
use reprise_artifact::positions::Positions;
use reprise_artifact::retarget::{FitInfo, Normalisation, Retarget, Role, Settings, TargetSpace as SpaceMeta};
use reprise_retarget::model::{step_rms, temporal_noise, Init, Model, Prior, Settings as FitSettings, TrainingSet};
use reprise_retarget::target::TargetSpace;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "retarget-fit", bin: "reprise-retarget-fit",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the capture, marker positions per frame.
        capture: required "positions.parquet",
        /// Input: the labelled pairs: the character's pose (a frame table on its controls)
        /// for some capture frames, named by the capture's clip and frame.
        pairs: required "pairs.parquet",
        /// Input: the character's corpus (a frame table), its unlabelled poses.
        corpus: required "frames.parquet",
        /// Input: the character's scales (control weights).
        scales: required "scales.parquet",
    }
    outputs {
        /// Output: the fitted model.
        model: artifact "retarget.parquet",
    }
}

/// `reprise-retarget-fit`: a shared GPLVM from a few labelled pairs.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-retarget-fit", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// The capture system's noise σc: standard deviation of a marker coordinate, capture units.
    #[arg(long)]
    pub capture_noise: Option<f64>,
    /// Latent dimension (the paper: 8).
    #[arg(long, default_value_t = 8)]
    pub q: usize,
    /// LLE neighbours of the prior and of the start's graphs (the paper: 8); 0 turns the
    /// LLE prior off (a unit Gaussian prior remains).
    #[arg(long, default_value_t = 8)]
    pub lle_neighbours: usize,
    /// Unlabelled capture frames, spread evenly over the capture.
    #[arg(long, default_value_t = 100)]
    pub source_frames: usize,
    /// Unlabelled character poses, spread evenly over the corpus.
    /// The paper adds them; on the dragon-face analogue of protocol B (docs/retarget.md)
    /// they made the mapping worse (mesh error 0.457 with 100 against 0.373 with none, mean
    /// of three label sets): their rows take over the target kernel's fit.
    #[arg(long, default_value_t = 0)]
    pub target_poses: usize,
    /// Share of the scaled poses' variance the target space keeps. The default keeps every
    /// component: the target GP's mean is a combination of its training poses, so a
    /// truncation can only lose what it could have predicted.
    #[arg(long, default_value_t = 1.0)]
    pub variance: f64,
    /// Most target-space components.
    #[arg(long, default_value_t = 256)]
    pub max_components: usize,
    /// L-BFGS iterations at most.
    #[arg(long, default_value_t = 500)]
    pub iterations: usize,
    /// Where the latents start: `alignment` (the paper's) or `pca`.
    #[arg(long, default_value = "alignment")]
    pub init: String,
    /// Capture clips to use: glob patterns (comma-separated; none: every clip).
    #[arg(long, value_delimiter = ',')]
    pub clips: Vec<String>,
    /// Corpus clips to use: glob patterns (comma-separated; none: every clip).
    #[arg(long, value_delimiter = ',')]
    pub corpus_clips: Vec<String>,
    /// Frame rate of a capture without `reprise.fps` metadata.
    #[arg(long)]
    pub fps: Option<f64>,
}

/// Limit: latent rows of a model (the fit is cubic in them).
pub const MAX_MODEL_ROWS: usize = 2_000;

/// What the stage fitted.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Rows by role: (labelled, source, target).
    pub rows: (usize, usize, usize),
    /// Latent dimension.
    pub q: usize,
    /// Target-space components and the variance share they keep.
    pub components: (usize, f64),
    /// The fit.
    pub fit: FitInfo,
}

impl Args {
    fn validate(&self) -> StageResult<(f64, Init)> {
        let noise = reprise_retarget::model::capture_noise(self.capture_noise).map_err(StageError::Config)?;
        if self.q == 0 || self.q > 64 {
            return Err(StageError::Config(format!("--q {} must be in 1..=64", self.q)));
        }
        if !(self.variance > 0.0 && self.variance <= 1.0) || self.max_components == 0 {
            return Err(StageError::Config("--variance must be in (0, 1] and --max-components at least 1".into()));
        }
        if self.fps.is_some_and(|f| !(f.is_finite() && f > 0.0)) {
            return Err(StageError::Config("--fps must be finite and positive".into()));
        }
        let init = Init::parse(&self.init).map_err(StageError::Config)?;
        Ok((noise, init))
    }
}

/// `count` of `0..n` spread evenly (all of them when `count >= n`).
pub fn spread_evenly(n: usize, count: usize) -> Vec<usize> {
    if count >= n {
        return (0..n).collect();
    }
    (0..count).map(|i| i * n / count).collect()
}

/// The capture row of each pair, in the pairs' order, and the pairs' poses reordered to
/// `controls`.
///
/// # Errors
/// A pair naming a capture frame that does not exist (or a clip `--clips` leaves out), a
/// frame labelled twice, or a character control the pairs lack.
pub fn match_pairs(
    pairs: &Frames,
    pairs_path: &std::path::Path,
    capture: &Positions,
    usable: &[bool],
    controls: &[String],
) -> StageResult<(Vec<usize>, Vec<f64>)> {
    let index: HashMap<(&str, i64), usize> =
        (0..capture.frames()).map(|r| ((capture.clip[r].as_str(), capture.frame[r]), r)).collect();
    let columns: Vec<usize> = controls
        .iter()
        .map(|c| {
            pairs.controls.iter().position(|p| p == c).ok_or_else(|| {
                StageError::Input(format!("{}: no column for the character's control `{c}`", pairs_path.display()))
            })
        })
        .collect::<StageResult<_>>()?;
    let mut rows = Vec::with_capacity(pairs.rows());
    let mut seen = BTreeMap::new();
    for r in 0..pairs.rows() {
        let key = (pairs.clip[r].as_str(), pairs.frame[r]);
        let row = index.get(&key).copied().filter(|&c| usable[c]).ok_or_else(|| {
            StageError::Input(format!(
                "{}: row {r} labels clip `{}` frame {}, which the capture does not hold{}",
                pairs_path.display(),
                key.0,
                key.1,
                if index.contains_key(&key) { " among the clips --clips keeps" } else { "" }
            ))
        })?;
        if let Some(first) = seen.insert(row, r) {
            return Err(StageError::Input(format!(
                "{}: rows {first} and {r} both label clip `{}` frame {}",
                pairs_path.display(),
                key.0,
                key.1
            )));
        }
        rows.push(row);
    }
    let poses = (0..pairs.rows()).flat_map(|r| columns.iter().map(move |&c| pairs.row(r)[c])).collect();
    Ok((rows, poses))
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let (capture_noise, init) = args.validate()?;
    let clips = reprise_stagekit::clips::matcher(&args.clips, "--clips")?;
    let corpus_clips = reprise_stagekit::clips::matcher(&args.corpus_clips, "--corpus-clips")?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let capture = Positions::read(&args.io.capture, args.fps)?;
    let pairs = Frames::read(&args.io.pairs)?;
    let corpus = Frames::read(&args.io.corpus)?;
    let scales = reprise_artifact::scales::read(&args.io.scales)?;
    let controls = corpus.controls.clone();
    let weights = reprise_artifact::scales::mean_weights(&scales, &controls);
    if weights.iter().all(|&w| w <= 0.0) {
        return Err(StageError::Input(format!(
            "{}: no control of the corpus has a weight; run scale on this corpus",
            args.io.scales.display()
        )));
    }

    let usable: Vec<bool> = capture.clip.iter().map(|c| clips.as_ref().is_none_or(|m| m.is_match(c))).collect();
    let (labelled, label_poses) = match_pairs(&pairs, &args.io.pairs, &capture, &usable, &controls)?;
    if labelled.len() < 2 {
        return Err(StageError::Input(format!(
            "{}: {} labelled pair(s); at least 2 are needed",
            args.io.pairs.display(),
            labelled.len()
        )));
    }
    let others: Vec<usize> = (0..capture.frames()).filter(|&r| usable[r] && !labelled.contains(&r)).collect();
    let source_only: Vec<usize> =
        spread_evenly(others.len(), args.source_frames).into_iter().map(|i| others[i]).collect();
    let corpus_rows: Vec<usize> =
        (0..corpus.rows()).filter(|&r| corpus_clips.as_ref().is_none_or(|m| m.is_match(&corpus.clip[r]))).collect();
    let target_only: Vec<usize> =
        spread_evenly(corpus_rows.len(), args.target_poses).into_iter().map(|i| corpus_rows[i]).collect();
    let n = labelled.len() + source_only.len() + target_only.len();
    if n > MAX_MODEL_ROWS {
        return Err(StageError::Config(format!(
            "{n} latent rows ({} pairs, {} capture frames, {} poses) exceed {MAX_MODEL_ROWS}; lower \
             --source-frames or --target-poses",
            labelled.len(),
            source_only.len(),
            target_only.len()
        )));
    }

    // The target space from the corpus poses and the labelled ones.
    let c = controls.len();
    let corpus_poses: Vec<f64> = target_only.iter().flat_map(|&r| corpus.row(r).iter().copied()).collect();
    let space = TargetSpace::fit(
        &[label_poses.clone(), corpus_poses.clone()].concat(),
        &weights,
        args.variance,
        args.max_components,
    )
    .map_err(|e| {
        StageError::Input(format!(
            "the character's poses ({} labelled in {}, {} from {}): {e}",
            labelled.len(),
            args.io.pairs.display(),
            target_only.len(),
            args.io.corpus.display()
        ))
    })?;
    for (j, name) in controls.iter().enumerate().filter(|(j, _)| weights[*j] <= 0.0) {
        let moved = label_poses.chunks_exact(c).any(|p| (p[j] - label_poses[j]).abs() > 0.0);
        if moved {
            eprintln!(
                "retarget-fit: warning: the pairs move `{name}`, which has no weight in {} (the corpus never moves \
                 it, or it moves no vertex): it is held at its mean",
                args.io.scales.display()
            );
        }
    }
    let encode = |poses: &[f64]| -> Vec<f64> { poses.chunks_exact(c).flat_map(|p| space.encode(p)).collect() };
    let x: Vec<f64> = labelled.iter().chain(&source_only).flat_map(|&r| capture.row(r).iter().copied()).collect();
    let y = [encode(&label_poses), encode(&corpus_poses)].concat();
    let set = TrainingSet { x: &x, dx: capture.width(), y: &y, dy: space.d(), labelled: labelled.len() };
    let settings = FitSettings {
        q: args.q,
        // The alignment's graphs keep the paper's 8 neighbours when the LLE prior is off.
        k: if args.lle_neighbours > 0 { args.lle_neighbours } else { 8 },
        prior: if args.lle_neighbours > 0 { Prior::Lle } else { Prior::Gaussian },
        init,
        capture_noise,
        max_iters: args.iterations,
    };
    let started = Instant::now();
    let (model, info) =
        Model::fit(&set, &settings).map_err(|e| StageError::Input(format!("the shared GPLVM's fit: {e}")))?;
    let fit = FitInfo {
        iterations: info.iterations,
        objective: info.value,
        converged: info.converged,
        seconds: started.elapsed().as_secs_f64(),
    };
    let runs: Vec<std::ops::Range<usize>> = capture
        .clip_runs()
        .into_iter()
        .filter(|(clip, _, _)| clips.as_ref().is_none_or(|m| m.is_match(clip)))
        .map(|(_, a, b)| a..b)
        .collect();
    let sigma_t = temporal_noise(step_rms(&capture.values, capture.width(), &runs), capture_noise);

    let rows = |idx: &[usize], f: &dyn Fn(usize) -> (String, i64)| idx.iter().map(|&r| f(r)).collect::<Vec<_>>();
    let cap = |r: usize| (capture.clip[r].clone(), capture.frame[r]);
    let keys = [
        rows(&labelled, &cap),
        rows(&source_only, &cap),
        rows(&target_only, &|r| (corpus.clip[r].clone(), corpus.frame[r])),
    ]
    .concat();
    let role = [(Role::Labelled, labelled.len()), (Role::Source, source_only.len()), (Role::Target, target_only.len())]
        .iter()
        .flat_map(|&(r, k)| std::iter::repeat_n(r, k))
        .collect();
    let out = Retarget {
        role,
        clip: keys.iter().map(|k| k.0.clone()).collect(),
        frame: keys.iter().map(|k| k.1).collect(),
        z: model.z.clone(),
        x: model.x.clone(),
        y: model.y.clone(),
        settings: Settings {
            points: capture.points.clone(),
            controls,
            q: model.q,
            source: Normalisation { mean: model.x_norm.mean.clone(), scale: model.x_norm.scale },
            target: Normalisation { mean: model.y_norm.mean.clone(), scale: model.y_norm.scale },
            source_kernel: model.hyper_x.to_log(),
            target_kernel: model.hyper_y.to_log(),
            space: SpaceMeta {
                weights: space.weights.clone(),
                held: space.held.clone(),
                mean: space.mean.clone(),
                directions: space.directions.clone(),
                explained: space.explained,
            },
            capture_noise,
            temporal_noise: sigma_t,
            lle_neighbours: args.lle_neighbours,
            fit: fit.clone(),
            fps: capture.fps,
        },
    };
    out.write(&args.io.model, &provenance)?;
    Ok(Some(Summary { rows: out.counts(), q: model.q, components: (space.d(), space.explained), fit }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capture_noise_must_be_stated() {
        let args = |extra: &[&str]| {
            let base = [
                "reprise-retarget-fit",
                "--capture",
                "c",
                "--pairs",
                "p",
                "--corpus",
                "f",
                "--scales",
                "s",
                "--model",
                "m",
            ];
            Args::parse_from(base.iter().chain(extra))
        };
        assert!(run(&args(&[])).unwrap_err().to_string().contains("--capture-noise is required"));
        assert!(run(&args(&["--capture-noise=-1"])).unwrap_err().to_string().contains("finite and positive"));
        assert!(run(&args(&["--capture-noise", "0.001", "--init", "random"]))
            .unwrap_err()
            .to_string()
            .contains("--init"));
    }

    #[test]
    fn evenly_spread_rows_cover_the_range() {
        assert_eq!(spread_evenly(10, 3), vec![0, 3, 6]);
        assert_eq!(spread_evenly(3, 5), vec![0, 1, 2]);
        assert!(spread_evenly(0, 4).is_empty());
    }
}
