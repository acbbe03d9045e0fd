//! The invrig-fit stage (Holden et al. 2017 §4.1–4.2): an inverse rig mapping learned from
//! the animator's own curves. The training set is every frame of the clips not held out
//! (`--hold-out`) plus the rig's rest pose, each evaluated through the rig at the chosen
//! points ([`reprise_invrig::points::spread`]); $\theta_0$ is the paper's cross-validated
//! line search over $[10^{-4}, 10^2]$ (on at most `--cv-rows` training poses); the
//! training poses kept are the paper's subsample (rest, farthest points, largest errors).
//! The table written holds those poses; `invrig-apply` refits the regression from them.
//!
//! Controls no training pose moves are not free: the refinement holds them (the paper
//! removes "rig attributes not used by the animators" from the Jacobian).

use clap::Parser;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::Frames;
use reprise_artifact::invrig::{Invrig, Mapping, REST_CLIP};
use reprise_invrig::gpr::{cross_validate, gather, theta0_grid, CvSettings};
use reprise_invrig::subsample::{subsample, SubsampleSettings};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "invrig-fit", bin: "reprise-invrig-fit",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the frame table (the animator's curves to learn from).
        frames: required "frames.parquet",
        /// Input: the controls table (names the rig).
        controls: required "controls.parquet",
    }
    outputs {
        /// Output: the fitted mapping.
        invrig: artifact "invrig.parquet",
    }
}

/// `reprise-invrig-fit`: learn positions → controls from the animator's curves.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-invrig-fit", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Points the mapping reads, spread over the rest mesh (0: every vertex; a skeleton's
    /// vertices are its joints).
    #[arg(long, default_value_t = 0)]
    pub points: usize,
    /// Clips left out of training: glob patterns of clip names (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub hold_out: Vec<String>,
    /// Training poses kept (the paper's 750), at most the frames there are.
    #[arg(long, default_value_t = 750)]
    pub samples: usize,
    /// Of them, taken by distance after the rest pose (the rest by largest error).
    #[arg(long, default_value_t = 50)]
    pub farthest: usize,
    /// Poses added per refit in the largest-error phase (the paper's is 1; more is faster).
    #[arg(long, default_value_t = 25)]
    pub batch: usize,
    /// The Tikhonov term θ₁ of every regression.
    #[arg(long, default_value_t = reprise_invrig::gpr::DEFAULT_THETA1)]
    pub theta1: f64,
    /// θ₀ candidates, log-spaced over [1e-4, 1e2].
    #[arg(long, default_value_t = 25)]
    pub cv_candidates: usize,
    /// Random half-splits scored per candidate (the paper: 10).
    #[arg(long, default_value_t = 5)]
    pub cv_rounds: usize,
    /// Training poses the cross-validation draws from (a random subset when there are more).
    #[arg(long, default_value_t = 1000)]
    pub cv_rows: usize,
    /// Seed of the cross-validation's draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Limit: training frames read (all clips not held out). A bound on memory: each costs
    /// `8 · (3 · points + controls)` bytes.
    #[arg(long, default_value_t = 200_000)]
    pub max_frames: usize,
}

impl Args {
    fn validate(&self) -> StageResult<()> {
        if self.samples == 0 || self.batch == 0 || self.cv_candidates == 0 || self.cv_rounds == 0 || self.cv_rows < 2 {
            return Err(StageError::Config(
                "--samples, --batch, --cv-candidates and --cv-rounds must be at least 1, --cv-rows at least 2".into(),
            ));
        }
        if !(self.theta1.is_finite() && self.theta1 > 0.0) {
            return Err(StageError::Config(format!("--theta1 must be finite and positive, got {}", self.theta1)));
        }
        Ok(())
    }
}

/// What the fit found.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Training frames (rest pose included).
    pub training: usize,
    /// Poses kept.
    pub samples: usize,
    /// Points read.
    pub points: usize,
    /// Controls free to move, of all.
    pub free: (usize, usize),
    /// The chosen θ₀ and its validation error.
    pub theta0: (f64, f64),
    /// Seconds: cross-validation, subsampling.
    pub seconds: (f64, f64),
}

fn input(e: impl std::fmt::Display) -> StageError {
    StageError::Input(e.to_string())
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    args.validate()?;
    let held_out = reprise_stagekit::clips::matcher(&args.hold_out, "--hold-out")?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let frames = Frames::read(&args.io.frames)?;
    let controls = Controls::read(&args.io.controls)?;
    let rig = reprise_stagekit::rig::open_rig(&controls, &frames.controls)?;
    let (c, vertices) = (frames.controls.len(), rig.0.vertex_count());

    // The training poses: the rest pose, then every frame not held out.
    let rest_full = rig.0.rest_pose();
    let rest: Vec<f64> = frames.controls.iter().map(|n| rest_full[rig_index(rig.0.as_ref(), n)]).collect();
    let rows: Vec<usize> =
        (0..frames.rows()).filter(|&r| held_out.as_ref().is_none_or(|m| !m.is_match(&frames.clip[r]))).collect();
    if rows.is_empty() {
        return Err(StageError::Input(format!(
            "{}: every clip is held out by --hold-out {:?}; nothing to learn from",
            args.io.frames.display(),
            args.hold_out
        )));
    }
    if rows.len() > args.max_frames {
        return Err(StageError::Input(format!(
            "{}: {} training frames exceed --max-frames {}",
            args.io.frames.display(),
            rows.len(),
            args.max_frames
        )));
    }
    let mut y_rows: Vec<Vec<f64>> = vec![rest.clone()];
    y_rows.extend(rows.iter().map(|&r| frames.row(r).to_vec()));
    let points = reprise_invrig::points::spread(&rig.0.evaluate(&rest_full).map_err(input)?, args.points);
    let meshes = reprise_stagekit::rig::meshes(&rig, &y_rows)?;
    let x = reprise_invrig::points::select(&meshes, vertices, &points);
    drop(meshes);
    let d = 3 * points.len();
    let y: Vec<f64> = y_rows.concat();
    let n = y_rows.len();

    // θ₀ by the paper's line search, on a random subset of at most --cv-rows poses.
    let started = std::time::Instant::now();
    let mut pick: Vec<usize> = (0..n).collect();
    pick.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(args.seed));
    pick.truncate(args.cv_rows.min(n));
    pick.sort_unstable();
    let cv = cross_validate(
        &gather(&x, d, &pick),
        d,
        &gather(&y, c, &pick),
        c,
        &CvSettings {
            grid: theta0_grid(args.cv_candidates),
            rounds: args.cv_rounds,
            theta1: args.theta1,
            seed: args.seed,
        },
    )
    .map_err(|e| StageError::Input(format!("{}: cross-validation: {e}", args.io.frames.display())))?;
    let cv_seconds = started.elapsed().as_secs_f64();

    let started = std::time::Instant::now();
    let settings = SubsampleSettings {
        farthest: args.farthest,
        total: args.samples,
        batch: args.batch,
        theta0: cv.theta0,
        theta1: args.theta1,
    };
    let taken = subsample(&x, d, &y, c, 0, &settings)
        .map_err(|e| StageError::Input(format!("{}: subsampling: {e}", args.io.frames.display())))?;
    let subsample_seconds = started.elapsed().as_secs_f64();

    let mut order = taken.clone();
    // Rest first, then by row (clip order of the table, frames increasing).
    order.sort_unstable();
    let source = |i: usize| {
        if i == 0 {
            (REST_CLIP.to_string(), 0)
        } else {
            (frames.clip[rows[i - 1]].clone(), frames.frame[rows[i - 1]])
        }
    };
    let samples = Frames {
        fps: frames.fps,
        controls: frames.controls.clone(),
        clip: order.iter().map(|&i| source(i).0).collect(),
        frame: order.iter().map(|&i| source(i).1).collect(),
        time: order.iter().map(|&i| source(i).1 as f64 / frames.fps).collect(),
        values: gather(&y, c, &order),
    };
    let moves = |j: usize| y.chunks_exact(c).any(|p| p[j] != y[j]);
    let free_controls: Vec<String> = (0..c).filter(|&j| moves(j)).map(|j| frames.controls[j].clone()).collect();
    let mut held_out_clips: Vec<String> = frames.clip_runs().into_iter().map(|(clip, _, _)| clip).collect();
    held_out_clips.retain(|clip| held_out.as_ref().is_some_and(|m| m.is_match(clip)));
    held_out_clips.dedup();
    let mapping = Mapping {
        points: points.iter().map(|&p| p as i64).collect(),
        theta0: cv.theta0,
        theta1: args.theta1,
        free_controls: free_controls.clone(),
        cross_validation: cv.errors.clone(),
        training_frames: n,
        held_out_clips,
    };
    Invrig { samples, mapping }.write(&args.io.invrig, &provenance)?;
    let best = cv.errors.iter().find(|e| e.0 == cv.theta0).map_or(f64::NAN, |e| e.1);
    Ok(Some(Summary {
        training: n,
        samples: taken.len(),
        points: points.len(),
        free: (free_controls.len(), c),
        theta0: (cv.theta0, best),
        seconds: (cv_seconds, subsample_seconds),
    }))
}

/// The rig's index of the control `name` (the layout of `open_rig` guarantees it is one).
fn rig_index(rig: &dyn reprise_rig::Rig, name: &str) -> usize {
    rig.control_names().iter().position(|n| n == name).expect("open_rig checked every table control is the rig's")
}
