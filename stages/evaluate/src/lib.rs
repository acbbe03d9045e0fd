//! The evaluate stage: every system's answers to the transition benchmark, measured by
//! the same code on meshes evaluated through the rig, plus the model-quality measurements
//! of the earlier stages. Writes `metrics.parquet` (one row per system, metric and label
//! pair), `report.md` (which defines every metric) and the HTML page.
//!
//! The work is split as measuring ([`training`]: the reference values, once;
//! [`measure`]: one answered request of one system, one module per metric family),
//! aggregating ([`aggregate`]: one value per request, means and CIs over requests per pair,
//! shares, paired differences), concluding (`reprise_benchmark`: the verdicts, once) and
//! reporting ([`model`]: the report's content; [`report`] and `html` render it). The
//! systems and metrics are declared in `reprise_benchmark`: a new metric is one row there
//! plus its measurement and its line in [`aggregate::value`]; a new system one row there
//! plus its answers and curves among this stage's inputs.

pub mod aggregate;
#[cfg(test)]
mod browser;
mod charts;
mod encode;
mod figures;
mod html;
pub mod measure;
pub mod model;
mod player;
mod render;
pub mod report;
pub mod systems;
pub mod training;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use clap::Parser;
use rayon::prelude::*;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::transitions::{self, Request};
use reprise_artifact::{bridges, gplvm, motion_graph, pca, scales, Columns, Kind, Table};
use reprise_stagekit::rig::open_rig;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

pub use aggregate::Metric;
use aggregate::{exact, metric};
use measure::Measured;
pub use model::Context;
use systems::System;
use training::Training;

/// Kind of the metrics table.
pub const METRICS: Kind = Kind { name: "metrics", version: 4 };

reprise_stagekit::stage_io! {
    stage: "evaluate", bin: "reprise-evaluate",
    partition: Whole,
    derived: [("name", PipelineName), ("lock", LockFile)],
    inputs {
        /// Input: the labeled frames.
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the controls table (the rig).
        controls: required "controls.parquet",
        /// Input: the scales.
        scales: required "scales.parquet",
        /// Input: the transition requests.
        requests: required "transition_requests.parquet",
        /// Input: reprise's answers.
        reprise_answers: required "answers_reprise.parquet",
        /// Input: reprise's transition curves.
        reprise_curves: required "transitions_reprise.parquet",
        /// Input: reprise's transition curves under other seeds.
        reprise_reseeded: required "transitions_reprise_reseeded.parquet",
        /// Input: the paper's reprise's answers.
        reprise_paper_answers: required "answers_reprise_paper.parquet",
        /// Input: the paper's reprise's transition curves.
        reprise_paper_curves: required "transitions_reprise_paper.parquet",
        /// Input: the paper's reprise's transition curves under other seeds.
        reprise_paper_reseeded: required "transitions_reprise_paper_reseeded.parquet",
        /// Input (optional): the ablation's answers, the paper with `live-idle`.
        live_idle_answers: optional "answers_reprise_paper_live_idle.parquet",
        /// Input (optional): the ablation's curves, the paper with `live-idle`.
        live_idle_curves: optional "transitions_reprise_paper_live_idle.parquet",
        /// Input (optional): the ablation's answers, the paper with `landing-choice`.
        landing_choice_answers: optional "answers_reprise_paper_landing_choice.parquet",
        /// Input (optional): the ablation's curves, the paper with `landing-choice`.
        landing_choice_curves: optional "transitions_reprise_paper_landing_choice.parquet",
        /// Input (optional): the ablation's answers, the paper with `settle`.
        settle_answers: optional "answers_reprise_paper_settle.parquet",
        /// Input (optional): the ablation's curves, the paper with `settle`.
        settle_curves: optional "transitions_reprise_paper_settle.parquet",
        /// Input: the Motion Graphs baseline's answers.
        motion_graphs_answers: required "answers_motion_graphs.parquet",
        /// Input: the Motion Graphs baseline's transition curves.
        motion_graphs_curves: required "transitions_motion_graphs.parquet",
        /// Input: the Motion Graphs baseline's transition curves under other seeds.
        motion_graphs_reseeded: required "transitions_motion_graphs_reseeded.parquet",
        /// Input (optional): motion matching's answers (with `--mm-curves`).
        mm_answers: optional "answers_motion_matching.parquet",
        /// Input (optional): motion matching's curves.
        mm_curves: optional "transitions_motion_matching.parquet",
        /// Input (optional): the crossfade baseline's answers (with `--crossfade-curves`).
        crossfade_answers: optional "answers_crossfade.parquet",
        /// Input (optional): the crossfade baseline's curves.
        crossfade_curves: optional "transitions_crossfade.parquet",
        /// Input: the bridges.
        bridges: required "bridges.parquet",
        /// Input: the motion graph's nodes.
        mg_nodes: required "mg_nodes.parquet",
        /// Input: the motion graph's edges.
        mg_edges: required "mg_edges.parquet",
        /// Input: the GPLVM fit summaries (held-out errors).
        gplvm_fits: required "gplvm_fits.parquet",
        /// Input (optional): the GPLVM optimisation traces (the fit-trace figure).
        gplvm_trace: optional "gplvm_trace.parquet",
        /// Input: the PCA errors (the scaling ablation).
        pca_errors: required "pca_errors.parquet",
        /// Input: the GPLVM latents (the latent-space figures).
        latents: required "gplvm_latents.parquet",
        /// Input: the GPLVM models (bridge poses).
        gplvm_models: required "gplvm_models.parquet",
        /// Input: the PCA models (bridge poses).
        pca_models: required "pca_models.parquet",
        /// Input: synthesized curves (the filmstrip shows their first script).
        curves: required "curves.parquet",
    }
    outputs {
        /// Output: the metrics table.
        metrics: report "metrics.parquet",
        /// Output: the Markdown report.
        report: report "report.md",
        /// Output: the HTML report (self-contained).
        html: report "index.html",
    }
}

/// `reprise-evaluate`: metrics and the report.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-evaluate", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// The runner's lock file, read (if present) for per-stage times in the provenance.
    #[arg(long, value_name = "FILE")]
    pub lock: Option<PathBuf>,
    /// The report's title (the pipeline's name).
    #[arg(long, default_value = "reprise")]
    pub name: String,
    /// The blend length k (frames).
    #[arg(long, default_value_t = 12)]
    pub window: usize,
    /// Coverage horizon T, seconds.
    #[arg(long, default_value_t = 2.0)]
    pub coverage_seconds: f64,
    /// Latency horizon τ, seconds: `perceived_latency_s` counts an arrival later than τ,
    /// none, or no answer as τ (the restricted mean time to arrival).
    #[arg(long, default_value_t = 4.0)]
    pub latency_horizon: f64,
    /// Measure plausibility on every n-th frame after the request.
    #[arg(long, default_value_t = 3)]
    pub plausibility_stride: usize,
    /// Arrival: frames in a row whose nearest training pose (on the mesh) belongs to the
    /// target label.
    #[arg(long, default_value_t = 6)]
    pub arrival_frames: usize,
    /// Frames of the discontinuity window centred on the label switch (the same for every
    /// system).
    #[arg(long, default_value_t = 24)]
    pub discontinuity_window: usize,
    /// Success: no frame of the answer with a peak vertex speed above this many times the
    /// training data's 99th percentile (a pose jump).
    #[arg(long, default_value_t = 2.0)]
    pub jump_ratio: f64,
    /// Bound on the mesh values held for the plausibility references (training frames × 3 ×
    /// vertices × 2 sets; 4 bytes each).
    #[arg(long, default_value_t = 250_000_000)]
    pub mesh_reference_limit: usize,
}

impl Io {
    /// Every system's (id, answers, curves, reseeded curves) given on the command line.
    fn systems(&self) -> Vec<(&'static str, &Path, &Path, Option<&Path>)> {
        let mut v = vec![
            (
                "reprise",
                self.reprise_answers.as_path(),
                self.reprise_curves.as_path(),
                Some(self.reprise_reseeded.as_path()),
            ),
            (
                "reprise-paper",
                &self.reprise_paper_answers,
                &self.reprise_paper_curves,
                Some(self.reprise_paper_reseeded.as_path()),
            ),
            (
                "motion-graphs",
                &self.motion_graphs_answers,
                &self.motion_graphs_curves,
                Some(self.motion_graphs_reseeded.as_path()),
            ),
        ];
        if let (Some(a), Some(c)) = (&self.mm_answers, &self.mm_curves) {
            v.push(("motion-matching", a, c, None));
        }
        if let (Some(a), Some(c)) = (&self.crossfade_answers, &self.crossfade_curves) {
            v.push(("crossfade", a, c, None));
        }
        v
    }

    /// The ablation's systems given (id, answers, curves), in
    /// [`reprise_benchmark::systems::ABLATION`]'s order.
    fn ablation(&self) -> Vec<(&'static str, &Path, &Path)> {
        let given = [
            (&self.live_idle_answers, &self.live_idle_curves),
            (&self.landing_choice_answers, &self.landing_choice_curves),
            (&self.settle_answers, &self.settle_curves),
        ];
        reprise_benchmark::systems::ABLATION
            .iter()
            .zip(given)
            .filter_map(|(def, files)| match files {
                (Some(a), Some(c)) => Some((def.id, a.as_path(), c.as_path())),
                _ => None,
            })
            .collect()
    }
}

/// Runs the stage; returns the metric rows.
pub fn run(args: &Args) -> StageResult<Option<Vec<Metric>>> {
    if args.window < 2
        || args.coverage_seconds.is_nan()
        || args.coverage_seconds < 0.0
        || args.latency_horizon.is_nan()
        || args.latency_horizon <= 0.0
        || args.plausibility_stride == 0
        || args.arrival_frames == 0
        || args.discontinuity_window < 4
    {
        return Err(StageError::Config(
            "need --window >= 2, --coverage-seconds >= 0, --latency-horizon > 0, --plausibility-stride >= 1, \
             --arrival-frames >= 1, \
             --discontinuity-window >= 4"
                .into(),
        ));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let rig = open_rig(&Controls::read(&args.io.controls)?, &labeled.frames.controls)?;
    let reqs = transitions::read_requests(&args.io.requests)?;
    let controls = &labeled.frames.controls;
    let mut systems = args
        .io
        .systems()
        .into_iter()
        .map(|(id, a, c, r)| System::load(id, a, c, r, &reqs))
        .collect::<StageResult<Vec<_>>>()?;
    let scale_rows = scales::read(&args.io.scales)?;
    let weight = scales::mean_weights(&scale_rows, &labeled.frames.controls);
    let (pca_controls, pcas) = pca::read_models(&args.io.pca_models)?;
    if pca_controls != labeled.frames.controls {
        return Err(StageError::Input(format!(
            "{} and {} list different controls; rerun pca",
            args.io.pca_models.display(),
            args.io.labeled_frames.display()
        )));
    }
    let maps = pcas
        .iter()
        .filter(|p| p.variant == pca::SCALED)
        .map(|p| Ok((p.label.clone(), reprise_label_models::rig_map(p, &pca_controls, &scale_rows, &args.io.scales)?)))
        .collect::<StageResult<Vec<_>>>()?;
    let training = Training::measure(&rig, &labeled, weight, &maps, args.mesh_reference_limit)?;
    let labels = training.labels.clone();
    let pairs = asked_pairs(&reqs);
    let settings = measure::Settings {
        k: args.window,
        stride: args.plausibility_stride,
        arrival_frames: args.arrival_frames,
        discontinuity_window: args.discontinuity_window,
    };
    let links = bridges::read(&args.io.bridges)?;
    let on_bridge = starts_on_bridges(&reqs, &links, &gplvm::read_latents(&args.io.latents)?);
    let rules = aggregate::Rules {
        on_bridge: &on_bridge,
        requests: &reqs,
        pairs: &pairs,
        jump_ratio: args.jump_ratio,
        horizon: args.coverage_seconds,
        latency_horizon: args.latency_horizon,
    };

    let mut out: Vec<Metric> = Vec::new();
    let (mut measured, mut varieties, mut deterministic) = (Vec::new(), Vec::new(), Vec::new());
    for system in &systems {
        let (per, variety) = measure_system(&rig, &training, settings, &reqs, system, controls)?;
        out.extend(aggregate::system_rows(system, &per, rules));
        match variety {
            Some(v) => varieties.push(metric(&system.id, "variety", "all", "all", &v, "mesh units", 7)),
            None => deterministic.push(system.id.clone()),
        }
        measured.push(per);
    }
    // The ablation: measured by the same code on the same requests, shown in its own table.
    let mut ablation = Vec::new();
    for (id, a, c) in args.io.ablation() {
        let system = System::load(id, a, c, None, &reqs)?;
        let (per, _) = measure_system(&rig, &training, settings, &reqs, &system, controls)?;
        out.extend(aggregate::system_rows(&system, &per, rules));
        ablation.push((system.id.clone(), system.shown.clone()));
    }
    for (i, a) in systems.iter().enumerate() {
        for (b, theirs) in systems.iter().zip(&measured).skip(i + 1) {
            out.extend(aggregate::paired((&a.id, &measured[i]), (&b.id, theirs), &pairs, args.latency_horizon));
        }
    }
    out.extend(varieties);
    out.extend(aggregate::start_rows(&reqs, &pairs, &on_bridge));
    let mg = motion_graph::read_graph(&args.io.mg_nodes, &args.io.mg_edges)?;
    mg.check_window(args.window, "--window")?;
    mg.check_frames(&labeled, &args.io.labeled_frames)?;
    reprise_artifact::provenance::check_made_from(&args.io.mg_nodes, &provenance)?;
    let (nodes, edges) = (&mg.nodes, &mg.edges);
    out.extend(transition_points(&links, &args.io.mg_edges, nodes, edges, &labels)?);
    out.extend(model_quality(&args.io.gplvm_fits, &args.io.pca_errors)?);

    let shown: Vec<(String, String)> = systems.iter().map(|s| (s.id.clone(), s.shown.clone())).collect();
    let ids: Vec<&str> = systems.iter().map(|s| s.id.as_str()).collect();
    let conclusions = reprise_benchmark::Conclusions::new(&out, &ids);
    let ctx = model::Context {
        name: &args.name,
        labels: &labels,
        systems: &shown,
        training: &training,
        window: args.window,
        coverage_seconds: args.coverage_seconds,
        latency_horizon: args.latency_horizon,
        jump_ratio: args.jump_ratio,
        stride: args.plausibility_stride,
        conclusions: &conclusions,
        arrival_frames: args.arrival_frames,
        discontinuity_window: args.discontinuity_window,
        graph_kept: (nodes.in_scc.iter().filter(|v| **v).count(), nodes.frame.len()),
        deterministic,
        refusals: systems.iter().map(|s| s.refusals(&reqs)).collect(),
        ablation: &ablation,
    };
    let md = report::markdown(&out, &ctx);
    let speed: Vec<(String, Vec<i64>, Vec<f64>)> =
        systems.iter().zip(&measured).map(|(s, per)| (s.shown.clone(), offsets(), mean_speed(per))).collect();
    // The player shows a few requests of every system: only their frames are read whole.
    let arrivals: Vec<std::collections::BTreeMap<i64, f64>> = measured
        .iter()
        .map(|per| per.iter().filter_map(|m| Some((m.request, m.perceived_latency?))).collect())
        .collect();
    let shown: HashSet<i64> = player::select(&reqs, &systems, &arrivals)
        .iter()
        .flat_map(|(_, rs)| rs.iter().map(|(r, _)| r.request))
        .collect();
    for s in &mut systems {
        s.keep_played(&shown, controls)?;
    }
    let camera_mesh = reprise_stagekit::rig::meshes(&rig, &[labeled.frames.row(0).to_vec()])?;
    let inputs = figures::Inputs {
        args,
        rig: &rig,
        training: &training,
        labeled: &labeled,
        requests: &reqs,
        systems: &systems,
        measured: &measured,
        arrivals: &arrivals,
        links: &links,
        labels: &labels,
        camera_mesh: &camera_mesh,
        markdown: &md,
        speed,
    };
    let page = figures::figures(inputs, &provenance)?;
    let html = html::page(&page, &out, &ctx);
    write_metrics(&args.io.metrics, &out, &provenance)?;
    // What wrote the pages, so a rerun knows them as its own without its lock.
    let marker = reprise_artifact::provenance::output_marker(WIRING.stage, provenance.pipeline.as_deref());
    let md = format!("{md}\n<!-- {marker} -->\n");
    let html = html.replacen("<head>", &format!("<head><meta name='generator' content='{marker}'>"), 1);
    for (path, text) in [(&args.io.report, md.as_str()), (&args.io.html, html.as_str())] {
        reprise_artifact::table::write_atomic(path, |f| {
            use std::io::Write as _;
            f.write_all(text.as_bytes()).map_err(|e| reprise_artifact::ArtifactError::io(path, e))
        })?;
    }
    Ok(Some(out))
}

/// Each ordered pair of labels the requests ask, once, in the order first asked: the
/// benchmark's requests come pair by pair, a replayed live session's (`reprise replay`) in
/// the order the session asked them, a pair asked again later.
fn asked_pairs(reqs: &[Request]) -> Vec<(String, String)> {
    let mut seen = HashSet::new();
    reqs.iter().map(|r| (r.from.clone(), r.to.clone())).filter(|p| seen.insert(p.clone())).collect()
}

/// The requests whose start frame is the first point of a bridge of their pair: the
/// start's latent row (by segment and frame among label A's latents, in the model's point
/// order) is a bridge's `from_point`.
fn starts_on_bridges(reqs: &[Request], links: &[bridges::Bridge], latents: &gplvm::Latents) -> HashSet<i64> {
    let mut point: HashMap<(&str, i64, i64), i64> = HashMap::new();
    let mut next: HashMap<&str, i64> = HashMap::new();
    for r in 0..latents.label.len() {
        let l = latents.label[r].as_str();
        let i = next.entry(l).or_default();
        point.insert((l, latents.segment_id[r], latents.frame[r]), *i);
        *i += 1;
    }
    let starts: HashSet<(&str, &str, i64)> =
        links.iter().map(|b| (b.from.as_str(), b.to.as_str(), b.from_point)).collect();
    reqs.iter()
        .filter(|r| {
            point
                .get(&(r.from.as_str(), r.segment_id, r.frame))
                .is_some_and(|p| starts.contains(&(r.from.as_str(), r.to.as_str(), *p)))
        })
        .map(|r| r.request)
        .collect()
}

/// Every answered request of one system measured, and (where it has seeds) its variety
/// per request it played under both: one pass over its curves, a chunk of requests at a
/// time in parallel (the next chunk read meanwhile), each answer's meshes evaluated once
/// for both measures.
fn measure_system(
    rig: training::RigRef<'_>,
    training: &Training,
    settings: measure::Settings,
    reqs: &[Request],
    system: &System,
    controls: &[String],
) -> StageResult<(Vec<Measured>, Option<Vec<f64>>)> {
    let mut reader = ChunkReader {
        by_id: reqs.iter().map(|r| (r.request, r)).collect(),
        first: system.stream(controls)?,
        again: system.stream_reseeded(controls)?,
        waiting: std::collections::BTreeMap::new(),
        seen: HashSet::new(),
        system,
    };
    let has_seeds = reader.again.is_some();
    let (mut measured, mut variety) = (Vec::new(), Vec::new());
    let bar = reprise_stagekit::progress(reqs.len() as u64, &format!("measure {}", system.id));
    let measure_one = |(r, p, b): Todo<'_>| -> StageResult<(Option<Measured>, Option<f64>)> {
        if r.is_some() {
            bar.inc(1);
        }
        let answer = r.and_then(|r| Some((r, system.answer(r).filter(|a| a.latency.is_some())?)));
        if answer.is_none() && b.is_none() {
            return Ok((None, None));
        }
        let m = reprise_stagekit::rig::meshes(rig, &p.controls)?;
        let measured = answer.and_then(|(r, a)| measure::measure_meshed(training, settings, r, a, &p, &m));
        let v = b.map(|b| measure::variety::between(&m, rig, &b)).transpose()?;
        Ok((measured, v))
    };
    let mut chunk = reader.next_chunk()?;
    while !chunk.is_empty() {
        let (next, results) =
            rayon::join(|| reader.next_chunk(), || chunk.into_par_iter().map(measure_one).collect::<Vec<_>>());
        for result in results {
            let (m, v) = result?;
            measured.extend(m);
            variety.extend(v.filter(|v| v.is_finite()));
        }
        chunk = next?;
    }
    bar.finish_and_clear();
    // An answered request with no frames at all.
    if let Some(r) = reqs.iter().find(|r| system.answered(r) && !reader.seen.contains(&r.request)) {
        system.check_reach(r, 0)?;
    }
    Ok((measured, has_seeds.then_some(variety)))
}

/// One script to measure: its request (`None`: not one of the benchmark's), its frames,
/// and its frames under the other seed.
type Todo<'r> = (Option<&'r Request>, systems::Played, Option<systems::Played>);

/// A system's curves (and reseeded curves) read a chunk of requests at a time.
struct ChunkReader<'a> {
    by_id: HashMap<i64, &'a Request>,
    first: systems::PlayedStream,
    again: Option<systems::PlayedStream>,
    /// Reseeded frames read ahead of their request.
    waiting: std::collections::BTreeMap<i64, systems::Played>,
    /// The requests whose frames were read.
    seen: HashSet<i64>,
    system: &'a System,
}

impl<'a> ChunkReader<'a> {
    /// The next [`reprise_stagekit::CHUNK`] scripts (empty: the end), each checked to
    /// reach as far as its answer says.
    fn next_chunk(&mut self) -> StageResult<Vec<Todo<'a>>> {
        let chunk: Vec<(i64, systems::Played)> =
            self.first.by_ref().take(reprise_stagekit::CHUNK).collect::<StageResult<_>>()?;
        let Some(&(last, _)) = chunk.last() else { return Ok(vec![]) };
        // The other seed's frames of the same requests (both files are in request order).
        if let Some(again) = self.again.as_mut() {
            while self.waiting.last_key_value().is_none_or(|(id, _)| *id < last) {
                let Some((id, p)) = again.next().transpose()? else { break };
                self.waiting.insert(id, p);
            }
        }
        let mut todo = Vec::with_capacity(chunk.len());
        for (id, p) in chunk {
            let r = self.by_id.get(&id).copied();
            if let Some(r) = r {
                self.system.check_reach(r, p.controls.len())?;
                self.seen.insert(r.request);
            }
            todo.push((r, p, self.waiting.remove(&id)));
        }
        Ok(todo)
    }
}

fn offsets() -> Vec<i64> {
    (-measure::SPEED_BEFORE..=measure::SPEED_AFTER).collect()
}

/// The mean peak-speed trace over answered requests (NaN where no answer has the frame).
fn mean_speed(per: &[Measured]) -> Vec<f64> {
    (0..offsets().len())
        .map(|i| {
            let v: Vec<f64> = per.iter().filter_map(|p| p.speed.get(i).copied()).filter(|v| v.is_finite()).collect();
            if v.is_empty() {
                f64::NAN
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        })
        .collect()
}

/// Bridges (reprise) and pruned-graph transition edges (the baseline) per ordered pair —
/// counts of the systems' tables, not measurements of their answers.
fn transition_points(
    links: &[bridges::Bridge],
    edges_path: &Path,
    nodes: &motion_graph::Nodes,
    edges: &[motion_graph::Edge],
    labels: &[String],
) -> StageResult<Vec<Metric>> {
    let label_of = |i: i64| -> StageResult<&str> {
        usize::try_from(i).ok().and_then(|i| nodes.label.get(i)).map(String::as_str).ok_or_else(|| {
            StageError::Input(format!(
                "{}: edge endpoint {i} is not one of the {} nodes; rerun motion-graph",
                edges_path.display(),
                nodes.label.len()
            ))
        })
    };
    let mut mg: std::collections::HashMap<(&str, &str), usize> = std::collections::HashMap::new();
    for e in edges.iter().filter(|e| e.kind == "transition" && e.in_scc) {
        *mg.entry((label_of(e.from)?, label_of(e.to)?)).or_default() += 1;
    }
    let mut out = Vec::new();
    for a in labels {
        for b in labels.iter().filter(|b| *b != a) {
            let n = links.iter().filter(|l| &l.from == a && &l.to == b).count();
            out.push(exact("reprise", "transition_points", a, b, n as f64, 1, "count"));
            let m = mg.get(&(a.as_str(), b.as_str())).copied().unwrap_or(0);
            out.push(exact("motion-graphs", "transition_points", a, b, m as f64, 1, "count"));
        }
    }
    Ok(out)
}

/// The model checks of the gplvm stage (held-out errors of the GPLVM, PCA-q and PCA-d;
/// the generative check against interpolation) and the scaling ablation of the pca stage.
fn model_quality(fits_path: &Path, errors_path: &Path) -> StageResult<Vec<Metric>> {
    let mut out = Vec::new();
    for f in gplvm::read_fits(fits_path)? {
        let checks = [
            ("heldout_mesh_rmse", f.heldout_frames, "gplvm", f.heldout_gplvm_mesh_rmse),
            ("heldout_mesh_rmse", f.heldout_frames, "pca-q", f.heldout_pca_q_mesh_rmse),
            ("heldout_mesh_rmse", f.heldout_frames, "pca-d", f.heldout_pca_d_mesh_rmse),
            ("generative_mesh_rmse", f.generative_frames, "gplvm", f.generative_gplvm_mesh_rmse),
            ("generative_mesh_rmse", f.generative_frames, "interpolation", f.generative_interp_mesh_rmse),
            ("generative_mesh_rmse", f.generative_frames, "interpolation-d", f.generative_interp_d_mesh_rmse),
        ];
        for (metric, frames, variant, v) in checks {
            if let Some(v) = v {
                out.push(exact(variant, metric, &f.label, "", v, frames.max(0) as usize, "mesh units"));
            }
        }
    }
    let errs = Table::read(errors_path, reprise_artifact::pca::PCA_ERRORS)?;
    let (el, ev, ed, em) =
        (errs.strings("label")?, errs.strings("variant")?, errs.i64("d")?, errs.f64_opt("mesh_rmse")?);
    for r in 0..errs.rows() {
        if let (3, Some(m)) = (ed[r], em[r]) {
            out.push(exact(&ev[r], "ablation_mesh_rmse", &el[r], "", m, 1, "mesh units"));
        }
    }
    Ok(out)
}

/// Reads a metrics table (`metrics.parquet`) as written by this stage: a null `value` (a
/// metric with no observation) reads as NaN.
pub fn read_metrics(path: &Path) -> StageResult<Vec<Metric>> {
    let t = Table::read(path, METRICS)?;
    let (system, metric, from, to) = (t.strings("system")?, t.strings("metric")?, t.strings("from")?, t.strings("to")?);
    let (value, lo, hi, n, unit) =
        (t.f64_opt("value")?, t.f64_opt("ci_low")?, t.f64_opt("ci_high")?, t.i64("n")?, t.strings("unit")?);
    Ok((0..t.rows())
        .map(|r| Metric {
            system: system[r].clone(),
            metric: metric[r].clone(),
            from: from[r].clone(),
            to: to[r].clone(),
            value: value[r].unwrap_or(f64::NAN),
            ci_low: lo[r],
            ci_high: hi[r],
            n: n[r],
            unit: unit[r].clone(),
        })
        .collect())
}

fn write_metrics(path: &Path, m: &[Metric], provenance: &reprise_artifact::Provenance) -> StageResult<()> {
    let s = |f: fn(&Metric) -> &str| m.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .str("system", &s(|m| m.system.as_str()))
        .str("metric", &s(|m| m.metric.as_str()))
        .str("from", &s(|m| m.from.as_str()))
        .str("to", &s(|m| m.to.as_str()))
        .f64_opt("value", m.iter().map(|m| Some(m.value).filter(|v| v.is_finite())).collect())
        .f64_opt("ci_low", m.iter().map(|m| m.ci_low).collect())
        .f64_opt("ci_high", m.iter().map(|m| m.ci_high).collect())
        .i64("n", m.iter().map(|m| m.n).collect())
        .str("unit", &s(|m| m.unit.as_str()));
    reprise_artifact::table::write(path, METRICS, cols, provenance, &[])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The metrics table comes back as written; a value without observations (NaN) is
    /// stored as null, never as a non-finite number, and reads back as NaN.
    #[test]
    fn metrics_round_trip_without_non_finite_values() {
        let dir = std::env::temp_dir().join(format!("reprise-metrics-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("metrics.parquet");
        let rows = vec![
            aggregate::metric("reprise", "perceived_latency_s", "all", "all", &[0.5, 0.7], "s", 1),
            aggregate::metric("crossfade", "latency_routed_s", "all", "all", &[], "s", 1),
        ];
        let provenance = reprise_artifact::Provenance::new("evaluate", "0", serde_json::json!({}));
        write_metrics(&path, &rows, &provenance).unwrap();
        let back = read_metrics(&path).unwrap();
        assert_eq!(back[0], rows[0]);
        assert!(back[1].value.is_nan() && back[1].n == 0 && back[1].ci_low.is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Every pair asked is listed once, where it is first asked, whether its requests come
    /// together (the benchmark) or apart (a replayed session).
    #[test]
    fn pairs_are_listed_once_in_the_order_asked() {
        let r = |id: i64, from: &str, to: &str| Request {
            request: id,
            from: from.into(),
            to: to.into(),
            segment_id: 0,
            clip: "c".into(),
            frame: 0,
        };
        let pair = |a: &str, b: &str| (a.to_string(), b.to_string());
        let apart = [r(0, "a", "b"), r(1, "b", "c"), r(2, "c", "a"), r(3, "a", "b"), r(4, "b", "c")];
        assert_eq!(asked_pairs(&apart), [pair("a", "b"), pair("b", "c"), pair("c", "a")]);
        let together = [r(0, "a", "b"), r(1, "a", "b"), r(2, "b", "a")];
        assert_eq!(asked_pairs(&together), [pair("a", "b"), pair("b", "a")]);
    }

    /// A start is on a bridge point when its frame is the `from_point` (the label's latent
    /// row, counted within the label) of a bridge of the same ordered pair.
    #[test]
    fn starts_on_bridge_points_are_found_by_pair_and_row() {
        // Label `a` has rows (segment 0, frames 0–2) then `b` (segment 1, frame 0), then
        // `a` again (segment 2, frame 5): a's rows are 0, 1, 2, 3.
        let latents = gplvm::Latents {
            label: ["a", "a", "a", "b", "a"].map(String::from).to_vec(),
            segment_id: vec![0, 0, 0, 1, 2],
            clip: vec!["c".into(); 5],
            frame: vec![0, 1, 2, 0, 5],
            time: vec![0.0; 5],
            x: vec![vec![0.0]; 5],
        };
        let bridge = |from: &str, to: &str, from_point: i64| bridges::Bridge {
            from: from.into(),
            to: to.into(),
            from_point,
            x1: vec![0.0],
            x2: vec![0.0],
            rig_distance: 0.0,
            mesh_distance: None,
            rank: 1,
        };
        let links = vec![bridge("a", "b", 1), bridge("a", "b", 3), bridge("a", "c", 2)];
        let request = |id: i64, to: &str, segment_id: i64, frame: i64| Request {
            request: id,
            from: "a".into(),
            to: to.into(),
            segment_id,
            clip: "c".into(),
            frame,
        };
        let reqs = vec![request(0, "b", 0, 1), request(1, "b", 0, 2), request(2, "c", 0, 1), request(3, "b", 2, 5)];
        let on: Vec<i64> = {
            let mut v: Vec<i64> = starts_on_bridges(&reqs, &links, &latents).into_iter().collect();
            v.sort_unstable();
            v
        };
        assert_eq!(on, vec![0, 3]);
    }
}
