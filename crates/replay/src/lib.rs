//! `reprise-replay`: a live session's recording (`reprise serve`'s
//! `recordings/session-*.json`) turned into the transition benchmark's artifacts, so that
//! `evaluate` measures the session with the benchmark's metrics, by the same code, for
//! every system. `reprise replay RECORDING` runs it, then `evaluate`, on a pipeline.
//!
//! Every system of `reprise_live::systems::SYSTEM_IDS` — not only those the session ran:
//! the systems are independent, so each one's frames under the session's commands are
//! [`reprise_live::session::replay`] of the recording with that system alone — answers
//! the session's TRANSITION commands ([`convert`]):
//!
//! - `transition_requests`: one request per TRANSITION command, from the label the
//!   TRANSITION before it went to (or the session's start label) to its label. The start
//!   frame columns (`segment_id`, `clip`, `frame`; evaluate reads them only for
//!   `start_on_bridge`) name label A's start row ([`World::start_row`]: its first labeled
//!   frame every system can start from) — the same for every system, and for the first
//!   request the frame the session started at; later requests start wherever the session
//!   left each system, which no single frame names.
//! - per system, `answers_<system>` and `transitions_<system>` (script `r<id>`): the
//!   system's frames from `hold` seconds before the command to the next command (or the
//!   recording's end), `asked` the last frame before the command; latency the frames to
//!   its first frame labelled B (its own `LiveFrame::label`), or unanswered with why.
//! - for the seeded systems (`reprise_benchmark::systems::SYSTEMS`' `seeded`),
//!   `transitions_<system>_reseeded`: the same windows of the session replayed under its
//!   seed + [`RESEED`], as the benchmark answers each request again under its seed +
//!   [`RESEED`] (for the variety metric).
//!
//! The systems run as `reprise serve` runs them ([`Tuning::default`]), so the frames are
//! those the session showed, bit for bit.

pub mod convert;

use std::path::Path;

use clap::Parser;
use reprise_artifact::curves;
use reprise_artifact::transitions::{self, Answer, Request};
use reprise_benchmark::systems::{RESEED, SYSTEMS};
use reprise_live::session::{self, Recording, Session};
use reprise_live::systems::{Debug, LiveFrame};
use reprise_live::world::{Paths, Tuning, World};
use reprise_stagekit::{AnswerSummary, StageError, StageResult};
use serde::Serialize;

use crate::convert::{Asked, Window};

reprise_stagekit::stage_io! {
    stage: "replay", bin: "reprise-replay",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the session's recording (JSON, as `reprise serve` writes it).
        recording: source "recording.json",
        /// Input: the GPLVM models.
        gplvm_models: required "gplvm_models.parquet",
        /// Input: the GPLVM latents.
        latents: required "gplvm_latents.parquet",
        /// Input: the PCA models.
        pca_models: required "pca_models.parquet",
        /// Input: the scales.
        scales: required "scales.parquet",
        /// Input: the bridges.
        bridges: required "bridges.parquet",
        /// Input: the labeled frames.
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the motion graph's nodes.
        mg_nodes: required "mg_nodes.parquet",
        /// Input: the motion graph's edges.
        mg_edges: required "mg_edges.parquet",
        /// Input: the controls table (names the rig).
        controls: required "controls.parquet",
    }
    outputs {
        /// Output: the requests, one per TRANSITION command.
        requests: artifact "transition_requests.parquet",
        /// Output: reprise's answers.
        reprise_answers: artifact "answers_reprise.parquet",
        /// Output: reprise's curves.
        reprise_curves: artifact "transitions_reprise.parquet",
        /// Output: reprise's curves with the session replayed under another seed.
        reprise_reseeded: artifact "transitions_reprise_reseeded.parquet",
        /// Output: the paper's reprise's answers.
        reprise_paper_answers: artifact "answers_reprise_paper.parquet",
        /// Output: the paper's reprise's curves.
        reprise_paper_curves: artifact "transitions_reprise_paper.parquet",
        /// Output: the paper's reprise's curves under another seed.
        reprise_paper_reseeded: artifact "transitions_reprise_paper_reseeded.parquet",
        /// Output: Motion Graphs' answers.
        motion_graphs_answers: artifact "answers_motion_graphs.parquet",
        /// Output: Motion Graphs' curves.
        motion_graphs_curves: artifact "transitions_motion_graphs.parquet",
        /// Output: Motion Graphs' curves under another seed.
        motion_graphs_reseeded: artifact "transitions_motion_graphs_reseeded.parquet",
        /// Output: motion matching's answers.
        mm_answers: artifact "answers_motion_matching.parquet",
        /// Output: motion matching's curves.
        mm_curves: artifact "transitions_motion_matching.parquet",
        /// Output: the crossfade's answers.
        crossfade_answers: artifact "answers_crossfade.parquet",
        /// Output: the crossfade's curves.
        crossfade_curves: artifact "transitions_crossfade.parquet",
    }
}

/// `reprise-replay`: a live session's recording as the transition benchmark's artifacts.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-replay", version, about)]
pub struct Args {
    /// The files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Seconds of each system's frames kept before every TRANSITION as context (the
    /// benchmark's `hold`; at least one frame).
    #[arg(long, default_value_t = 0.5)]
    pub hold: f64,
    /// Controls of the curves are stored to this fraction of their range in the training
    /// frames (a power-of-two grid; 0: exactly), as the benchmark's.
    #[arg(long, default_value_t = curves::BENCHMARK_RESOLUTION)]
    pub resolution: f64,
}

/// The longest `--hold`, seconds (context only: a longer one would only repeat the
/// answer before).
pub const MAX_HOLD_SECONDS: f64 = 60.0;

/// One system's files.
struct Output<'a> {
    id: &'static str,
    answers: &'a Path,
    curves: &'a Path,
    reseeded: Option<&'a Path>,
}

impl Io {
    /// Every system's files, in [`SYSTEMS`]' order (reseeded curves for the seeded ones).
    fn systems(&self) -> StageResult<Vec<Output<'_>>> {
        let files: [(&Path, &Path, Option<&Path>); 5] = [
            (&self.reprise_answers, &self.reprise_curves, Some(&self.reprise_reseeded)),
            (&self.reprise_paper_answers, &self.reprise_paper_curves, Some(&self.reprise_paper_reseeded)),
            (&self.motion_graphs_answers, &self.motion_graphs_curves, Some(&self.motion_graphs_reseeded)),
            (&self.mm_answers, &self.mm_curves, None),
            (&self.crossfade_answers, &self.crossfade_curves, None),
        ];
        SYSTEMS
            .iter()
            .zip(files)
            .map(|(def, (answers, curves, reseeded))| {
                if def.seeded != reseeded.is_some() {
                    return Err(StageError::Config(format!("internal error: `{}`'s reseeded curves", def.id)));
                }
                Ok(Output { id: def.id, answers, curves, reseeded })
            })
            .collect()
    }

    /// The world's files.
    fn world(&self) -> Paths {
        Paths {
            gplvm_models: self.gplvm_models.clone(),
            latents: self.latents.clone(),
            pca_models: self.pca_models.clone(),
            scales: self.scales.clone(),
            bridges: self.bridges.clone(),
            labeled_frames: self.labeled_frames.clone(),
            mg_nodes: self.mg_nodes.clone(),
            mg_edges: self.mg_edges.clone(),
            controls: self.controls.clone(),
        }
    }
}

/// One system's frames of the session, in the played sequence of [`convert`]: the start
/// frame, then the session's frames.
struct Played<'w> {
    world: &'w World,
    /// The labeled row every system starts from.
    start: usize,
    frames: Vec<LiveFrame>,
}

impl Played<'_> {
    fn controls(&self, i: usize) -> &[f64] {
        match i {
            0 => self.world.labeled.frames.row(self.start),
            _ => &self.frames[i - 1].controls,
        }
    }

    fn label(&self, i: usize) -> usize {
        match i {
            0 => self.world.row_label[self.start],
            _ => self.frames[i - 1].label,
        }
    }

    /// reprise's latent point (the start frame gets its first frame's: where it started);
    /// empty for the others.
    fn x(&self, i: usize) -> &[f64] {
        match self.frames.get(i.saturating_sub(1)).map(|f| &f.debug) {
            Some(Debug::Reprise { x, .. }) => x,
            _ => &[],
        }
    }

    fn note(&self, i: usize) -> Option<&str> {
        i.checked_sub(1).and_then(|i| self.frames[i].note.as_deref())
    }

    /// The system's answer to `a` over `w`.
    fn answer(&self, a: &Asked, w: &Window, to: usize) -> Answer {
        let labels: Vec<usize> = (w.first..w.end).map(|i| self.label(i)).collect();
        let notes: Vec<Option<&str>> = (w.first..w.end).map(|i| self.note(i)).collect();
        a.answer(w, &labels, &notes, to)
    }

    /// The curve's frames over `w` (command 0 up to the request, 1 after it, as the
    /// benchmark's hold and TRANSITION).
    fn curve<'a>(&'a self, w: &Window) -> impl Iterator<Item = curves::Frame<'a>> + 'a {
        let (labels, asked) = (&self.world.labels, w.asked);
        (w.first..w.end).map(move |i| curves::Frame {
            model: &labels[self.label(i)],
            controls: self.controls(i),
            x: self.x(i),
            command: i64::from(i > asked),
        })
    }
}

/// What was replayed: the requests and each system's answers, in [`SYSTEMS`]' order.
#[derive(Debug, Clone)]
pub struct Replayed {
    /// The requests.
    pub requests: Vec<Request>,
    /// Per system, its id and its answers (in request order).
    pub answers: Vec<(&'static str, Vec<Answer>)>,
}

impl Replayed {
    /// One summary line per system.
    pub fn summaries(&self) -> Vec<AnswerSummary> {
        self.answers.iter().map(|(id, a)| AnswerSummary::new(id, a)).collect()
    }
}

/// `e`, a recording's fault, naming the recording.
fn bad_recording(file: &Path, e: impl std::fmt::Display) -> StageError {
    StageError::Input(format!("{}: {e}", file.display()))
}

/// The frames of system `id` alone under `rec`'s commands, seeded with `seed`.
fn replay_one(world: &'static World, rec: &Recording, id: &str, seed: u64, file: &Path) -> StageResult<Vec<LiveFrame>> {
    let alone = Recording { systems: vec![id.to_string()], seed, ..rec.clone() };
    let frames = session::replay(world, &alone).map_err(|e| bad_recording(file, e))?;
    Ok(frames.into_iter().filter_map(|mut f| f.pop()).collect())
}

/// Runs the replay; returns the requests and every system's answers.
///
/// # Errors
/// [`StageError::Config`] for a bad `--hold` or `--resolution`; [`StageError::Input`]
/// naming the recording when it is not a recording, names an unknown system or label, has
/// commands out of frame order or past its end, or has no TRANSITION command; the
/// artifacts' own errors, naming them.
pub fn run(args: &Args) -> StageResult<Option<Replayed>> {
    if !((0.0..=MAX_HOLD_SECONDS).contains(&args.hold) && (0.0..=0.1).contains(&args.resolution)) {
        return Err(StageError::Config(format!(
            "need 0 <= --hold <= {MAX_HOLD_SECONDS} seconds and --resolution in [0, 0.1]"
        )));
    }
    if args.io.check {
        return Ok(None);
    }
    let file = args.io.recording.as_path();
    let rec = reprise_serve::record::read(file).map_err(StageError::Input)?;
    let provenance = args.io.provenance(args)?;
    let world = World::load(&args.io.world(), Tuning::default())?;
    // The recording's systems and start, checked as the session checked them.
    drop(Session::new(world, &rec.systems, &rec.start, rec.seed).map_err(|e| bad_recording(file, e))?);
    let asked = convert::asked(&rec);
    if asked.is_empty() {
        return Err(bad_recording(file, "the session has no TRANSITION command: nothing to measure"));
    }
    let label =
        |name: &str| world.label_index(name).ok_or_else(|| bad_recording(file, format!("unknown label `{name}`")));
    let start = label(&rec.start)?;
    let start_row = world.start_row(start).ok_or_else(|| bad_recording(file, "its start label has no start frame"))?;
    let hold = ((args.hold * world.fps).round() as usize).max(1);
    let windows: Vec<Window> = asked.iter().map(|a| a.window(hold)).collect();
    let resolution = curves::Resolution::relative(args.resolution, &world.labeled.frames.ranges());
    let writer = |p: &Path| {
        curves::Writer::create(p, world.fps, &world.controls, &provenance).with_resolution(resolution.clone())
    };
    // Only the first request's frames play from the start frame; the others' start columns
    // name their label A's start row (see the crate docs).
    let mut requests = Vec::with_capacity(asked.len());
    for a in &asked {
        let row = world.start_row(label(&a.from)?).unwrap_or(start_row);
        let l = &world.labeled;
        requests.push(Request {
            request: a.request,
            from: a.from.clone(),
            to: a.to.clone(),
            segment_id: l.segment_id[row],
            clip: l.frames.clip[row].clone(),
            frame: l.frames.frame[row],
        });
    }
    let targets = asked.iter().map(|a| label(&a.to)).collect::<StageResult<Vec<_>>>()?;
    let mut answered = Vec::new();
    for o in args.io.systems()? {
        let played = Played { world, start: start_row, frames: replay_one(world, &rec, o.id, rec.seed, file)? };
        let mut w = writer(o.curves);
        let mut answers = Vec::with_capacity(asked.len());
        for ((a, win), &to) in asked.iter().zip(&windows).zip(&targets) {
            answers.push(played.answer(a, win, to));
            w.push_script(&format!("r{}", a.request), played.curve(win))?;
        }
        w.finish()?;
        let rows: Vec<(i64, Answer)> = asked.iter().map(|a| a.request).zip(answers.iter().cloned()).collect();
        transitions::write_answers(o.answers, o.id, &rows, &provenance)?;
        drop(played);
        if let Some(path) = o.reseeded {
            let seed = rec.seed.wrapping_add(RESEED);
            let again = Played { world, start: start_row, frames: replay_one(world, &rec, o.id, seed, file)? };
            let mut w = writer(path);
            for (a, win) in asked.iter().zip(&windows) {
                w.push_script(&format!("r{}", a.request), again.curve(win))?;
            }
            w.finish()?;
        }
        answered.push((o.id, answers));
    }
    transitions::write_requests(&args.io.requests, &requests, &provenance)?;
    Ok(Some(Replayed { requests, answers: answered }))
}
