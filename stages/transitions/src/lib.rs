//! The transition benchmark. For every ordered pair of labels (A, B), `per_pair` start
//! frames of A are drawn (seeded); each request "from this frame, reach B" is answered
//!
//! - by **reprise**: the script start = the frame, IDLE `hold` seconds, TRANSITION to B,
//!   IDLE `hold` seconds, run by the synthesis engine;
//! - by the **baseline**: from the frame's node, a near-fewest-frames path in the pruned
//!   motion graph to any frame of B (within `path_slack` of the fewest, chosen under the
//!   seed — see `Graph::near_shortest_to`), played frame by frame; a transition edge
//!   $A_i \to B_{j+1}$ plays the $k$ blended frames $\alpha(p)p^A_{i+p} + (1-\alpha(p))p^B_{j-k+1+p}$
//!   (rig space: the blend of scaled controls, unscaled, is this blend of controls), then
//!   `hold` seconds more of B where its motion goes on. A start frame outside the largest
//!   strongly connected component has no answer.
//!
//! Both systems also answer every request once more under another seed (`*_reseeded`),
//! for the variety metric. Each system writes its answers (`transition_answers`) and its
//! curves (scripts `r<id>`); a frame's `model` is the label being played (for blended
//! frames, the label blended into). Latency: frames from the request to the
//! first frame of B — for reprise from the end of its hold (the TRANSITION command), for
//! the baseline from its start frame; the hold before the request counts for no one.

use clap::Parser;
use rand::{Rng, SeedableRng};
use reprise_artifact::curves;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::motion_graph;
use reprise_artifact::transitions::{self, Answer, Request};

use reprise_model_library::LibraryParts;
use reprise_stagekit::{StageError, StageResult};
use reprise_synth_engine::engine::{self, Settings};
use reprise_synth_engine::method::Method;
use reprise_synth_engine::script::{Command, Script, Start};
use reprise_transition_graph::{play_path, Graph, PathFrame};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "transitions", bin: "reprise-transitions",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the GPLVM models.
        gplvm_models: required "gplvm_models.parquet",
        /// Input: the GPLVM latents (which training frame each latent point is).
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
    }
    outputs {
        /// Output: the requests.
        requests: artifact "transition_requests.parquet",
        /// Output: reprise's answers.
        reprise_answers: artifact "answers_reprise.parquet",
        /// Output: reprise's curves.
        reprise_curves: artifact "transitions_reprise.parquet",
        /// Output: reprise's curves for the same requests under other seeds (for variety).
        reprise_reseeded: artifact "transitions_reprise_reseeded.parquet",
        /// Output: the paper's reprise's answers.
        reprise_paper_answers: artifact "answers_reprise_paper.parquet",
        /// Output: the paper's reprise's curves.
        reprise_paper_curves: artifact "transitions_reprise_paper.parquet",
        /// Output: the paper's reprise's curves under other seeds.
        reprise_paper_reseeded: artifact "transitions_reprise_paper_reseeded.parquet",
        /// Output: the ablation's answers, the paper with `live-idle`.
        live_idle_answers: artifact "answers_reprise_paper_live_idle.parquet",
        /// Output: the ablation's curves, the paper with `live-idle`.
        live_idle_curves: artifact "transitions_reprise_paper_live_idle.parquet",
        /// Output: the ablation's answers, the paper with `landing-choice`.
        landing_choice_answers: artifact "answers_reprise_paper_landing_choice.parquet",
        /// Output: the ablation's curves, the paper with `landing-choice`.
        landing_choice_curves: artifact "transitions_reprise_paper_landing_choice.parquet",
        /// Output: the ablation's answers, the paper with `settle`.
        settle_answers: artifact "answers_reprise_paper_settle.parquet",
        /// Output: the ablation's curves, the paper with `settle`.
        settle_curves: artifact "transitions_reprise_paper_settle.parquet",
        /// Output: the baseline's answers.
        motion_graphs_answers: artifact "answers_motion_graphs.parquet",
        /// Output: the baseline's curves.
        motion_graphs_curves: artifact "transitions_motion_graphs.parquet",
        /// Output: the baseline's curves under other seeds (another near-shortest path).
        motion_graphs_reseeded: artifact "transitions_motion_graphs_reseeded.parquet",
    }
}

/// `reprise-transitions`: the transition benchmark.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-transitions", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Requests per ordered pair of labels.
    #[arg(long, default_value_t = 20)]
    pub per_pair: usize,
    /// At most this many requests in all: with many labels, fewer per pair; when even one
    /// per pair would pass it, one each for this many pairs sampled evenly over the labels
    /// (the stage says when it lowers `per_pair` or samples pairs).
    #[arg(long, default_value_t = 1200)]
    pub max_requests: usize,
    /// Seed of the start frames (and of reprise's random force, + request id).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seconds played before and after the transition.
    #[arg(long, default_value_t = 0.5)]
    pub hold: f64,
    /// The baseline's path choice: any path at most (1 + slack) × the fewest frames, chosen
    /// under the seed (0: always the shortest, and no variety).
    #[arg(long, default_value_t = 0.1)]
    pub path_slack: f64,
    /// The motion graph's blend length k (frames; as its window).
    #[arg(long, default_value_t = 12)]
    pub window: usize,
    /// Controls of the answers' curves are stored to this fraction of their range in the
    /// training frames (a power-of-two grid; 0: exactly).
    #[arg(long, default_value_t = reprise_artifact::curves::BENCHMARK_RESOLUTION)]
    pub resolution: f64,
}

/// One played frame: the label that produced it, its controls, its latent point (reprise's
/// particle; empty for the baseline) and the script command in progress.
#[derive(Debug, Clone)]
struct PlayedFrame {
    label: String,
    controls: Vec<f64>,
    x: Vec<f64>,
    command: i64,
}

impl PlayedFrame {
    /// A baseline frame: no latent point, command 0.
    fn clip(label: &str, controls: Vec<f64>) -> Self {
        Self { label: label.to_string(), controls, x: vec![], command: 0 }
    }
}

/// One answer's frames.
type Played = Vec<PlayedFrame>;

/// The baseline's graph and what playing it needs.
struct Baseline<'a> {
    g: &'a Graph,
    alive: &'a [bool],
    edges: &'a [motion_graph::Edge],
    labeled: &'a LabeledFrames,
    k: usize,
    hold: usize,
    slack: f64,
}

/// One request's answers: the request, and per system (in [`Io::systems`]' order) its answer.
struct Answers {
    request: Request,
    systems: Vec<Reply>,
}

/// One system's answer, its frames under the request's seed and, for a system with
/// reseeded curves, under the reseeded one.
type Reply = (Answer, Result<Played, String>, Option<Result<Played, String>>);

/// What the stage answered: the systems' ids and, per request, each system's answer (in
/// the same order).
#[derive(Debug, Clone)]
pub struct Answered {
    /// System ids.
    pub systems: Vec<&'static str>,
    /// Per request, each system's answer.
    pub rows: Vec<(Request, Vec<Answer>)>,
}

impl Answered {
    /// One [`reprise_stagekit::AnswerSummary`] per system.
    pub fn summaries(&self) -> Vec<reprise_stagekit::AnswerSummary> {
        (self.systems.iter().enumerate())
            .map(|(s, id)| reprise_stagekit::AnswerSummary::new(id, self.rows.iter().map(|(_, a)| &a[s])))
            .collect()
    }
}

/// How one system of this stage answers.
#[derive(Debug, Clone, Copy)]
enum Player {
    /// The synthesis engine under a method.
    Reprise(Method),
    /// The motion graph.
    MotionGraphs,
}

/// One system this stage answers with: its id, how it plays, and its files (answers,
/// curves, and the reseeded curves for a system measured for variety).
struct Output<'a> {
    id: &'static str,
    player: Player,
    answers: &'a std::path::Path,
    curves: &'a std::path::Path,
    reseeded: Option<&'a std::path::Path>,
}

impl Io {
    /// The systems, in the order of [`Answered`]: reprise (tuned), the paper's reprise,
    /// Motion Graphs, then the ablation (the paper with each improvement alone, in
    /// [`Method::IMPROVEMENTS`]' order, ids as `reprise_benchmark::systems::ABLATION`).
    fn systems(&self) -> Vec<Output<'_>> {
        let paper = Method::PAPER;
        let mut v = vec![
            Output {
                id: "reprise",
                player: Player::Reprise(Method::TUNED),
                answers: &self.reprise_answers,
                curves: &self.reprise_curves,
                reseeded: Some(&self.reprise_reseeded),
            },
            Output {
                id: "reprise-paper",
                player: Player::Reprise(paper),
                answers: &self.reprise_paper_answers,
                curves: &self.reprise_paper_curves,
                reseeded: Some(&self.reprise_paper_reseeded),
            },
            Output {
                id: "motion-graphs",
                player: Player::MotionGraphs,
                answers: &self.motion_graphs_answers,
                curves: &self.motion_graphs_curves,
                reseeded: Some(&self.motion_graphs_reseeded),
            },
        ];
        let files = [
            (&self.live_idle_answers, &self.live_idle_curves),
            (&self.landing_choice_answers, &self.landing_choice_curves),
            (&self.settle_answers, &self.settle_curves),
        ];
        let ablation = reprise_benchmark::systems::ABLATION.iter().zip(Method::IMPROVEMENTS).zip(files);
        v.extend(ablation.map(|((def, improvement), (answers, curves))| Output {
            id: def.id,
            player: Player::Reprise((improvement.apply)(paper)),
            answers,
            curves,
            reseeded: None,
        }));
        v
    }
}

/// The seed offset of the repeated runs (the benchmark's, shared with the replay of live sessions).
pub use reprise_benchmark::systems::RESEED;

impl Baseline<'_> {
    fn answer(&self, start: usize, to: &str, seed: u64) -> Result<Played, String> {
        let Baseline { g, alive, edges, labeled, k, hold, slack } = *self;
        let row = |r: usize| labeled.frames.row(r).to_vec();
        let mut out: Played = vec![PlayedFrame::clip(&labeled.label[start], row(start))];
        // A start the pruning dropped plays forward along its clip into the kept component
        // (those frames count toward the latency); one that never gets there has no answer.
        let mut at = start;
        while !alive[at] {
            let Some(&(w, _, _)) = g.adj[at].iter().find(|&&(_, _, id)| edges[id].kind == "next") else {
                return Err(
                    "the start frame's clip never enters the motion graph's largest strongly connected component"
                        .into(),
                );
            };
            out.push(PlayedFrame::clip(&labeled.label[w], row(w)));
            at = w;
        }
        let (_, path) = g
            .near_shortest_to(at, alive, |v| labeled.label[v] == to, slack, seed)
            .ok_or_else(|| format!("no path to `{to}` in the motion graph"))?;
        // Frames walked into the component are still queued: a transition from the last
        // of them replaces it, one from the start frame (shown) does not.
        let mut queue: Vec<PathFrame> = Vec::new();
        if out.len() > 1 {
            out.pop();
            queue.push(PathFrame::Node(at));
        }
        play_path(
            &mut queue,
            &path,
            |e| (edges[e].from as usize, edges[e].to as usize, edges[e].kind == "transition"),
            k,
        );
        for f in &queue {
            let controls = match *f {
                PathFrame::Node(v) => row(v),
                PathFrame::Blend { a, b, weight, .. } => {
                    row(a).iter().zip(row(b)).map(|(x, y)| weight * x + (1.0 - weight) * y).collect()
                }
            };
            out.push(PlayedFrame::clip(&labeled.label[f.node()], controls));
        }
        at = queue.last().map_or(at, PathFrame::node);
        // Play on in B while its motion continues.
        for _ in 0..hold {
            match g.adj[at].iter().find(|&&(w, _, id)| edges[id].kind == "next" && alive[w]) {
                Some(&(w, _, _)) => {
                    out.push(PlayedFrame::clip(&labeled.label[w], row(w)));
                    at = w;
                }
                None => break,
            }
        }
        Ok(out)
    }
}

/// Requests per ordered pair of `labels` labels: `wanted`, or fewer so that all pairs
/// together stay within `budget` — but at least one per pair.
fn requests_per_pair(wanted: usize, budget: usize, labels: usize) -> usize {
    let pairs = labels * labels.saturating_sub(1);
    wanted.min((budget / pairs.max(1)).max(1))
}

/// The ordered label pairs $(a, b)$ (indices into `labels` labels) that get requests, in
/// `(a, b)` order. Every pair when one request each fits `budget`; otherwise `budget`
/// pairs sampled in rounds: round $d \in \{1, \dots, L-1\}$ pairs every label $i$ with
/// $(i + d) \bmod L$, the rounds taken in an order drawn from `seed`, the last one cut to
/// a seeded choice of its pairs. Each label is thus asked to leave, and to be reached,
/// equally often (within one) — a stated sample, not a cut by label order.
fn request_pairs(labels: usize, budget: usize, seed: u64) -> Vec<(usize, usize)> {
    use rand::seq::SliceRandom;
    let all = || (0..labels).flat_map(|a| (0..labels).filter(move |&b| b != a).map(move |b| (a, b)));
    if labels * labels.saturating_sub(1) <= budget {
        return all().collect();
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7061_6972_735f_7631);
    let mut rounds: Vec<usize> = (1..labels).collect();
    rounds.shuffle(&mut rng);
    let mut pairs = Vec::with_capacity(budget);
    for d in rounds {
        let mut round: Vec<(usize, usize)> = (0..labels).map(|i| (i, (i + d) % labels)).collect();
        if pairs.len() + round.len() > budget {
            round.shuffle(&mut rng);
            round.truncate(budget - pairs.len());
        }
        pairs.extend(round);
        if pairs.len() == budget {
            break;
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Frames from the request to the first frame of `to`: `request` is the index of the
/// last frame before the request (the start pose for the baseline, the end of the hold
/// for reprise), so a hold before the request counts for no one.
fn latency(p: &Played, to: &str, request: usize) -> Option<i64> {
    p.iter().position(|f| f.label == to).map(|i| i as i64 - request as i64)
}

/// Runs the stage; returns the requests with each system's answers.
pub fn run(args: &Args) -> StageResult<Option<Answered>> {
    if args.per_pair == 0
        || args.max_requests == 0
        || args.hold.is_nan()
        || args.hold < 0.0
        || args.hold > reprise_synth_engine::script::MAX_SECONDS
        || args.window < 2
        || !(0.0..=10.0).contains(&args.path_slack)
        || !(0.0..=0.1).contains(&args.resolution)
    {
        return Err(StageError::Config(
            "need --per-pair >= 1, --max-requests >= 1, 0 <= --hold <= 3600, --window >= 2, --path-slack in [0, 10], \
             --resolution in [0, 0.1]"
                .into(),
        ));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let parts = LibraryParts::load(
        &args.io.gplvm_models,
        &args.io.latents,
        &args.io.pca_models,
        &args.io.scales,
        &args.io.bridges,
    )?;
    let models = &parts.models;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let mg = motion_graph::read_graph(&args.io.mg_nodes, &args.io.mg_edges)?;
    mg.check_window(args.window, "--window")?;
    mg.check_frames(&labeled, &args.io.labeled_frames)?;
    reprise_artifact::provenance::check_made_from(&args.io.mg_nodes, &provenance)?;
    if labeled.frames.controls != models.controls {
        return Err(StageError::Input(format!(
            "{} and the label models list different controls; rerun the stages after label",
            args.io.labeled_frames.display()
        )));
    }
    let (nodes, edges) = (&mg.nodes, &mg.edges);
    let g = Graph::from_edges(nodes.frame.len(), edges.iter().map(|e| (e.from, e.to, e.cost)))
        .map_err(|e| StageError::Input(format!("{}: {e}", args.io.mg_edges.display())))?;
    let settings = Settings { fps: labeled.frames.fps, ..Settings::default() };
    let lib = parts.library(&settings);
    let hold_frames = (args.hold * labeled.frames.fps).round() as usize;
    // The seeded requests.
    let labels: Vec<String> = models.models.iter().map(|m| m.label.clone()).collect();
    let per_pair = requests_per_pair(args.per_pair, args.max_requests, labels.len());
    let pairs = request_pairs(labels.len(), args.max_requests, args.seed);
    let all_pairs = labels.len() * labels.len().saturating_sub(1);
    if pairs.len() < all_pairs {
        eprintln!(
            "transitions: {all_pairs} ordered pairs would pass --max-requests {}: one request each for {} pairs, \
             sampled so that every label leaves and is reached equally often (within one)",
            args.max_requests,
            pairs.len()
        );
    } else if per_pair < args.per_pair {
        eprintln!(
            "transitions: {all_pairs} ordered pairs × {} requests would pass --max-requests {}: {per_pair} per pair",
            args.per_pair, args.max_requests
        );
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let mut requests = Vec::new();
    let mut rows_of = Vec::with_capacity(labels.len());
    for a in &labels {
        let rows: Vec<usize> = (0..labeled.frames.rows()).filter(|&r| &labeled.label[r] == a).collect();
        if rows.is_empty() {
            return Err(StageError::Input(format!(
                "label `{a}` of the models has no frame in {}",
                args.io.labeled_frames.display()
            )));
        }
        rows_of.push(rows);
    }
    for &(a, b) in &pairs {
        let rows = &rows_of[a];
        for _ in 0..per_pair {
            let r = rows[rng.gen_range(0..rows.len())];
            requests.push((requests.len(), labels[a].clone(), labels[b].clone(), r));
        }
    }
    let base = Baseline {
        g: &g,
        alive: &nodes.in_scc,
        edges,
        labeled: &labeled,
        k: args.window,
        hold: hold_frames,
        slack: args.path_slack,
    };
    let bar = reprise_stagekit::progress(requests.len() as u64, "transitions");
    let fps = labeled.frames.fps;
    let outputs = args.io.systems();
    // Requests are answered a chunk at a time and their frames written before the next
    // chunk: the stage holds a chunk's frames, not the benchmark's.
    let resolution = curves::Resolution::relative(args.resolution, &labeled.frames.ranges());
    let writer = |p: &std::path::Path| {
        curves::Writer::create(p, fps, &models.controls, &provenance).with_resolution(resolution.clone())
    };
    let mut writers: Vec<(curves::Writer, Option<curves::Writer>)> =
        outputs.iter().map(|o| (writer(o.curves), o.reseeded.map(writer))).collect();
    let mut answered: Vec<(Request, Vec<Answer>)> = Vec::with_capacity(requests.len());
    let answer = |(id, a, b, r): &(usize, String, String, usize)| {
        let hold =
            Command::Idle { duration: args.hold.max(1.0 / settings.fps), radius: None, poses: vec![], hover: None };
        let seed = args.seed.wrapping_add(*id as u64);
        let script = Script {
            name: Some(format!("r{id}")),
            seed,
            start: Start {
                label: a.clone(),
                segment: Some(labeled.segment_id[*r]),
                clip: None,
                frame: Some(labeled.frames.frame[*r]),
                latent: None,
            },
            commands: vec![hold.clone(), Command::Transition { to: b.clone(), blend_frames: None }, hold],
        };
        // reprise is asked after its hold: at the hold's last frame; the baseline at
        // its start frame.
        let ours = |method: Method, seed: u64| {
            let set = Settings { method, ..settings };
            engine::run(&lib, &Script { seed, ..script.clone() }, &set)
                .map(|f| {
                    let asked = f.iter().position(|f| f.command == 1).map_or(0, |i| i.saturating_sub(1));
                    let played = f.into_iter().map(|f| PlayedFrame {
                        label: labels[f.model].clone(),
                        controls: f.controls,
                        x: f.x,
                        command: f.command as i64,
                    });
                    (asked, played.collect::<Played>())
                })
                .map_err(|e| e.to_string())
        };
        let play = |player: Player, seed: u64| match player {
            Player::Reprise(method) => ours(method, seed),
            Player::MotionGraphs => base.answer(*r, b, seed).map(|p| (0, p)),
        };
        let answer = |p: &Result<(usize, Played), String>| match p {
            Ok((asked, p)) => match latency(p, b, *asked) {
                Some(l) => Answer::reached(*asked, l),
                None => Answer { asked: *asked as i64, ..Answer::failed(format!("never reached `{b}`")) },
            },
            Err(e) => Answer::failed(e.clone()),
        };
        let system = |o: &Output<'_>| {
            let first = play(o.player, seed);
            let again = o.reseeded.map(|_| play(o.player, seed.wrapping_add(RESEED)).map(|(_, p)| p));
            (answer(&first), first.map(|(_, p)| p), again)
        };
        let request = Request {
            request: *id as i64,
            from: a.clone(),
            to: b.clone(),
            segment_id: labeled.segment_id[*r],
            clip: labeled.frames.clip[*r].clone(),
            frame: labeled.frames.frame[*r],
        };
        bar.inc(1);
        Answers { request, systems: outputs.iter().map(system).collect() }
    };
    reprise_stagekit::par_map_chunked(&requests, answer, |ans: Answers| {
        let id = ans.request.request;
        for ((first_w, again_w), (_, first, again)) in writers.iter_mut().zip(&ans.systems) {
            let pairs = std::iter::once((first_w, Some(first))).chain(again_w.as_mut().map(|w| (w, again.as_ref())));
            for (w, played) in pairs {
                if let Some(Ok(p)) = played {
                    let frames = p.iter().map(|f| curves::Frame {
                        model: &f.label,
                        controls: &f.controls,
                        x: &f.x,
                        command: f.command,
                    });
                    w.push_script(&format!("r{id}"), frames)?;
                }
            }
        }
        answered.push((ans.request, ans.systems.into_iter().map(|s| s.0).collect()));
        Ok(())
    })?;
    bar.finish_and_clear();
    for (s, (o, (first, again))) in outputs.iter().zip(writers).enumerate() {
        let rows: Vec<(i64, Answer)> = answered.iter().map(|(r, a)| (r.request, a[s].clone())).collect();
        transitions::write_answers(o.answers, o.id, &rows, &provenance)?;
        first.finish()?;
        if let Some(w) = again {
            w.finish()?;
        }
    }
    let reqs: Vec<Request> = answered.iter().map(|(r, _)| r.clone()).collect();
    transitions::write_requests(&args.io.requests, &reqs, &provenance)?;
    Ok(Some(Answered { systems: outputs.iter().map(|o| o.id).collect(), rows: answered }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each ablation system's id names the improvement it plays (`reprise-paper-<name>`): the
    /// benchmark's list and the engine's are in the same order.
    #[test]
    fn the_ablation_ids_name_their_improvements() {
        for (def, improvement) in reprise_benchmark::systems::ABLATION.iter().zip(Method::IMPROVEMENTS) {
            assert_eq!(def.id, format!("reprise-paper-{}", improvement.name));
        }
        assert_eq!(reprise_benchmark::systems::ABLATION.len(), Method::IMPROVEMENTS.len());
    }
    use reprise_artifact::frames::Frames;

    /// Two labels of 40 frames each, one control moving at a constant 1 per frame (a from
    /// 0, b from 100), so any repeated or stalled frame shows as a short step.
    fn labeled() -> LabeledFrames {
        let n = 40;
        let values: Vec<f64> = (0..2 * n).map(|r| if r < n { r as f64 } else { 100.0 + (r - n) as f64 }).collect();
        LabeledFrames {
            segment_id: (0..2 * n).map(|r| (r / n) as i64).collect(),
            label: (0..2 * n).map(|r| if r < n { "a".into() } else { "b".into() }).collect(),
            frames: Frames {
                fps: 24.0,
                controls: vec!["c".into()],
                clip: (0..2 * n).map(|r| format!("clip{}", r / n)).collect(),
                frame: (0..2 * n).map(|r| (r % n) as i64).collect(),
                time: (0..2 * n).map(|r| (r % n) as f64 / 24.0).collect(),
                values,
            },
            masked_controls: vec![],
        }
    }

    fn edge(from: usize, to: usize, kind: &str) -> motion_graph::Edge {
        motion_graph::Edge { from: from as i64, to: to as i64, kind: kind.into(), cost: 1, distance: 0.0, in_scc: true }
    }

    /// The baseline plays no frame twice: the blend replaces A_i … A_{i+k−1}, whether the
    /// transition leaves from the request's own frame or from a frame reached by playing.
    #[test]
    fn the_baseline_plays_no_duplicated_frame() {
        let lf = labeled();
        let k = 4;
        for (start, leave) in [(10usize, 10usize), (5, 10)] {
            // next edges within each label; one transition a_leave -> b_20 (blend with b_{17..20}).
            let mut edges: Vec<motion_graph::Edge> =
                (0..79).filter(|&i| i != 39).map(|i| edge(i, i + 1, "next")).collect();
            edges.push(edge(leave, 40 + 20, "transition"));
            let mut g = Graph::new(80);
            for (i, e) in edges.iter().enumerate() {
                g.add(e.from as usize, e.to as usize, e.cost as u32, i);
            }
            let alive = vec![true; 80];
            let base = Baseline { g: &g, alive: &alive, edges: &edges, labeled: &lf, k, hold: 3, slack: 0.0 };
            let played = base.answer(start, "b", 0).unwrap();
            // Pruned starts play forward into the kept component: the same answer, later.
            let mut pruned = alive.clone();
            pruned[..start].iter_mut().for_each(|a| *a = false);
            if start > 0 {
                let late = Baseline { alive: &pruned, ..base }.answer(start - 1, "b", 0).unwrap();
                assert_eq!(late.len(), played.len() + 1, "one frame more, from the frame before");
            }
            let v: Vec<f64> = played.iter().map(|f| f.controls[0]).collect();
            assert_eq!(v[0], start as f64, "the request's own frame comes first");
            for w in v.windows(2) {
                // Within A and within B a step is 1; across the blend the mix moves by
                // (A's step) plus the weight change times the 80-unit gap — never 0.
                assert!(w[1] - w[0] >= 0.99, "stalled: {v:?}");
            }
            // From the request, A plays to A_{leave−1}, then the k blended frames in place of
            // A_leave … (at the request, A_leave is the request's frame and k − 1 follow it),
            // then B_20: k frames after A_leave's place either way.
            let to_b = v.iter().position(|&x| x == 120.0).unwrap();
            assert_eq!(to_b, (leave - start) + k, "{v:?}");
            assert_eq!(v.len(), to_b + 1 + 3, "then the hold plays on in B");
        }
    }

    /// 8 labels keep 20 per pair within 1,200 requests; 48 labels get 1 per pair (2,256
    /// pairs: the budget cannot give fewer than one each); 12 labels get 9.
    #[test]
    fn many_labels_get_fewer_requests_per_pair() {
        assert_eq!(requests_per_pair(20, 1200, 8), 20);
        assert_eq!(requests_per_pair(20, 1200, 12), 9);
        assert_eq!(requests_per_pair(20, 1200, 48), 1);
        assert_eq!(requests_per_pair(5, 1200, 2), 5);
    }

    /// Up to the budget every ordered pair is asked, in (a, b) order; past it, exactly
    /// `budget` distinct pairs, each label leaving and reached equally often (within one),
    /// the same for a seed and different for another.
    #[test]
    fn a_request_budget_samples_pairs_evenly_over_labels() {
        assert_eq!(request_pairs(3, 6, 0), [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]);
        for (labels, budget) in [(48, 1200), (48, 1000), (48, 47), (10, 89), (40, 1559)] {
            let pairs = request_pairs(labels, budget, 7);
            assert_eq!(pairs.len(), budget, "{labels} labels");
            assert!(pairs.windows(2).all(|w| w[0] < w[1]), "sorted and distinct");
            assert!(pairs.iter().all(|&(a, b)| a != b && a < labels && b < labels));
            for side in [0, 1] {
                let mut n = vec![0usize; labels];
                pairs.iter().for_each(|p| n[if side == 0 { p.0 } else { p.1 }] += 1);
                let (lo, hi) = (n.iter().min().unwrap(), n.iter().max().unwrap());
                assert!(hi - lo <= 1, "{labels} labels, budget {budget}: counts {lo}..{hi}");
            }
            assert_eq!(pairs, request_pairs(labels, budget, 7));
        }
        assert_ne!(request_pairs(48, 1200, 7), request_pairs(48, 1200, 8));
    }
}
