//! The bridges stage (Bailey et al. 2016 §5.2): for every ordered pair of label models
//! M1 → M2 and every `stride`-th training latent $x_1$ of M1, reconstruct its pose
//! $p = g_1(x_1)$, project it into M2's scaled PCA space ($\hat y = Pp + o$, Eq. 13), and
//! find the M2 latent point $x_2 = \arg\min_x\lVert\hat y - y_2(x)\rVert^2$ (Eq. 15) by
//! multi-start SCG from M2's training latents whose outputs are nearest $\hat y$ plus
//! random starts, bounded to M2's latent bounding box widened by `latent_margin` of its
//! extent on each side (far from its latents M2's mean reverts to the output mean, which
//! "matches" any pose near it at a point the model knows nothing of; candidates pressed
//! against the bound are counted). The candidates' distance is measured in M2's scaled control space,
//! $\lVert W_2(p - g_2(x_2))\rVert$ (mesh length), and, through the rig, as the RMS vertex
//! distance of the two poses. A pair keeps its candidates under a threshold, then at most
//! `max_per_pair` of them, spread over M1's latent space. The default threshold,
//! `mesh-motion`, is absolute and comes from the data: a bridge's two poses may differ by
//! at most `motion_multiple` (default 8) times the `motion_quantile` (default 0.99) of the
//! two labels' per-frame mesh motion — the RMS vertex distance between consecutive frames
//! of a segment, over both labels' segments (per pair, so that a pair's bridges depend on
//! its two labels only and the runner can cache each pair). With the defaults the 12-frame
//! smoothstep blend, whose steepest frame carries 1.5/12 of the gap, moves the mesh by at
//! most one 99th-percentile training frame step per frame: no faster than the labels
//! themselves ever move. Of the candidates under it, the pair keeps the nearest by mesh
//! distance whose $x_1$ is farther than `spread` median M1 training steps from every
//! $x_1$ already kept, up to `max_per_pair` (default 50, the top of the paper's 10–50), so
//! that TRANSITION finds a good bridge near wherever the particle is rather than fifty
//! neighbours of one pose. Two labels with no pose that close get no direct bridge (the
//! engine then routes through a third label where one bridges both, or fails). The
//! alternatives: a quantile of the pair's own rig distances (every pair keeps at least one
//! bridge), or an absolute rig or mesh distance.

use clap::{Parser, ValueEnum};
use rayon::prelude::*;
use reprise_artifact::bridges::{self, Bridge};
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_label_models::Models;
use reprise_numerics::gplvm::{best_latent, LatentModel, ProjectOptions};
use reprise_numerics::scg::ScgOptions;
use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

/// How a pair's candidates are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Threshold {
    /// The `--quantile` best of the pair's rig distances.
    Quantile,
    /// Rig distance at most `--max-distance`.
    Rig,
    /// Mesh distance at most `--max-distance` (needs a rig).
    Mesh,
    /// Mesh distance at most `--motion-multiple` × the `--motion-quantile` of the training
    /// frames' per-frame mesh motion (needs a rig and the labeled frames).
    MeshMotion,
}

reprise_stagekit::stage_io! {
    stage: "bridges", bin: "reprise-bridges",
    partition: LabelPair { by: "gplvm_models" },
    derived: [],
    inputs {
        /// Input: the GPLVM models.
        gplvm_models: required "gplvm_models.parquet",
        /// Input: the PCA models.
        pca_models: required "pca_models.parquet",
        /// Input: the scales.
        scales: required "scales.parquet",
        /// Input: the controls table (names the rig, for mesh distances).
        controls: optional "controls.parquet",
        /// Input (for `--threshold mesh-motion`): the labeled frames, whose per-frame mesh
        /// motion sets the threshold.
        labeled_frames: optional "labeled_frames.parquet",
    }
    outputs {
        /// Output: the bridges.
        bridges: artifact "bridges.parquet",
    }
}

/// `reprise-bridges`: matching latent points between every ordered pair of label models.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-bridges", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Try every k-th training point of M1.
    #[arg(long, default_value_t = 1)]
    pub stride: usize,
    /// Starts at M2's training latents nearest the target.
    #[arg(long, default_value_t = 2)]
    pub nearest_starts: usize,
    /// Plus this many random starts in M2's latent bounding box.
    #[arg(long, default_value_t = 1)]
    pub random_starts: usize,
    /// SCG iterations per start ("small steps").
    #[arg(long, default_value_t = 40)]
    pub max_iters: usize,
    /// Where x₂ may land: the search is bounded to M2's latent bounding box widened by
    /// this share of its extent on each side (0.25: a box 1.5 × the extent). Far from its
    /// latents M2's mean is only the output mean, not a pose the model knows. Candidates
    /// whose x₂ presses against the bound are counted.
    #[arg(long, default_value_t = 0.25)]
    pub latent_margin: f64,
    /// Which threshold keeps a candidate.
    #[arg(long, value_enum, default_value_t = Threshold::MeshMotion)]
    pub threshold: Threshold,
    /// With `quantile`: the share of each pair's candidates kept (at least one).
    #[arg(long, default_value_t = 0.02)]
    pub quantile: f64,
    /// With `rig` or `mesh`: the largest distance kept.
    #[arg(long)]
    pub max_distance: Option<f64>,
    /// With `mesh-motion`: the largest mesh distance kept, in units of the training data's
    /// per-frame mesh motion at `--motion-quantile` (8 = a 12-frame blend's steepest frame,
    /// 1.5/12 of the gap, carries one such step).
    #[arg(long, default_value_t = 8.0)]
    pub motion_multiple: f64,
    /// With `mesh-motion`: which quantile of the per-frame mesh motion is the unit.
    #[arg(long, default_value_t = 0.99)]
    pub motion_quantile: f64,
    /// The most bridges a pair keeps (0: no limit).
    #[arg(long, default_value_t = 50)]
    pub max_per_pair: usize,
    /// A kept bridge's x₁ is farther than this many median M1 training steps (latent
    /// distance between consecutive training latents) from every other kept x₁ (0: no
    /// spacing).
    #[arg(long, default_value_t = 2.0)]
    pub spread: f64,
    /// With `mesh-motion`: the threshold is at least this share of the character's size
    /// (the bounding-box diagonal of M1's first training pose's mesh), so that labels that
    /// barely move, whose motion gives a threshold near zero, can still be bridged where
    /// their poses are close.
    #[arg(long, default_value_t = 0.01)]
    pub size_floor: f64,
    /// Seed of the random starts (each pair's seed mixes in its two labels' names).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// The most starts of each kind per candidate (each is an SCG run).
pub const MAX_STARTS: usize = 1000;
/// The most SCG iterations per start.
pub const MAX_ITERS: usize = 100_000;

impl Args {
    fn validate(&self) -> StageResult<()> {
        let cfg = |m: &str| Err(StageError::Config(m.into()));
        if self.stride == 0 || self.max_iters == 0 || self.nearest_starts.saturating_add(self.random_starts) == 0 {
            return cfg("--stride and --max-iters must be at least 1, and there must be at least one start");
        }
        if !(self.latent_margin.is_finite() && self.latent_margin >= 0.0) {
            return cfg("--latent-margin must be a finite number >= 0");
        }
        if !(self.spread.is_finite() && self.spread >= 0.0) {
            return cfg("--spread must be a finite number >= 0");
        }
        if self.nearest_starts > MAX_STARTS || self.random_starts > MAX_STARTS || self.max_iters > MAX_ITERS {
            return Err(StageError::Config(format!(
                "--nearest-starts and --random-starts may be at most {MAX_STARTS}, --max-iters at most {MAX_ITERS}"
            )));
        }
        match self.threshold {
            Threshold::Quantile if !(self.quantile > 0.0 && self.quantile <= 1.0) => {
                cfg("--quantile must be in (0, 1]")
            }
            Threshold::Rig | Threshold::Mesh if !self.max_distance.is_some_and(|d| d.is_finite() && d >= 0.0) => {
                cfg("--threshold rig|mesh needs --max-distance >= 0")
            }
            Threshold::Mesh if self.io.controls.is_none() => cfg("--threshold mesh needs --controls (the rig)"),
            Threshold::MeshMotion if self.io.controls.is_none() || self.io.labeled_frames.is_none() => {
                cfg("--threshold mesh-motion needs --controls (the rig) and --labeled-frames")
            }
            Threshold::MeshMotion
                if !(self.motion_multiple.is_finite()
                    && self.size_floor.is_finite()
                    && self.size_floor >= 0.0
                    && self.motion_multiple >= 0.0
                    && (0.0..=1.0).contains(&self.motion_quantile)) =>
            {
                cfg("--motion-multiple and --size-floor must be >= 0 and --motion-quantile in [0, 1]")
            }
            _ => Ok(()),
        }
    }
}

/// Per ordered pair: candidates tried and bridges kept.
#[derive(Debug, Clone, PartialEq)]
pub struct PairCount {
    /// M1.
    pub from: String,
    /// M2.
    pub to: String,
    /// Candidates tried.
    pub candidates: usize,
    /// Candidates under the threshold.
    pub under: usize,
    /// Bridges kept.
    pub kept: usize,
    /// The kept bridges' smallest rig distance.
    pub best: f64,
    /// With `mesh-motion`: the two labels' per-frame mesh motion at `motion_quantile`.
    pub frame_motion: Option<f64>,
    /// With a mesh threshold: the largest mesh distance kept.
    pub max_mesh: Option<f64>,
    /// Candidates whose x₂ presses against M2's bound (`--latent-margin`): the search
    /// wanted to go farther from M2's latents. They are kept only if they pass the
    /// threshold like any other.
    pub at_bound: usize,
}

/// The `q`-quantile over all segments' consecutive frame pairs of the RMS vertex distance
/// between their meshes (mesh units per frame, the nearest order statistic).
pub fn frame_motion(
    rig: &(Box<dyn reprise_rig::Rig>, reprise_rig::PoseLayout),
    lf: &LabeledFrames,
    q: f64,
) -> StageResult<f64> {
    let steps: Vec<f64> = frame_steps(rig, lf, |_| true)?.into_values().flatten().collect();
    quantile(steps, q)
}

/// The nearest order statistic of `steps` at `q`; an input error when there are none.
fn quantile(mut steps: Vec<f64>, q: f64) -> StageResult<f64> {
    if steps.is_empty() {
        return Err(StageError::Input("the labeled frames have no two consecutive frames in a segment".into()));
    }
    steps.sort_by(f64::total_cmp);
    Ok(steps[((steps.len() - 1) as f64 * q).round() as usize])
}

/// Per label (of those `wanted`), the RMS vertex distance between the meshes of each two
/// consecutive frames of a segment (mesh units per frame); evaluated 128 frames at a time.
fn frame_steps(
    rig: &(Box<dyn reprise_rig::Rig>, reprise_rig::PoseLayout),
    lf: &LabeledFrames,
    wanted: impl Fn(&str) -> bool,
) -> StageResult<std::collections::BTreeMap<String, Vec<f64>>> {
    const CHUNK: usize = 128;
    let mut by_label: std::collections::BTreeMap<String, Vec<f64>> = std::collections::BTreeMap::new();
    for (start, end) in lf.segment_runs() {
        if !wanted(&lf.label[start]) {
            continue;
        }
        let steps = by_label.entry(lf.label[start].clone()).or_default();
        let mut prev: Option<Vec<f64>> = None;
        let mut at = start;
        while at < end {
            let to = (at + CHUNK).min(end);
            let rows: Vec<Vec<f64>> = (at..to).map(|r| lf.frames.row(r).to_vec()).collect();
            let m = meshes(rig, &rows)?;
            let dim = m.len() / rows.len();
            if dim == 0 {
                return Err(StageError::Input(
                    "the rig has no vertices: per-frame mesh motion (--threshold mesh-motion) needs a mesh".into(),
                ));
            }
            for mesh in m.chunks_exact(dim) {
                if let Some(p) = &prev {
                    steps.push(mesh_rmse(p, mesh));
                }
                prev = Some(mesh.to_vec());
            }
            at = to;
        }
    }
    Ok(by_label)
}

/// The seed of pair `from → to`: `seed` mixed with both labels' names, so a pair draws the
/// same starts whatever other labels there are.
fn pair_seed(seed: u64, from: &str, to: &str) -> u64 {
    let mut h = blake3::Hasher::new();
    h.update(from.as_bytes()).update(&[0]).update(to.as_bytes());
    let bytes: [u8; 8] = h.finalize().as_bytes()[..8].try_into().expect("a blake3 hash has 32 bytes");
    seed ^ u64::from_le_bytes(bytes)
}

/// What the stage found.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Per ordered pair.
    pub counts: Vec<PairCount>,
    /// How many label models there are.
    pub labels: usize,
}

/// The stage's summary: one line per ordered pair (candidates, those under the threshold,
/// bridges kept, the best rig distance, the pair's per-frame mesh motion and the largest
/// mesh distance kept), then how many pairs have no direct bridge.
impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{:<12} {:<12} {:>10} {:>8} {:>5} {:>5} {:>12} {:>12} {:>12}",
            "from", "to", "candidates", "at bound", "under", "kept", "best rig dist", "frame motion", "max mesh"
        )?;
        let or_dash = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.4}"));
        for c in &self.counts {
            writeln!(
                f,
                "{:<12} {:<12} {:>10} {:>8} {:>5} {:>5} {:>12.4} {:>12} {:>12}",
                c.from,
                c.to,
                c.candidates,
                c.at_bound,
                c.under,
                c.kept,
                c.best,
                or_dash(c.frame_motion),
                or_dash(c.max_mesh)
            )?;
        }
        let none = self.counts.iter().filter(|c| c.kept == 0).count();
        if none > 0 {
            let then = if self.labels > 2 {
                "synthesis routes through a third label where one bridges both"
            } else {
                "with two labels there is no third to route through: those transitions fail"
            };
            writeln!(f, "{none} of {} ordered pairs have no direct bridge ({then})", self.counts.len())?;
        }
        let at_bound: usize = self.counts.iter().map(|c| c.at_bound).sum();
        if at_bound > 0 {
            writeln!(
                f,
                "{at_bound} candidate(s) found x2 only at the edge of the target model's latent box (--latent-margin); \
                 kept where the threshold allows"
            )?;
        }
        Ok(())
    }
}

/// One candidate of a pair.
struct Candidate {
    point: usize,
    x1: Vec<f64>,
    x2: Vec<f64>,
    p1: Vec<f64>,
    p2: Vec<f64>,
    rig: f64,
}

/// The pair's candidates (one per `stride`-th training point of M1), and how many of their
/// x₂ press against M2's bound.
fn candidates(m1: &LatentModel, m2: &LatentModel, train2: &[f64], args: &Args, seed: u64) -> (Vec<Candidate>, usize) {
    let (q1, d2) = (m1.q(), m2.d());
    let opts = ProjectOptions {
        nearest: args.nearest_starts,
        random: args.random_starts,
        seed,
        scg: ScgOptions { max_iters: args.max_iters, xtol: 1e-6, ftol: 1e-10, ..Default::default() },
        margin: Some(args.latent_margin),
    };
    let (mut y1, mut y2) = (vec![0.0; m1.d()], vec![0.0; d2]);
    let mut at_bound = 0;
    let found: Vec<Candidate> = (0..m1.frames())
        .step_by(args.stride)
        .map(|i| {
            let x1 = m1.latents()[i * q1..(i + 1) * q1].to_vec();
            let mut p1 = vec![0.0; m1.controls()];
            m1.controls_into(&x1, &mut y1, &mut p1);
            m2.map.project(&p1, &mut y2);
            y2.iter_mut().zip(&m2.offset).for_each(|(y, o)| *y -= o);
            let found = best_latent(&m2.predictor, &y2, m2.latents(), train2, &opts);
            at_bound += usize::from(found.at_bound);
            let mut p2 = vec![0.0; m2.controls()];
            m2.controls_into(&found.x, &mut vec![0.0; d2], &mut p2);
            let rig = m2.map.scaled_distance(&p1, &p2);
            Candidate { point: i, x1, x2: found.x, p1, p2, rig }
        })
        .collect();
    (found, at_bound)
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Outcome>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    // The models must have been fit on these labeled frames and controls (the PCA and
    // scales are checked by `reprise_label_models::load`).
    reprise_artifact::provenance::check_made_from(&args.io.gplvm_models, &provenance)?;
    let Models { controls, models } =
        reprise_label_models::load(&args.io.gplvm_models, &args.io.pca_models, &args.io.scales)?;
    if models.len() < 2 {
        return Err(StageError::Input(format!(
            "{}: {} label model(s); bridges need at least two",
            args.io.gplvm_models.display(),
            models.len()
        )));
    }
    let rig = args
        .io
        .controls
        .as_ref()
        .map(|c| reprise_stagekit::rig::open_rig(&Controls::read(c)?, &controls))
        .transpose()?;
    let pairs = pairs_to_run(&models, args)?;
    let used = |i: usize| pairs.iter().any(|&(a, b)| a == i || b == i);
    let steps = match (args.threshold, &args.io.labeled_frames, rig.as_ref()) {
        (Threshold::MeshMotion, Some(path), Some(r)) => {
            let lf = LabeledFrames::read(path)?;
            if lf.frames.controls != controls {
                return Err(StageError::Input(format!(
                    "{} has other controls than the models of {}; rerun the stages after label",
                    path.display(),
                    args.io.gplvm_models.display()
                )));
            }
            let labels: Vec<&str> = (0..models.len()).filter(|&i| used(i)).map(|i| models[i].label.as_str()).collect();
            Some(frame_steps(r, &lf, |l| labels.contains(&l))?)
        }
        _ => None,
    };
    // A pair's threshold: (the per-frame motion it is a multiple of, the largest mesh distance).
    let pair_max = |from: &str, to: &str| -> StageResult<Option<(f64, f64)>> {
        match (args.threshold, &steps) {
            (Threshold::MeshMotion, Some(steps)) => {
                let both = [from, to].iter().flat_map(|l| steps.get(*l).into_iter().flatten().copied()).collect();
                let motion = quantile(both, args.motion_quantile)?;
                Ok(Some((motion, args.motion_multiple * motion)))
            }
            (Threshold::Mesh, _) => Ok(args.max_distance.map(|d| (f64::NAN, d))),
            _ => Ok(None),
        }
    };
    let train: Vec<Option<Vec<f64>>> =
        models.par_iter().enumerate().map(|(i, m)| used(i).then(|| m.training_means())).collect();
    let bar = reprise_stagekit::progress(pairs.len() as u64, "bridges");
    let per_pair: Vec<StageResult<(Vec<Bridge>, PairCount)>> = pairs
        .par_iter()
        .map(|&(a, b)| {
            let (m1, m2) = (&models[a], &models[b]);
            let mesh_max = pair_max(&m1.label, &m2.label)?;
            let train2 = train[b].as_deref().unwrap_or_default();
            let (mut cands, at_bound) = candidates(m1, m2, train2, args, pair_seed(args.seed, &m1.label, &m2.label));
            cands.sort_by(|x, y| x.rig.total_cmp(&y.rig));
            let tried = cands.len();
            let mesh_of = |c: &[Candidate]| -> StageResult<Option<Vec<f64>>> {
                let Some(r) = rig.as_ref() else { return Ok(None) };
                let (e1, e2) = (
                    meshes(r, &c.iter().map(|c| c.p1.clone()).collect::<Vec<_>>())?,
                    meshes(r, &c.iter().map(|c| c.p2.clone()).collect::<Vec<_>>())?,
                );
                let m = e1.len() / c.len().max(1);
                Ok(Some((0..c.len()).map(|i| mesh_rmse(&e1[i * m..(i + 1) * m], &e2[i * m..(i + 1) * m])).collect()))
            };
            // The size floor of a mesh-motion threshold: a share of the character's size.
            let mesh_max = match (args.threshold, mesh_max, rig.as_ref(), cands.iter().min_by_key(|c| c.point)) {
                (Threshold::MeshMotion, Some((motion, max)), Some(r), Some(first)) => {
                    let size = bbox_diagonal(&meshes(r, std::slice::from_ref(&first.p1))?);
                    Some((motion, max.max(args.size_floor * size)))
                }
                (_, m, ..) => m,
            };
            let (kept, mesh): (Vec<Candidate>, Option<Vec<f64>>) = match args.threshold {
                Threshold::Quantile => {
                    let k = ((args.quantile * tried as f64).round() as usize).clamp(1, tried.max(1)).min(tried);
                    cands.truncate(k);
                    let mesh = mesh_of(&cands)?;
                    (cands, mesh)
                }
                Threshold::Rig => {
                    let max = args.max_distance.unwrap_or(f64::INFINITY);
                    cands.retain(|c| c.rig <= max);
                    let mesh = mesh_of(&cands)?;
                    (cands, mesh)
                }
                Threshold::Mesh | Threshold::MeshMotion => {
                    let max = mesh_max.map_or(f64::INFINITY, |m| m.1);
                    let mesh = mesh_of(&cands)?.unwrap_or_default();
                    let mut both: Vec<(Candidate, f64)> =
                        cands.into_iter().zip(mesh).filter(|(_, m)| *m <= max).collect();
                    both.sort_by(|x, y| x.1.total_cmp(&y.1));
                    let (c, m): (Vec<_>, Vec<_>) = both.into_iter().unzip();
                    (c, Some(m))
                }
            };
            let radius = args.spread * median_step(m1);
            let chosen = spread(kept.iter().map(|c| c.x1.as_slice()), radius, args.max_per_pair);
            let mesh = mesh.map(|m| chosen.iter().map(|&i| m[i]).collect::<Vec<f64>>());
            let under = kept.len();
            let kept: Vec<Candidate> =
                kept.into_iter().enumerate().filter(|(i, _)| chosen.binary_search(i).is_ok()).map(|(_, c)| c).collect();
            bar.inc(1);
            let count = PairCount {
                from: m1.label.clone(),
                to: m2.label.clone(),
                candidates: tried,
                under,
                kept: kept.len(),
                best: kept.iter().map(|c| c.rig).fold(f64::INFINITY, f64::min),
                frame_motion: mesh_max.map(|m| m.0).filter(|m| m.is_finite()),
                max_mesh: mesh_max.map(|m| m.1),
                at_bound,
            };
            let rows = kept
                .into_iter()
                .enumerate()
                .map(|(r, c)| Bridge {
                    from: m1.label.clone(),
                    to: m2.label.clone(),
                    from_point: c.point as i64,
                    x1: c.x1,
                    x2: c.x2,
                    rig_distance: c.rig,
                    mesh_distance: mesh.as_ref().map(|m| m[r]),
                    rank: r as i64 + 1,
                })
                .collect();
            Ok((rows, count))
        })
        .collect();
    bar.finish_and_clear();
    let mut all = Vec::new();
    let mut counts = Vec::new();
    for r in per_pair {
        let (rows, count) = r?;
        all.extend(rows);
        counts.push(count);
    }
    bridges::write(&args.io.bridges, &all, models[0].q(), &provenance)?;
    Ok(Some(Outcome { counts, labels: models.len() }))
}

/// Which of `x1s` (in order of preference) a pair keeps: each in turn unless it lies within
/// `radius` of one already kept, until `max` are kept (0: no limit). Indices ascending.
fn spread<'a>(x1s: impl Iterator<Item = &'a [f64]>, radius: f64, max: usize) -> Vec<usize> {
    let mut kept: Vec<(usize, &[f64])> = Vec::new();
    for (i, x) in x1s.enumerate() {
        if max > 0 && kept.len() >= max {
            break;
        }
        if kept.iter().all(|(_, k)| reprise_numerics::vector::dist(k, x) > radius) {
            kept.push((i, x));
        }
    }
    let mut idx: Vec<usize> = kept.into_iter().map(|(i, _)| i).collect();
    idx.sort_unstable();
    idx
}

/// The median latent distance between consecutive training latents of `m` (0 with fewer
/// than two).
fn median_step(m: &LatentModel) -> f64 {
    let q = m.q();
    let mut steps: Vec<f64> = m
        .latents()
        .chunks_exact(q)
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| reprise_numerics::vector::dist(w[0], w[1]))
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    steps.sort_by(f64::total_cmp);
    steps[steps.len() / 2]
}

/// The diagonal of the bounding box of `mesh` (`x y z …`, mesh units); 0 for none.
fn bbox_diagonal(mesh: &[f64]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for v in mesh.chunks_exact(3) {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    if lo[0] > hi[0] {
        return 0.0;
    }
    (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt()
}

/// The ordered pairs `(from, to)` of model indices to search: every pair, or the one
/// `--partition` and `--partition-to` name.
fn pairs_to_run(models: &[LatentModel], args: &Args) -> StageResult<Vec<(usize, usize)>> {
    let all = (0..models.len()).flat_map(|a| (0..models.len()).filter(move |&b| b != a).map(move |b| (a, b)));
    let (Some(from), Some(to)) = (&args.io.partition, &args.io.partition_to) else { return Ok(all.collect()) };
    let find = |label: &str| {
        models.iter().position(|m| m.label == label).ok_or_else(|| {
            StageError::Input(format!(
                "{}: no label `{label}` for --partition (labels: {})",
                args.io.gplvm_models.display(),
                models.iter().map(|m| m.label.as_str()).collect::<Vec<_>>().join(", ")
            ))
        })
    };
    let (a, b) = (find(from)?, find(to)?);
    if a == b {
        return Err(StageError::Config(format!("--partition and --partition-to are both `{from}`: a pair needs two")));
    }
    Ok(vec![(a, b)])
}

#[cfg(test)]
mod tests {
    /// The summary has a header, a line per pair (a dash where a measure does not apply)
    /// and counts the pairs without a bridge.
    #[test]
    fn the_summary_lists_every_pair() {
        let pair = |to: &str, kept| super::PairCount {
            from: "a".into(),
            to: to.into(),
            candidates: 10,
            under: 2 * kept,
            kept,
            best: 0.5,
            frame_motion: Some(0.25),
            max_mesh: None,
            at_bound: if kept == 0 { 4 } else { 0 },
        };
        let text = super::Outcome { counts: vec![pair("b", 3), pair("c", 0)], labels: 3 }.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 5, "{text}");
        assert!(lines[1].contains("     6     3 "), "under the threshold, then kept: {text}");
        assert!(lines[0].starts_with("from") && lines[1].starts_with("a            b"), "{text}");
        assert!(lines[1].contains("0.5000") && lines[1].contains("0.2500") && lines[1].trim_end().ends_with('-'));
        assert!(lines[0].contains("at bound") && lines[2].contains("10        4     0     0"), "{text}");
        assert_eq!(
            lines[3],
            "1 of 2 ordered pairs have no direct bridge (synthesis routes through a third label where one bridges both)"
        );
        assert!(lines[4].starts_with("4 candidate(s) found x2 only at the edge"), "{text}");
        // Two labels: no third to route through, and the summary says so.
        let two = super::Outcome { counts: vec![pair("b", 0)], labels: 2 }.to_string();
        assert!(two.contains("(with two labels there is no third to route through: those transitions fail)"), "{two}");
    }

    use super::*;
    use reprise_artifact::frames::Frames;
    use reprise_rig::local::{Local, PoseEvaluator};

    /// One control moving two vertices: the first by (c, 0, 0), the second by (0, 2c, 0).
    struct Line;
    impl PoseEvaluator for Line {
        fn describe(&self) -> String {
            "line".into()
        }
        fn control_names(&self) -> Vec<String> {
            vec!["c".into()]
        }
        fn rest_pose(&self) -> Vec<f64> {
            vec![0.0]
        }
        fn vertex_count(&self) -> usize {
            2
        }
        fn triangles(&self) -> &[[u32; 3]] {
            &[]
        }
        fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
            out.copy_from_slice(&[pose[0], 0.0, 0.0, 0.0, 2.0 * pose[0], 0.0]);
        }
    }

    /// The size floor's measure: the bounding box's diagonal (3-4-12 → 13).
    #[test]
    fn bbox_diagonal_is_known() {
        assert_eq!(super::bbox_diagonal(&[0.0, 0.0, 0.0, 3.0, 4.0, 0.0, 1.0, 1.0, 12.0]), 13.0);
        assert_eq!(super::bbox_diagonal(&[]), 0.0);
    }

    /// The threshold's data: quantiles of the per-frame RMS vertex motion, within segments
    /// only (the jump between two segments is not motion).
    #[test]
    fn frame_motion_is_known() {
        // Segment 0 steps by 1, 1, 3 (c = 0, 1, 2, 5); segment 1 by 2, 2 (c = 100, 102, 104).
        let c = [0.0, 1.0, 2.0, 5.0, 100.0, 102.0, 104.0];
        let lf = LabeledFrames {
            segment_id: vec![0, 0, 0, 0, 1, 1, 1],
            label: vec!["a".into(); 7],
            frames: Frames {
                fps: 24.0,
                controls: vec!["c".into()],
                clip: vec!["x".into(); 7],
                frame: (0..7).collect(),
                time: (0..7).map(|f| f as f64 / 24.0).collect(),
                values: c.to_vec(),
            },
            masked_controls: vec![],
        };
        let rig: Box<dyn reprise_rig::Rig> = Box::new(Local::new(Line));
        let layout = reprise_rig::PoseLayout::new(&["c".into()], vec![0.0], &["c".into()]).unwrap();
        // A step of s moves the vertices by s and 2s: RMS √((s² + 4s²)/2) = s·√2.5.
        let rig = (rig, layout);
        let m = frame_motion(&rig, &lf, 0.5).unwrap();
        assert!((m - 2.0 * 2.5f64.sqrt()).abs() < 1e-12, "{m}");
        assert!((frame_motion(&rig, &lf, 1.0).unwrap() - 3.0 * 2.5f64.sqrt()).abs() < 1e-12);
        assert!((frame_motion(&rig, &lf, 0.0).unwrap() - 2.5f64.sqrt()).abs() < 1e-12);
        // Per label: segment 1 relabelled `b` keeps its own steps.
        let mut lf = lf;
        lf.label[4..].iter_mut().for_each(|l| *l = "b".into());
        let steps = frame_steps(&rig, &lf, |_| true).unwrap();
        let unit = 2.5f64.sqrt();
        assert_eq!(steps["a"].len(), 3);
        assert!(steps["b"].iter().all(|s| (s - 2.0 * unit).abs() < 1e-12), "{steps:?}");
        assert!(frame_steps(&rig, &lf, |l| l == "b").unwrap().keys().eq(["b"]));
    }

    /// Candidates in order of preference on a line: each within the radius of one kept
    /// is skipped, and no more than `max` are kept.
    #[test]
    fn spread_keeps_the_best_apart() {
        let xs: Vec<Vec<f64>> = [0.0, 0.5, 3.0, 1.5, 0.9, 6.0].iter().map(|&v| vec![v, 0.0]).collect();
        let it = || xs.iter().map(|x| x.as_slice());
        assert_eq!(spread(it(), 1.0, 0), vec![0, 2, 3, 5]);
        assert_eq!(spread(it(), 1.0, 2), vec![0, 2]);
        assert_eq!(spread(it(), 0.0, 0), vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(spread(it(), 10.0, 0), vec![0]);
    }

    /// A pair's seed depends on its two labels, in order, and on the stage's seed only.
    #[test]
    fn pair_seeds_follow_the_labels() {
        assert_eq!(pair_seed(0, "a", "b"), pair_seed(0, "a", "b"));
        assert_ne!(pair_seed(0, "a", "b"), pair_seed(0, "b", "a"));
        assert_ne!(pair_seed(0, "ab", "c"), pair_seed(0, "a", "bc"));
        assert_ne!(pair_seed(0, "a", "b"), pair_seed(1, "a", "b"));
    }
}
