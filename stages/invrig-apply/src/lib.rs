//! The invrig-apply stage: positions → rig-control curves through a fitted inverse rig
//! mapping (Holden et al. 2017), written as a `frames` table so that label, scale, pca,
//! gplvm and the rest run on it as on the animator's curves.
//!
//! `--method` makes the curves written; every method of `--compare` is measured on the
//! same frames by the same code ([`measure`]) for the report's table (the paper's Table 1):
//! the nearest training pose, the regression, the regression refined on the learned
//! Jacobian, on the computed (finite-difference) Jacobian, and the computed-Jacobian
//! refinement from the rest pose. Where the curves are known (`--frames` holds the clip)
//! the ground-truth error is measured too, and `--carry-clips` copies that table's other
//! clips into the output, so a corpus whose some takes exist only as positions becomes
//! one frames table.
//!
//! A pose the rig cannot reach is never returned as if reached: every frame's residual
//! (its joint error) is in `invrig_errors`, and the report counts the frames whose
//! refinement stopped without progress.

pub mod report;

use std::collections::BTreeMap;
use std::time::Instant;

use clap::Parser;
use rayon::prelude::*;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::Frames;
use reprise_artifact::invrig::{write_errors, FrameError, Invrig};
use reprise_artifact::positions::{point_mismatch, Positions};
use reprise_invrig::mapping::{InverseMap, Method, Training};
use reprise_invrig::refine::{RefineSettings, Stop};
use reprise_invrig::InvrigError;
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "invrig-apply", bin: "reprise-invrig-apply",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the fitted mapping.
        invrig: required "invrig.parquet",
        /// Input: the positions to map.
        positions: required "positions.parquet",
        /// Input: the controls table (names the rig).
        controls: required "controls.parquet",
        /// Input (optional): known curves: the ground truth of the clips the positions
        /// hold, and the clips `--carry-clips` copies.
        frames: optional "frames.parquet",
    }
    outputs {
        /// Output: the curves found, a frame table.
        recovered: artifact "invrig_frames.parquet",
        /// Output: per method and frame, the errors and costs.
        errors: artifact "invrig_errors.parquet",
        /// Output: the Markdown report (the paper's Table 1 on these positions).
        report: report "invrig.md",
    }
}

/// `reprise-invrig-apply`: positions to curves.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-invrig-apply", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// The method whose curves are written: nearest, gpr, gpr-learned-jacobian,
    /// gpr-computed-jacobian, gpr-broyden-jacobian or rest-computed-jacobian.
    #[arg(long, default_value = "gpr-computed-jacobian")]
    pub method: String,
    /// Methods measured beside it for the report (comma-separated; `all`, or `none`).
    #[arg(long, value_delimiter = ',', default_value = "all")]
    pub compare: Vec<String>,
    /// The damping λ of Eq. 13, in length unit per control unit (tuned on dragon-face: cm
    /// per control unit there).
    #[arg(long, default_value_t = 0.1)]
    pub lambda: f64,
    /// Refinement steps at most per frame.
    #[arg(long, default_value_t = 10)]
    pub iterations: usize,
    /// A refinement stops once the root-mean-square point distance is at most this (length unit).
    #[arg(long, default_value_t = 1e-4)]
    pub tolerance: f64,
    /// Finite-difference step h of the Jacobian, in control units.
    #[arg(long, default_value_t = 1e-4)]
    pub step: f64,
    /// Limit: MiB the learned Jacobian may take (2 · 3 · points · free controls values per
    /// training pose); it is learned from as many training poses as fit, spread by farthest
    /// points, and the report says how many.
    #[arg(long, default_value_t = 1024)]
    pub max_jacobian_mib: usize,
    /// Copy `--frames`' clips that the positions do not hold into the curves written.
    #[arg(long, default_value_t = false, action = clap::ArgAction::Set)]
    pub carry_clips: bool,
    /// Frame rate of positions without `reprise.fps` metadata.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Limit: frames of positions read.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_frames: usize,
}

/// The methods: the one written first, then the others of `--compare`, in the paper's order.
///
/// # Errors
/// [`StageError::Config`] naming an unknown method.
pub fn methods(args: &Args) -> StageResult<Vec<Method>> {
    let parse = |name: &str| {
        Method::parse(name).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            StageError::Config(format!("unknown method `{name}`; one of {}", names.join(", ")))
        })
    };
    let main = parse(&args.method)?;
    let mut out = vec![main];
    for name in &args.compare {
        match name.as_str() {
            "all" => out.extend(Method::ALL),
            "none" => {}
            other => out.push(parse(other)?),
        }
    }
    let mut seen = Vec::new();
    out.retain(|m| {
        !seen.contains(m) && {
            seen.push(*m);
            true
        }
    });
    out[1..].sort_by_key(|m| Method::ALL.iter().position(|a| a == m));
    Ok(out)
}

impl Args {
    fn validate(&self) -> StageResult<Vec<Method>> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !(positive(self.lambda) && positive(self.step) && self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(StageError::Config("--lambda and --step must be finite and positive, --tolerance >= 0".into()));
        }
        if self.fps.is_some_and(|f| !positive(f)) {
            return Err(StageError::Config("--fps must be finite and positive".into()));
        }
        methods(self)
    }
}

/// The rig as inverse rig mapping sees it: table controls in, the chosen points out.
pub struct PointRig<'a> {
    rig: &'a dyn Rig,
    layout: &'a PoseLayout,
    points: &'a [usize],
}

impl<'a> PointRig<'a> {
    /// The rig `rig` read through `layout`, keeping `points`.
    pub fn new(rig: &'a dyn Rig, layout: &'a PoseLayout, points: &'a [usize]) -> Self {
        Self { rig, layout, points }
    }
}

impl reprise_invrig::refine::Rig for PointRig<'_> {
    fn controls(&self) -> usize {
        self.layout.table_len()
    }
    fn positions(&self) -> usize {
        3 * self.points.len()
    }
    fn evaluate(&mut self, poses: &[f64], count: usize) -> reprise_invrig::Result<Vec<f64>> {
        let full = self.layout.full_batch(&poses[..count * self.layout.table_len()]);
        let v = self.rig.vertex_count();
        let mut meshes = vec![0.0; count * 3 * v];
        self.rig.evaluate_batch(&full, &mut meshes).map_err(|e| InvrigError::Rig(e.to_string()))?;
        Ok(reprise_invrig::points::select(&meshes, v, self.points))
    }
}

/// One method's run over the frames, for the report.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodRun {
    /// The method.
    pub method: Method,
    /// Seconds of set-up before the first frame (the learned Jacobian's fit).
    pub setup_seconds: f64,
    /// Training poses the learned Jacobian was learned from (0 for other methods).
    pub jacobian_poses: usize,
    /// Why it did not run, if it did not.
    pub skipped: Option<String>,
}

/// What the stage did.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Every method's run.
    pub runs: Vec<MethodRun>,
    /// Per-frame rows of every method run.
    pub errors: Vec<FrameError>,
    /// Frames mapped.
    pub frames: usize,
    /// Clips carried over unchanged.
    pub carried: usize,
    /// Milliseconds of one rig evaluation of a single pose (mean of a batch).
    pub eval_ms: f64,
}

fn input_err(path: &std::path::Path) -> impl Fn(InvrigError) -> StageError + '_ {
    move |e| StageError::Input(format!("{}: {e}", path.display()))
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let methods = args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let fitted = Invrig::read(&args.io.invrig)?;
    let controls = Controls::read(&args.io.controls)?;
    let positions = Positions::read(&args.io.positions, args.fps)?;
    if positions.frames() > args.max_frames {
        return Err(StageError::Input(format!(
            "{}: {} frames exceed --max-frames {}",
            args.io.positions.display(),
            positions.frames(),
            args.max_frames
        )));
    }
    if positions.points != fitted.mapping.points {
        return Err(point_mismatch(&args.io.positions, &fitted.mapping.points, &positions.points).into());
    }
    let samples = &fitted.samples;
    let (rig, layout) = reprise_stagekit::rig::open_rig(&controls, &samples.controls)?;
    let points = reprise_invrig::points::check(&fitted.mapping.points, rig.vertex_count())
        .map_err(input_err(&args.io.invrig))?;
    let truth = args.io.frames.as_deref().map(Frames::read).transpose()?;
    if let Some(t) = &truth {
        if t.controls != samples.controls {
            return Err(StageError::Input(format!(
                "{}: its controls are not the mapping's ({} vs {}); give the frames the mapping was fitted from",
                args.io.frames.as_deref().map(|p| p.display().to_string()).unwrap_or_default(),
                t.controls.len(),
                samples.controls.len()
            )));
        }
    }

    // The regression, refitted from the poses the fit kept.
    let c = samples.controls.len();
    let mut point_rig = PointRig::new(rig.as_ref(), &layout, &points);
    let started = Instant::now();
    let x = reprise_invrig::refine::Rig::evaluate(&mut point_rig, &samples.values, samples.rows())
        .map_err(input_err(&args.io.invrig))?;
    let eval_ms = 1e3 * started.elapsed().as_secs_f64() / samples.rows() as f64;
    let free: Vec<bool> = samples.controls.iter().map(|n| fitted.mapping.free_controls.contains(n)).collect();
    let rest: Vec<f64> = {
        let defaults: BTreeMap<&str, f64> = controls.controls.iter().map(|c| (c.name.as_str(), c.default)).collect();
        samples.controls.iter().map(|n| defaults.get(n.as_str()).copied().unwrap_or(0.0)).collect()
    };
    let training = Training { x, d: positions.width(), y: samples.values.clone(), c };
    let mut map = InverseMap::new(training, (fitted.mapping.theta0, fitted.mapping.theta1), free, rest)
        .map_err(input_err(&args.io.invrig))?;

    let truth_rows = truth.as_ref().map(truth_index);
    let settings = RefineSettings { lambda: args.lambda, max_iters: args.iterations, tolerance: args.tolerance };
    let bar = reprise_stagekit::progress((methods.len() * positions.frames()) as u64, "invrig-apply");
    let mut runs = Vec::new();
    let mut errors = Vec::new();
    let mut written = None;
    for &method in &methods {
        let mut run = MethodRun { method, setup_seconds: 0.0, jacobian_poses: 0, skipped: None };
        if method.learns_jacobian() {
            let max_values = args.max_jacobian_mib.saturating_mul(1 << 20) / 8;
            let started = Instant::now();
            match map.learn_jacobian(&mut point_rig, args.step, max_values) {
                Ok(poses) => {
                    run.setup_seconds = started.elapsed().as_secs_f64();
                    run.jacobian_poses = poses;
                }
                Err(InvrigError::Param { .. }) if written.is_some() => {
                    run.skipped = Some(format!(
                        "one pose's learned Jacobian takes {} MiB, more than --max-jacobian-mib {}",
                        (map.learned_jacobian_values_per_pose() * 8) >> 20,
                        args.max_jacobian_mib
                    ));
                    runs.push(run);
                    bar.inc(positions.frames() as u64);
                    continue;
                }
                Err(e) => return Err(input_err(&args.io.invrig)(e)),
            }
        }
        let solved = measure(&map, method, &positions, rig.as_ref(), &layout, &points, args.step, &settings, &bar)
            .map_err(input_err(&args.io.positions))?;
        for (f, (y, e)) in solved.iter().enumerate() {
            let truth_error = truth_rows.as_ref().and_then(|(t, index)| {
                index.get(&(positions.clip[f].as_str(), positions.frame[f])).map(|&r| mean_sq(y, t.row(r)))
            });
            errors.push(FrameError { truth_error, ..e.clone() });
        }
        if written.is_none() {
            written = Some(solved.into_iter().map(|(y, _)| y).collect::<Vec<_>>());
        }
        runs.push(run);
    }
    bar.finish_and_clear();
    let ys = written.expect("the written method is first and always runs");
    let (recovered, carried) =
        assemble(&positions, &samples.controls, &ys, truth.as_ref().filter(|_| args.carry_clips));
    recovered.write(&args.io.recovered, &provenance)?;
    write_errors(&args.io.errors, &errors, &provenance)?;
    let summary = Summary { runs, errors, frames: positions.frames(), carried, eval_ms };
    let md = report::markdown(&report::Context {
        summary: &summary,
        mapping: &fitted.mapping,
        samples: samples.rows(),
        controls: c,
        written: methods[0],
        settings: &settings,
        step: args.step,
    });
    let marker = reprise_artifact::provenance::output_marker(WIRING.stage, provenance.pipeline.as_deref());
    let md = format!("{md}\n<!-- {marker} -->\n");
    reprise_artifact::table::write_atomic(&args.io.report, |f| {
        use std::io::Write as _;
        f.write_all(md.as_bytes()).map_err(|e| reprise_artifact::ArtifactError::io(&args.io.report, e))
    })?;
    Ok(Some(summary))
}

/// `(clip, frame) → row` of known curves.
fn truth_index(t: &Frames) -> (&Frames, BTreeMap<(&str, i64), usize>) {
    (t, (0..t.rows()).map(|r| ((t.clip[r].as_str(), t.frame[r]), r)).collect())
}

/// Mean of squared differences.
fn mean_sq(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(u, v)| (u - v) * (u - v)).sum::<f64>() / a.len().max(1) as f64
}

/// Every frame's controls by `method`, with its errors against the target positions
/// (measured by evaluating the rig at the controls found, outside the method's time).
#[allow(clippy::too_many_arguments)]
pub fn measure(
    map: &InverseMap,
    method: Method,
    positions: &Positions,
    rig: &dyn Rig,
    layout: &PoseLayout,
    points: &[usize],
    step: f64,
    settings: &RefineSettings,
    bar: &reprise_stagekit::ProgressBar,
) -> reprise_invrig::Result<Vec<(Vec<f64>, FrameError)>> {
    (0..positions.frames())
        .into_par_iter()
        .map(|f| {
            let mut pr = PointRig::new(rig, layout, points);
            let target = positions.row(f);
            let started = Instant::now();
            let s = map.solve(method, target, &mut pr, step, settings)?;
            let ms = 1e3 * started.elapsed().as_secs_f64();
            let x = reprise_invrig::refine::Rig::evaluate(&mut pr, &s.y, 1)?;
            let (joint_error, joint_distance) = point_errors(&x, target);
            bar.inc(1);
            let stop = match s.stop {
                None => "",
                Some(Stop::Converged) => "converged",
                Some(Stop::MaxIters) => "max-iters",
                Some(Stop::NoProgress) => "no-progress",
            };
            let row = FrameError {
                method: method.name().into(),
                clip: positions.clip[f].clone(),
                frame: positions.frame[f],
                joint_error,
                joint_distance,
                truth_error: None,
                iterations: s.iterations as i64,
                evaluations: s.evaluations as i64,
                ms,
                stop: stop.into(),
            };
            Ok((s.y, row))
        })
        .collect()
}

/// Mean squared and mean point distance between two sets of points (`x, y, z` each).
pub fn point_errors(a: &[f64], b: &[f64]) -> (f64, f64) {
    let (mut sq, mut dist) = (0.0, 0.0);
    for (p, q) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        let d2: f64 = p.iter().zip(q).map(|(u, v)| (u - v) * (u - v)).sum();
        sq += d2;
        dist += d2.sqrt();
    }
    let n = (a.len() / 3).max(1) as f64;
    (sq / n, dist / n)
}

/// The frames table written: the clips of `carry` in its order, each replaced by the
/// positions' clip of that name where there is one, then the positions' other clips;
/// with the number of clips carried unchanged.
fn assemble(positions: &Positions, controls: &[String], ys: &[Vec<f64>], carry: Option<&Frames>) -> (Frames, usize) {
    let fps = positions.fps;
    let mut out = Frames {
        fps,
        controls: controls.to_vec(),
        clip: Vec::new(),
        frame: Vec::new(),
        time: Vec::new(),
        values: Vec::new(),
    };
    let mapped = positions.clip_runs();
    let push_mapped = |out: &mut Frames, (clip, a, b): &(String, usize, usize)| {
        for (&frame, y) in positions.frame[*a..*b].iter().zip(&ys[*a..*b]) {
            out.clip.push(clip.clone());
            out.frame.push(frame);
            out.time.push(frame as f64 / fps);
            out.values.extend_from_slice(y);
        }
    };
    let mut done = vec![false; mapped.len()];
    let mut carried = 0;
    if let Some(t) = carry {
        for (clip, a, b) in t.clip_runs() {
            match mapped.iter().position(|m| m.0 == clip) {
                Some(k) if !done[k] => {
                    push_mapped(&mut out, &mapped[k]);
                    done[k] = true;
                }
                Some(_) => {}
                None => {
                    carried += 1;
                    for r in a..b {
                        out.clip.push(clip.clone());
                        out.frame.push(t.frame[r]);
                        out.time.push(t.time[r]);
                        out.values.extend_from_slice(t.row(r));
                    }
                }
            }
        }
    }
    for (k, run) in mapped.iter().enumerate() {
        if !done[k] {
            push_mapped(&mut out, run);
        }
    }
    (out, carried)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_written_method_comes_first_then_the_paper_order() {
        let mut args = Args::parse_from([
            "x",
            "--invrig",
            "m",
            "--positions",
            "p",
            "--controls",
            "c",
            "--recovered",
            "r",
            "--errors",
            "e",
            "--report",
            "md",
        ]);
        assert_eq!(methods(&args).unwrap()[0], Method::GprComputedJacobian);
        assert_eq!(methods(&args).unwrap().len(), 6);
        args.method = "gpr".into();
        args.compare = vec!["rest-computed-jacobian".into(), "nearest".into()];
        assert_eq!(methods(&args).unwrap(), vec![Method::Gpr, Method::Nearest, Method::RestComputedJacobian]);
        args.compare = vec!["fastest".into()];
        assert!(methods(&args).unwrap_err().to_string().contains("unknown method `fastest`"));
    }

    #[test]
    fn point_errors_are_mean_squared_and_mean_distances() {
        let (sq, d) = point_errors(&[0.0, 0.0, 0.0, 3.0, 4.0, 0.0], &[0.0; 6]);
        assert_eq!((sq, d), (12.5, 2.5));
    }

    #[test]
    fn carried_clips_keep_their_place_and_mapped_ones_replace_theirs() {
        let positions = Positions {
            fps: 24.0,
            points: vec![0],
            clip: vec!["b".into(), "z".into()],
            frame: vec![0, 0],
            values: vec![0.0; 6],
        };
        let truth = Frames {
            fps: 24.0,
            controls: vec!["k".into()],
            clip: vec!["a".into(), "b".into(), "b".into()],
            frame: vec![0, 0, 1],
            time: vec![0.0, 0.0, 1.0 / 24.0],
            values: vec![1.0, 2.0, 3.0],
        };
        let (out, carried) = assemble(&positions, &truth.controls, &[vec![9.0], vec![8.0]], Some(&truth));
        assert_eq!(carried, 1);
        assert_eq!(out.clip, vec!["a", "b", "z"]);
        assert_eq!(out.values, vec![1.0, 9.0, 8.0]);
        let (alone, _) = assemble(&positions, &truth.controls, &[vec![9.0], vec![8.0]], None);
        assert_eq!(alone.clip, vec!["b", "z"]);
    }
}
