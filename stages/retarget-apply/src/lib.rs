//! The retarget-apply stage: a capture (marker positions per frame) onto a character's rig
//! through a model of `retarget-fit`. Each frame is the MAP solve of Bouaziz and Pauly
//! (Eq. 12–17): the capture's noise, the step from the previous frame of the clip, and the
//! source GP's manifold; markers named by `--missing` are unseen on every frame and filled
//! in from the manifold. The character's pose is the target GP's mean at the latent found
//! (Eq. 18), decoded from the scaled PCA space to every control.
//!
//! The curves are a `curves` table (script = the capture's clip), so glTF export and the
//! players read them as synthesized animation. Where the character's poses are known
//! (`--truth`, e.g. an oracle's), every frame's mesh error is measured, and ridge regression
//! and GPR fitted on the same labelled pairs are measured beside it by the same code.

use std::time::Instant;

use clap::Parser;
use reprise_artifact::controls::Controls;
use reprise_artifact::curves::{self, Curves, Frame};
use reprise_artifact::frames::Frames;
use reprise_artifact::positions::{point_mismatch, Positions};
use reprise_artifact::retarget::{write_frames, MappedFrame, Retarget, Role};
use reprise_numerics::gplvm::Hyper;
use reprise_retarget::baselines::{gpr, Ridge};
use reprise_retarget::model::{Affine, Mapper, Model};
use reprise_retarget::source::Noise;
use reprise_retarget::target::TargetSpace;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

pub mod report;

reprise_stagekit::stage_io! {
    stage: "retarget-apply", bin: "reprise-retarget-apply",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the fitted model.
        model: required "retarget.parquet",
        /// Input: the capture to map, marker positions per frame.
        capture: required "positions.parquet",
        /// Input: the character's controls table (names its rig).
        controls: required "controls.parquet",
        /// Input (optional): the character's known poses for the capture's frames, named by
        /// the capture's clip and frame.
        truth: optional "truth.parquet",
    }
    outputs {
        /// Output: the character's curves, one script per capture clip.
        curves: artifact "curves.parquet",
        /// Output: per frame, the residual, variance, time and mesh error.
        frames: artifact "retarget_frames.parquet",
        /// Output: the character performing the capture (and the known poses beside it),
        /// baked to morph targets, as a glTF binary.
        glb: artifact "retarget.glb",
        /// Output: the Markdown report.
        report: report "retarget.md",
        /// Output: the player: the same tracks in a standalone page.
        player: report "retarget.html",
    }
}

/// `reprise-retarget-apply`: a capture onto a character's rig.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-retarget-apply", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Markers (point ids of the capture) unseen on every frame (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub missing: Vec<i64>,
    /// Capture clips to map: glob patterns (comma-separated; none: every clip).
    #[arg(long, value_delimiter = ',')]
    pub clips: Vec<String>,
    /// The temporal term (off: every frame is solved alone).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub temporal: bool,
    /// Most morph targets of the baked glTF and player (their RMS vertex error is in the
    /// report).
    #[arg(long, default_value_t = 48)]
    pub morph_targets: usize,
    /// A pose to complete from a few fixed controls (the paper's Fig. 8), as
    /// `control=value,control=value`; repeat for more. Each becomes a frame of the script
    /// `posed` in the curves.
    #[arg(long)]
    pub pose: Vec<String>,
    /// How closely a completed pose holds its fixed controls, mesh length.
    #[arg(long, default_value_t = 1e-3)]
    pub pose_tolerance: f64,
    /// Ridge penalty of the ridge baseline, in normalised units.
    #[arg(long, default_value_t = 1e-3)]
    pub ridge: f64,
    /// Frame rate of a capture without `reprise.fps` metadata.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Limit: capture frames mapped.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_frames: usize,
}

/// The report's name for the known poses projected onto the target space and back: a
/// reference for what the space can hold (the projection is nearest in scaled controls, not
/// in mesh distance, so it is no strict lower bound).
pub const FLOOR: &str = "the known pose, projected onto the target space";

/// The script of the completed poses (parenthesised: no capture clip may take the name).
pub const POSED: &str = "(posed)";

/// Parses `--pose` values into (control index, value) lists over `names`.
///
/// # Errors
/// A term that is not `control=value`, an unknown control, a value that is not a finite
/// number, or a control named twice.
pub fn parse_poses(poses: &[String], names: &[String]) -> StageResult<Vec<Vec<(usize, f64)>>> {
    poses
        .iter()
        .map(|p| {
            let mut out: Vec<(usize, f64)> = Vec::new();
            for term in p.split(',').map(str::trim).filter(|t| !t.is_empty()) {
                let bad = |why: &str| StageError::Config(format!("--pose `{p}`: `{term}` {why}"));
                let (name, value) = term.split_once('=').ok_or_else(|| bad("is not control=value"))?;
                let j =
                    names.iter().position(|n| n == name.trim()).ok_or_else(|| bad("names no control of the model"))?;
                let v: f64 = value
                    .trim()
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| bad("has no finite value"))?;
                if out.iter().any(|&(k, _)| k == j) {
                    return Err(bad("names a control twice"));
                }
                out.push((j, v));
            }
            if out.is_empty() {
                return Err(StageError::Config(format!("--pose `{p}` fixes no control")));
            }
            Ok(out)
        })
        .collect()
}

/// The model name written in the curves' `model` column.
pub const MODEL: &str = "retarget";

/// What the stage did.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Per frame.
    pub frames: Vec<MappedFrame>,
    /// Mean mesh error of the target space's reference ([`FLOOR`]) and of each baseline
    /// (ridge, GPR), where the poses are known: over every frame, and over the frames the
    /// model did not train on (NaN when there are none).
    pub baselines: Vec<(String, f64, f64)>,
    /// The capture's frame rate.
    pub fps: f64,
    /// Labelled pairs, source frames, target poses of the model.
    pub rows: (usize, usize, usize),
    /// Seconds the model's fit took.
    pub fit_seconds: f64,
    /// Target-space components.
    pub components: usize,
    /// The baked animation: morph targets and their RMS vertex error (rig length unit).
    pub baked: (usize, f64),
    /// Milliseconds of one rig evaluation (the mean over the curves' frames, in batches):
    /// the reference the mapping's time is read against.
    pub eval_ms: f64,
    /// Each completed pose: its fixed controls and how closely they are held (mesh length).
    pub posed: Vec<(Vec<(usize, f64)>, f64)>,
}

/// The model of an artifact.
pub fn model_of(r: &Retarget) -> (Model, TargetSpace) {
    let s = &r.settings;
    let model = Model {
        q: s.q,
        labelled: r.counts().0,
        x_norm: Affine { mean: s.source.mean.clone(), scale: s.source.scale },
        y_norm: Affine { mean: s.target.mean.clone(), scale: s.target.scale },
        x: r.x.clone(),
        y: r.y.clone(),
        z: r.z.clone(),
        hyper_x: Hyper::from_log(s.source_kernel),
        hyper_y: Hyper::from_log(s.target_kernel),
    };
    let space = TargetSpace {
        weights: s.space.weights.clone(),
        held: s.space.held.clone(),
        mean: s.space.mean.clone(),
        directions: s.space.directions.clone(),
        explained: s.space.explained,
    };
    (model, space)
}

/// Which capture values are seen: false for the three coordinates of each `missing` point.
///
/// # Errors
/// A missing point the capture does not hold; every point missing.
pub fn seen_mask(points: &[i64], missing: &[i64]) -> StageResult<Vec<bool>> {
    if let Some(p) = missing.iter().find(|p| !points.contains(p)) {
        return Err(StageError::Config(format!("--missing {p}: the capture has no such point")));
    }
    if points.iter().all(|p| missing.contains(p)) {
        return Err(StageError::Config("--missing names every point: nothing is left to map".into()));
    }
    Ok(points.iter().flat_map(|p| [!missing.contains(p); 3]).collect())
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let clips = reprise_stagekit::clips::matcher(&args.clips, "--clips")?;
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if args.fps.is_some_and(|f| !positive(f)) || !positive(args.ridge) || !positive(args.pose_tolerance) {
        return Err(StageError::Config("--fps, --ridge and --pose-tolerance must be finite and positive".into()));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let fitted = Retarget::read(&args.io.model)?;
    let capture = Positions::read(&args.io.capture, args.fps)?;
    if capture.points != fitted.settings.points {
        return Err(point_mismatch(&args.io.capture, &fitted.settings.points, &capture.points).into());
    }
    check_capture(&capture, &args.io.capture, fitted.settings.fps)?;
    let keep: Vec<bool> = capture.clip.iter().map(|c| clips.as_ref().is_none_or(|m| m.is_match(c))).collect();
    let rows: Vec<usize> = (0..capture.frames()).filter(|&r| keep[r]).collect();
    if rows.is_empty() || rows.len() > args.max_frames {
        return Err(StageError::Input(format!(
            "{}: {} frames to map (clips {:?}); between 1 and --max-frames {}",
            args.io.capture.display(),
            rows.len(),
            args.clips,
            args.max_frames
        )));
    }
    let seen = seen_mask(&capture.points, &args.missing)?;
    let controls = Controls::read(&args.io.controls)?;
    let names = &fitted.settings.controls;
    let fixed = parse_poses(&args.pose, names)?;
    let rig = reprise_stagekit::rig::open_rig(&controls, names)?;
    let truth = args.io.truth.as_deref().map(|p| known_poses(p, names, &capture, &rows)).transpose()?;

    let (model, space) = model_of(&fitted);
    if let Some(&(j, _)) = fixed.iter().flatten().find(|&&(j, _)| space.weights[j] <= 0.0) {
        return Err(StageError::Config(format!(
            "--pose: `{}` has no weight in the model (the corpus never moves it, or it moves no vertex), so the \
             model cannot hold it",
            names[j]
        )));
    }
    let trained: std::collections::HashSet<(&str, i64)> = (0..fitted.role.len())
        .filter(|&r| fitted.role[r] != Role::Target)
        .map(|r| (fitted.clip[r].as_str(), fitted.frame[r]))
        .collect();
    let s = &fitted.settings;
    let mapper = Mapper::new(&model, Noise { capture: s.capture_noise, temporal: s.temporal_noise })
        .map_err(|e| StageError::Input(format!("{}: {e}", args.io.model.display())))?;
    let missing = seen.iter().filter(|&&v| !v).count() as i64;
    let mut out = Curves { fps: capture.fps, controls: names.clone(), ..Curves::default() };
    let mut stats = Vec::with_capacity(rows.len());
    let mut poses = Vec::with_capacity(rows.len());
    let bar = reprise_stagekit::progress(rows.len() as u64, "retarget-apply");
    for (clip, a, b) in capture.clip_runs() {
        let run: Vec<usize> = (a..b).filter(|&r| keep[r]).collect();
        let mut previous: Option<Vec<f64>> = None;
        for &r in &run {
            let started = Instant::now();
            let m = mapper.map(capture.row(r), &seen, previous.as_deref().filter(|_| args.temporal));
            let pose = space.decode(&m.y);
            let ms = 1e3 * started.elapsed().as_secs_f64();
            stats.push(MappedFrame {
                clip: clip.clone(),
                frame: capture.frame[r],
                residual: m.residual,
                variance: m.variance,
                missing,
                ms,
                mesh_error: None,
                trained: trained.contains(&(clip.as_str(), capture.frame[r])),
            });
            // The capture's own frame numbers and times, so the curves stay in sync with it.
            out.script.push(clip.clone());
            out.frame.push(capture.frame[r]);
            out.time.push(capture.frame[r] as f64 / capture.fps);
            out.model.push(MODEL.into());
            out.command.push(0);
            out.x.push(m.z.clone());
            out.values.extend_from_slice(&pose);
            poses.push(pose);
            previous = Some(m.x);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let posed = complete_poses(&model, &space, &fixed, args.pose_tolerance)?;
    out.push_script(POSED, posed.iter().map(|p| Frame { model: MODEL, controls: &p.pose, x: &p.z, command: 0 }));

    let mut baselines = Vec::new();
    let started = Instant::now();
    let mut tracks = vec![reprise_stagekit::rig::meshes(&rig, &poses)?];
    let eval_ms = 1e3 * started.elapsed().as_secs_f64() / poses.len().max(1) as f64;
    if let Some(truth) = &truth {
        let c = names.len();
        tracks.push(reprise_stagekit::rig::meshes(
            &rig,
            &truth.chunks_exact(c).map(<[f64]>::to_vec).collect::<Vec<_>>(),
        )?);
        let errors = mesh_errors(&tracks[0], &tracks[1], rig.0.vertex_count());
        for (st, e) in stats.iter_mut().zip(&errors) {
            st.mesh_error = Some(*e);
        }
        let floor: Vec<Vec<f64>> = truth.chunks_exact(c).map(|p| space.decode(&space.encode(p))).collect();
        let mut others = vec![(FLOOR.to_string(), floor)];
        others.extend(baseline_poses(&fitted, &model, &space, &capture, &rows, &seen, args.ridge)?);
        let held_out: Vec<bool> = stats.iter().map(|f| !f.trained).collect();
        for (name, predicted) in others {
            let e = mesh_errors(&reprise_stagekit::rig::meshes(&rig, &predicted)?, &tracks[1], rig.0.vertex_count());
            baselines.push((name, mean_where(&e, |_| true), mean_where(&e, |i| held_out[i])));
        }
    }
    curves::write(&args.io.curves, &out, &provenance)?;
    write_frames(&args.io.frames, &stats, &provenance)?;
    let track_names: Vec<String> =
        ["retargeted", "known (the --truth poses)"].iter().take(tracks.len()).map(|s| s.to_string()).collect();
    let refs: Vec<&[f64]> = tracks.iter().map(Vec::as_slice).collect();
    let baked = reprise_mesh_animation::bake(&refs, rig.0.vertex_count(), args.morph_targets)
        .map_err(|e| StageError::Input(format!("the meshes of the curves: {e}")))?;
    let glb = reprise_mesh_animation::glb::write(&baked, rig.0.triangles(), &track_names, capture.fps, "retargeted");
    write_bytes(&args.io.glb, &glb)?;
    let summary = Summary {
        frames: stats,
        baselines,
        rows: fitted.counts(),
        fit_seconds: s.fit.seconds,
        components: space.d(),
        baked: (baked.k(), baked.rms_error),
        eval_ms,
        fps: capture.fps,
        posed: fixed.iter().zip(&posed).map(|(f, p)| (f.clone(), p.residual)).collect(),
    };
    let md = report::markdown(&summary, &fitted.settings, args);
    let marker = reprise_artifact::provenance::output_marker(WIRING.stage, provenance.pipeline.as_deref());
    write_bytes(&args.io.report, format!("{md}\n<!-- {marker} -->\n").as_bytes())?;
    let errors: Vec<f64> = summary.frames.iter().filter_map(|f| f.mesh_error).collect();
    let readouts = if errors.is_empty() {
        vec![]
    } else {
        vec![reprise_mesh_animation::player::Readout { label: "mesh error".into(), values: errors }]
    };
    let page = reprise_mesh_animation::player::html(&reprise_mesh_animation::player::Page {
        title: "The capture, retargeted onto the character",
        caption: &report::player_caption(&summary, &track_names),
        baked: &baked,
        triangles: rig.0.triangles(),
        names: &track_names,
        fps: capture.fps,
        readouts: &readouts,
    });
    write_bytes(&args.io.player, page.as_bytes())?;
    Ok(Some(summary))
}

/// Completes each list of fixed controls (the paper's Fig. 8).
fn complete_poses(
    model: &Model,
    space: &TargetSpace,
    fixed: &[Vec<(usize, f64)>],
    tolerance: f64,
) -> StageResult<Vec<reprise_retarget::pose::Posed>> {
    if fixed.is_empty() {
        return Ok(Vec::new());
    }
    let poser = reprise_retarget::pose::Poser::new(model, space)
        .map_err(|e| StageError::Input(format!("the model's target GP: {e}")))?;
    fixed.iter().map(|f| poser.pose(f, tolerance).map_err(|e| StageError::Config(format!("--pose: {e}")))).collect()
}

/// The mean of `v` over the indices `keep` takes; NaN for none.
pub fn mean_where(v: &[f64], keep: impl Fn(usize) -> bool) -> f64 {
    let (sum, n) = v.iter().enumerate().filter(|(i, _)| keep(*i)).fold((0.0, 0usize), |(s, n), (_, x)| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// Refuses a capture the model cannot map as fitted: a rate other than the fit's (σt is a
/// per-frame step), a clip in two separate runs (its curves would be two scripts of one
/// name), or a clip named [`POSED`].
fn check_capture(capture: &Positions, path: &std::path::Path, fps: f64) -> StageResult<()> {
    if (capture.fps - fps).abs() > 1e-9 * fps {
        return Err(StageError::Input(format!(
            "{}: {} fps, where the model was fitted at {fps} fps (its temporal term is a per-frame step): fit on a \
             capture of this rate",
            path.display(),
            capture.fps
        )));
    }
    let mut seen = std::collections::HashSet::new();
    for (clip, _, _) in capture.clip_runs() {
        if clip == POSED || !seen.insert(clip.clone()) {
            return Err(StageError::Input(format!(
                "{}: clip `{clip}` {}",
                path.display(),
                if clip == POSED {
                    "takes the name of the completed poses' script"
                } else {
                    "appears in two separate runs of rows"
                }
            )));
        }
    }
    Ok(())
}

fn write_bytes(path: &std::path::Path, bytes: &[u8]) -> StageResult<()> {
    reprise_artifact::table::write_atomic(path, |f| {
        use std::io::Write as _;
        f.write_all(bytes).map_err(|e| reprise_artifact::ArtifactError::io(path, e))
    })?;
    Ok(())
}

/// The known pose of every mapped capture frame, in the model's control order.
///
/// # Errors
/// A control the table lacks, or a mapped frame it does not hold.
fn known_poses(path: &std::path::Path, names: &[String], capture: &Positions, rows: &[usize]) -> StageResult<Vec<f64>> {
    let t = Frames::read(path)?;
    let columns: Vec<usize> = names
        .iter()
        .map(|c| {
            t.controls.iter().position(|n| n == c).ok_or_else(|| {
                StageError::Input(format!("{}: no column for the character's control `{c}`", path.display()))
            })
        })
        .collect::<StageResult<_>>()?;
    let index: std::collections::HashMap<(&str, i64), usize> =
        (0..t.rows()).map(|r| ((t.clip[r].as_str(), t.frame[r]), r)).collect();
    let mut out = Vec::with_capacity(rows.len() * names.len());
    for &r in rows {
        let k = index.get(&(capture.clip[r].as_str(), capture.frame[r])).ok_or_else(|| {
            StageError::Input(format!(
                "{}: holds no pose for the capture's clip `{}` frame {}",
                path.display(),
                capture.clip[r],
                capture.frame[r]
            ))
        })?;
        out.extend(columns.iter().map(|&c| t.row(*k)[c]));
    }
    Ok(out)
}

/// Per pose, the RMS vertex distance between two batches of meshes of `vertices` vertices.
fn mesh_errors(a: &[f64], b: &[f64], vertices: usize) -> Vec<f64> {
    let m = 3 * vertices;
    a.chunks_exact(m).zip(b.chunks_exact(m)).map(|(a, b)| reprise_stagekit::rig::mesh_rmse(a, b)).collect()
}

/// Ridge regression and GPR fitted on the model's labelled pairs (normalised capture →
/// normalised target coordinates) over the capture values seen (`--missing` leaves the
/// others out of the fit, as it leaves them out of the solve), each frame's pose decoded.
fn baseline_poses(
    fitted: &Retarget,
    model: &Model,
    space: &TargetSpace,
    capture: &Positions,
    rows: &[usize],
    seen: &[bool],
    alpha: f64,
) -> StageResult<Vec<(String, Vec<Vec<f64>>)>> {
    let (dx, dy, l) = (model.dx(), model.dy(), fitted.role.iter().filter(|&&r| r == Role::Labelled).count());
    let cols: Vec<usize> = (0..dx).filter(|&j| seen[j]).collect();
    let pick = |row: &[f64]| cols.iter().map(|&j| row[j]).collect::<Vec<f64>>();
    let xl: Vec<f64> = model.x[..l * dx].chunks_exact(dx).flat_map(pick).collect();
    let yl = &model.y[..l * dy];
    let err = |e: reprise_numerics::gplvm::GplvmError| StageError::Input(format!("a baseline's fit: {e}"));
    let ridge = Ridge::fit(&xl, cols.len(), yl, dy, alpha).map_err(err)?;
    let gp = gpr(&xl, cols.len(), yl, dy).map_err(err)?;
    let inputs: Vec<Vec<f64>> = rows.iter().map(|&r| pick(&model.x_norm.apply(capture.row(r)))).collect();
    let decode = |y: &[f64]| space.decode(&model.y_norm.invert(y));
    let ridge_poses = inputs.iter().map(|x| decode(&ridge.predict(x))).collect();
    let gpr_poses = inputs
        .iter()
        .map(|x| {
            let mut y = vec![0.0; dy];
            gp.mean(x, &mut y);
            decode(&y)
        })
        .collect();
    Ok(vec![("ridge".into(), ridge_poses), ("GPR".into(), gpr_poses)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_are_parsed_by_control_name_and_bad_ones_are_named() {
        let names: Vec<String> = ["jaw_open", "smile_L"].map(String::from).to_vec();
        let p = parse_poses(&["jaw_open=30, smile_L=0.5".into()], &names).unwrap();
        assert_eq!(p, vec![vec![(0, 30.0), (1, 0.5)]]);
        let err = |s: &str| parse_poses(&[s.into()], &names).unwrap_err().to_string();
        assert!(err("nose=1").contains("names no control"));
        assert!(err("jaw_open").contains("control=value"));
        assert!(err("jaw_open=NaN").contains("finite"));
        assert!(err("jaw_open=1,jaw_open=2").contains("twice"));
        assert!(err(" , ").contains("fixes no control"));
    }

    #[test]
    fn a_capture_of_another_rate_or_with_a_clip_in_two_runs_is_refused() {
        let capture = |clips: &[&str], fps: f64| Positions {
            fps,
            points: vec![0],
            clip: clips.iter().map(|c| c.to_string()).collect(),
            frame: (0..clips.len() as i64).collect(),
            values: vec![0.0; 3 * clips.len()],
        };
        let path = std::path::Path::new("take.parquet");
        assert!(check_capture(&capture(&["a", "a", "b"], 60.0), path, 60.0).is_ok());
        let err = check_capture(&capture(&["a", "a"], 30.0), path, 60.0).unwrap_err().to_string();
        assert!(err.contains("30 fps") && err.contains("fitted at 60 fps"), "{err}");
        let err = check_capture(&capture(&["a", "b", "a"], 60.0), path, 60.0).unwrap_err().to_string();
        assert!(err.contains("clip `a` appears in two separate runs"), "{err}");
        let err = check_capture(&capture(&[POSED], 60.0), path, 60.0).unwrap_err().to_string();
        assert!(err.contains("completed poses"), "{err}");
    }

    #[test]
    fn a_missing_point_hides_its_three_values_and_an_unknown_one_is_refused() {
        assert_eq!(seen_mask(&[4, 9], &[9]).unwrap(), vec![true, true, true, false, false, false]);
        assert!(seen_mask(&[4, 9], &[5]).unwrap_err().to_string().contains("--missing 5"));
        assert!(seen_mask(&[4, 9], &[4, 9]).unwrap_err().to_string().contains("every point"));
    }
}
