//! The benchmark's systems as live characters: each takes [`LiveCommand`]s and produces
//! one frame per [`Character::step`], deterministically (the same start, seed and commands
//! at the same frames give the same frames).
//!
//! **A command waits for a blend under way.** Every system blends when it changes motion
//! (reprise's rig-space blend at a bridge, Motion Graphs' transition, the crossfade);
//! a command arriving during one takes effect at its end, so no system jumps out of a
//! half-blended pose. Motion matching has no such wait: its inertialization absorbs jumps.

use std::collections::VecDeque;
use std::sync::mpsc::{sync_channel, Receiver};

use reprise_matching::{Controller, Crossfader};
use reprise_synth_engine::engine::{Checkpoint, Frame, Library, Phase, Settings, Synth, SynthError};
use reprise_synth_engine::script::{Command, Start};
use reprise_transition_graph::{play_path, PathFrame};
use serde::Serialize;

use crate::command::LiveCommand;
use crate::world::World;

/// What a system shows in the debug panel for one frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Debug {
    /// reprise: the particle and the bridge it heads for.
    Reprise {
        /// The latent point.
        x: Vec<f64>,
        /// The bridge's $x_1$, while a TRANSITION reaches and blends.
        aim: Option<Vec<f64>>,
    },
    /// Motion Graphs: the node shown and the nodes still planned.
    MotionGraphs {
        /// The labeled row shown (a blend's destination).
        node: usize,
        /// Planned frames still to show (their nodes), at most [`PLANNED_SHOWN`].
        planned: Vec<usize>,
    },
    /// Motion matching: the frame playing and the search made this frame.
    MotionMatching {
        /// The database row playing.
        frame: usize,
        /// The best candidates of a search made this frame, best first: (row, its label,
        /// cost), at most [`CANDIDATES_SHOWN`]; empty if it did not search.
        candidates: Vec<(usize, usize, f64)>,
        /// Whether it jumped.
        switched: bool,
    },
    /// Crossfade: the frame playing and the weight on the frame being left.
    Crossfade {
        /// The database row playing.
        frame: usize,
        /// $\alpha$, 0 after the blend.
        source_weight: f64,
    },
}

/// Motion matching's candidates in a frame's debug record.
pub const CANDIDATES_SHOWN: usize = 5;

/// At most this many planned Motion Graphs frames in a frame's debug record.
pub const PLANNED_SHOWN: usize = 48;

/// One frame of one system.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LiveFrame {
    /// Rig controls, in [`World::controls`]' order.
    pub controls: Vec<f64>,
    /// The label shown (index into [`World::labels`]; a blend's destination).
    pub label: usize,
    /// What it is doing: `reach`, `idle`, `blend`, `play` (reprise's phases) or `play`,
    /// `blend` (the others).
    pub phase: &'static str,
    /// The debug panel's record.
    pub debug: Debug,
    /// Something the system says about this frame (a command refused on the way, a
    /// failure it recovered from).
    pub note: Option<String>,
}

/// What became of a command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Taken (from the next frame, or at the end of a blend under way).
    Taken,
    /// Nothing for this system to do; its motion goes on.
    Ignored(String),
    /// Refused, with why; its motion goes on.
    Refused(String),
}

/// A live character.
pub trait Character: Send {
    /// The system's id (as in the benchmark).
    fn system(&self) -> &'static str;
    /// Takes a command (already checked against the world's labels).
    fn command(&mut self, c: &LiveCommand) -> Outcome;
    /// The next frame.
    fn step(&mut self) -> LiveFrame;
}

/// The ids of the systems a session can run, the method under test first.
pub const SYSTEM_IDS: [&str; 5] = ["reprise", "reprise-paper", "motion-graphs", "motion-matching", "crossfade"];

/// A character of system `id` starting at labeled row `start`, seeded with `seed`.
///
/// # Errors
/// An unknown id, or a start the system cannot play from, with why.
pub fn character(world: &'static World, id: &str, start: usize, seed: u64) -> Result<Box<dyn Character>, String> {
    Ok(match id {
        "reprise" => Box::new(Reprise::new(world, "reprise", &world.tuned, world.tuned_settings, start, seed)?),
        "reprise-paper" => {
            Box::new(Reprise::new(world, "reprise-paper", &world.paper, world.paper_settings, start, seed)?)
        }
        "motion-graphs" => Box::new(MotionGraphs::new(world, start, seed)),
        "motion-matching" => Box::new(MotionMatching::new(world, start)?),
        "crossfade" => Box::new(Crossfade::new(world, start)?),
        other => return Err(format!("unknown system `{other}`; the systems are: {}", SYSTEM_IDS.join(", "))),
    })
}

/// One item from a reprise synthesis thread.
type Produced = Result<(Frame, Checkpoint), SynthError>;

/// Frames a synthesis thread may run ahead of the frames taken.
const LOOKAHEAD: usize = 2;

/// Seconds per IDLE chunk of the endless idle after each command.
const IDLE_CHUNK: f64 = 1.0;

/// A reprise thread's work from checkpoint `cp`: `command` (an IDLE is left to the endless
/// IDLE, with its radius), then IDLE for ever; returns why it stopped.
#[allow(clippy::too_many_arguments)]
fn program(
    lib: &Library<'_>,
    set: &Settings,
    seed: u64,
    cp: &Checkpoint,
    index: usize,
    command: Option<Command>,
    idle_radius: Option<f64>,
    mut sink: impl FnMut(Frame, Checkpoint) -> bool,
) -> SynthError {
    let mut run = || -> Result<(), SynthError> {
        let mut synth = Synth::resume(lib, set, seed, cp)?;
        if let Some(c) = command.as_ref().filter(|c| !matches!(c, Command::Idle { .. })) {
            synth.execute(index, c, &mut sink)?;
        }
        let idle = Command::Idle { duration: IDLE_CHUNK, radius: idle_radius, poses: vec![], hover: None };
        loop {
            synth.execute(index, &idle, &mut sink)?;
        }
    };
    match run() {
        Err(e) => e,
        Ok(()) => SynthError::Stopped,
    }
}

/// reprise: the synthesis engine on a thread of its own, producing frames as they are
/// taken (at most [`LOOKAHEAD`] ahead). A command stops the thread and starts another
/// from the checkpoint of the last frame taken, running the command and then an endless
/// IDLE; the frames are those a script of the same commands would give.
struct Reprise {
    id: &'static str,
    world: &'static World,
    lib: &'static Library<'static>,
    set: Settings,
    seed: u64,
    frames: Receiver<Produced>,
    last: Checkpoint,
    last_phase: Phase,
    pending: Option<LiveCommand>,
    /// Commands started so far (the engine's command index).
    started: usize,
    note: Option<String>,
}

impl Reprise {
    fn new(
        world: &'static World,
        id: &'static str,
        lib: &'static Library<'static>,
        set: Settings,
        start: usize,
        seed: u64,
    ) -> Result<Self, String> {
        let l = &world.labeled;
        let start = Start {
            label: l.label[start].clone(),
            segment: Some(l.segment_id[start]),
            clip: None,
            frame: Some(l.frames.frame[start]),
            latent: None,
        };
        let last = Synth::new(lib, &set, &start, seed).map_err(|e| e.to_string())?.checkpoint();
        let mut r = Self {
            id,
            world,
            lib,
            set,
            seed,
            frames: sync_channel(0).1,
            last,
            last_phase: Phase::Idle,
            pending: None,
            started: 0,
            note: None,
        };
        r.restart(None);
        Ok(r)
    }

    /// Stops the running thread (dropping its receiver makes its next send fail) and starts
    /// one from the last checkpoint: `command`, if any, then an endless IDLE.
    fn restart(&mut self, command: Option<Command>) {
        let (tx, rx) = sync_channel::<Produced>(LOOKAHEAD);
        self.frames = rx;
        let (lib, set, seed, cp) = (self.lib, self.set, self.seed, self.last.clone());
        let first = self.started;
        self.started += 1;
        let idle_radius = match &command {
            Some(Command::Idle { radius, .. }) => *radius,
            _ => None,
        };
        std::thread::spawn(move || {
            let sink = |f: Frame, cp: Checkpoint| tx.send(Ok((f, cp))).is_ok();
            let e = program(lib, &set, seed, &cp, first, command, idle_radius, sink);
            if e != SynthError::Stopped {
                let _ = tx.send(Err(e));
            }
        });
    }

    fn engine_command(c: &LiveCommand) -> Command {
        match c.clone() {
            LiveCommand::Transition { to, blend_frames } => Command::Transition { to, blend_frames },
            LiveCommand::Idle { radius } => Command::Idle { duration: IDLE_CHUNK, radius, poses: vec![], hover: None },
            LiveCommand::Move { to, duration, path } => Command::Move { to, duration, path, radius: None },
            LiveCommand::Play { segment, clip } => Command::Play { segment, clip },
        }
    }
}

impl Character for Reprise {
    fn system(&self) -> &'static str {
        self.id
    }

    fn command(&mut self, c: &LiveCommand) -> Outcome {
        self.pending = Some(c.clone());
        Outcome::Taken
    }

    fn step(&mut self) -> LiveFrame {
        if self.last_phase != Phase::Blend {
            if let Some(c) = self.pending.take() {
                self.restart(Some(Self::engine_command(&c)));
            }
        }
        loop {
            match self.frames.recv() {
                Ok(Ok((f, cp))) => {
                    self.last = cp;
                    self.last_phase = f.phase;
                    return LiveFrame {
                        controls: f.controls,
                        label: f.model,
                        phase: f.phase.name(),
                        debug: Debug::Reprise { x: f.x, aim: f.aim },
                        note: self.note.take(),
                    };
                }
                // The command failed (no bridge, a time-out, a bad pose): say so and idle
                // from where it stands.
                Ok(Err(e)) => {
                    self.note = Some(e.to_string());
                    self.last_phase = Phase::Idle;
                    self.restart(None);
                }
                Err(_) => {
                    self.note = Some("the synthesis thread ended; idling".into());
                    self.restart(None);
                }
            }
            debug_assert!(self.world.fps > 0.0);
        }
    }
}

/// Motion Graphs: the graph's frames played along planned paths. With nothing asked it
/// plays on along its take and, at the take's end, takes a near-shortest path to another
/// frame of its label; `transition` plans a near-shortest path to the label, `play` one to
/// the take's first frame (each under the seed and the plan's number).
struct MotionGraphs {
    world: &'static World,
    /// The node shown last.
    at: usize,
    /// Frames planned, not yet shown.
    queue: VecDeque<PathFrame>,
    /// The label being played or gone to.
    label: usize,
    seed: u64,
    plans: u64,
    pending: Option<LiveCommand>,
    note: Option<String>,
}

impl MotionGraphs {
    fn new(world: &'static World, start: usize, seed: u64) -> Self {
        Self {
            world,
            at: start,
            queue: VecDeque::new(),
            label: world.row_label[start],
            seed,
            plans: 0,
            pending: None,
            note: None,
        }
    }

    fn blending(&self) -> bool {
        matches!(self.queue.front(), Some(PathFrame::Blend { .. }))
    }

    /// Plans a near-shortest path from the last planned node to a node with `goal`;
    /// `false` if there is none.
    fn plan(&mut self, goal: impl Fn(usize) -> bool) -> bool {
        let w = self.world;
        let from = self.queue.back().map_or(self.at, PathFrame::node);
        let seed = self.seed ^ self.plans.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.plans += 1;
        let Some((_, path)) = w.graph.near_shortest_to(from, &w.alive, goal, w.tuning.path_slack, seed) else {
            return false;
        };
        let mut queue: Vec<PathFrame> = self.queue.drain(..).collect();
        let ends = |e: usize| {
            let edge = &w.edges[e];
            (edge.from as usize, edge.to as usize, edge.kind == "transition")
        };
        play_path(&mut queue, &path, ends, w.window);
        self.queue = queue.into();
        true
    }

    fn apply(&mut self, c: &LiveCommand) {
        let w = self.world;
        // Keep the blend under way and the frame it ends on; drop the rest of the plan.
        let keep = self.queue.iter().position(|f| matches!(f, PathFrame::Node(_))).map_or(0, |i| i + 1);
        let keep = if self.blending() { keep } else { 0 };
        self.queue.truncate(keep);
        let (found, goal) = match c {
            LiveCommand::Transition { to, .. } => {
                let Some(label) = w.label_index(to) else { return };
                self.label = label;
                (self.plan(|v| w.row_label[v] == label), format!("`{to}`"))
            }
            LiveCommand::Play { segment, clip } => match w.take_start(self.label, *segment, clip.as_deref()) {
                Some(first) => (self.plan(|v| v == first), format!("the take's first frame ({first})")),
                None => {
                    self.note = Some(format!("no such take in `{}`", w.labels[self.label]));
                    return;
                }
            },
            _ => return,
        };
        if !found {
            self.note = Some(format!(
                "no path to {goal} in the motion graph (none of its frames is in the graph's largest strongly \
                 connected component); playing on"
            ));
        }
    }
}

impl Character for MotionGraphs {
    fn system(&self) -> &'static str {
        "motion-graphs"
    }

    fn command(&mut self, c: &LiveCommand) -> Outcome {
        match c {
            LiveCommand::Idle { .. } | LiveCommand::Move { .. } => {
                Outcome::Ignored("Motion Graphs has no latent point to hover or move; its motion goes on".into())
            }
            _ => {
                self.pending = Some(c.clone());
                Outcome::Taken
            }
        }
    }

    fn step(&mut self) -> LiveFrame {
        let w = self.world;
        if !self.blending() {
            if let Some(c) = self.pending.take() {
                self.apply(&c);
            }
        }
        if self.queue.is_empty() {
            let next = w.graph.adj[self.at]
                .iter()
                .find(|&&(v, _, e)| w.edges[e].kind == "next" && w.alive.get(v).copied().unwrap_or(false));
            match next {
                Some(&(v, _, _)) => self.queue.push_back(PathFrame::Node(v)),
                None => {
                    let label = self.label;
                    if !self.plan(|v| w.row_label[v] == label) && !self.plan(|_| true) {
                        // Outside the component with no way in: hold the frame.
                        self.queue.push_back(PathFrame::Node(self.at));
                    }
                }
            }
        }
        let f = self.queue.pop_front().expect("planned above");
        let row = |r: usize| w.labeled.frames.row(r);
        let (controls, phase) = match f {
            PathFrame::Node(v) => (row(v).to_vec(), "play"),
            PathFrame::Blend { a, b, weight, .. } => {
                (row(a).iter().zip(row(b)).map(|(x, y)| weight * x + (1.0 - weight) * y).collect(), "blend")
            }
        };
        self.at = f.node();
        LiveFrame {
            controls,
            label: w.row_label[self.at],
            phase,
            debug: Debug::MotionGraphs {
                node: self.at,
                planned: self.queue.iter().take(PLANNED_SHOWN).map(PathFrame::node).collect(),
            },
            note: self.note.take(),
        }
    }
}

/// The database label id of world label `label`.
fn corpus_id(world: &World, label: usize) -> Option<u32> {
    world.corpus_label.iter().position(|&l| l == label).map(|i| i as u32)
}

/// Motion matching: the controller playing the database, searching its target label on
/// its timer (the first search at the session's first frame).
struct MotionMatching {
    world: &'static World,
    controller: Controller<'static>,
    row: Vec<f64>,
}

impl MotionMatching {
    fn new(world: &'static World, start: usize) -> Result<Self, String> {
        let c = &world.corpus;
        let target = corpus_id(world, world.row_label[start]).ok_or("the start label has no database frames")?;
        let controller =
            Controller::new(&c.db, &c.feats, start, target, 0, &world.tuning.controller).map_err(|e| c.why(e))?;
        Ok(Self { world, controller, row: Vec::new() })
    }
}

impl Character for MotionMatching {
    fn system(&self) -> &'static str {
        "motion-matching"
    }

    fn command(&mut self, c: &LiveCommand) -> Outcome {
        let w = self.world;
        match c {
            LiveCommand::Transition { to, .. } => {
                let Some(id) = w.label_index(to).and_then(|l| corpus_id(w, l)) else {
                    return Outcome::Refused(format!("`{to}` has no database frames"));
                };
                match self.controller.set_target(id) {
                    Ok(()) => Outcome::Taken,
                    Err(e) => Outcome::Refused(w.corpus.why(e)),
                }
            }
            LiveCommand::Play { .. } => {
                Outcome::Ignored("motion matching searches labels, not takes; its motion goes on".into())
            }
            _ => Outcome::Ignored("motion matching has no latent point to hover or move; its motion goes on".into()),
        }
    }

    fn step(&mut self) -> LiveFrame {
        let w = self.world;
        let (info, mut note) = match self.controller.step() {
            Ok(i) => (Some(i), None),
            Err(e) => (None, Some(w.corpus.why(e))),
        };
        let candidates = match self.controller.candidates(CANDIDATES_SHOWN) {
            Ok(top) => top.into_iter().map(|m| (m.frame, w.row_label[m.frame], m.cost)).collect(),
            Err(e) => {
                note.get_or_insert(w.corpus.why(e));
                Vec::new()
            }
        };
        self.row = w.corpus.unscale(self.controller.output());
        let frame = self.controller.current_frame();
        LiveFrame {
            controls: self.row.clone(),
            label: w.row_label[frame],
            phase: if info.is_some_and(|i| i.switched) { "blend" } else { "play" },
            debug: Debug::MotionMatching { frame, candidates, switched: info.is_some_and(|i| i.switched) },
            note,
        }
    }
}

/// The crossfade: a blend into the target label's frame nearest the pose shown, then that
/// take plays on, chaining a new crossfade at its end.
struct Crossfade {
    world: &'static World,
    fade: Crossfader<'static>,
    row: Vec<f64>,
    pending: Option<LiveCommand>,
    note: Option<String>,
}

impl Crossfade {
    fn new(world: &'static World, start: usize) -> Result<Self, String> {
        let c = &world.corpus;
        let label = corpus_id(world, world.row_label[start]).ok_or("the start label has no database frames")?;
        let fade = Crossfader::playing(&c.db, start, label, world.tuning.blend_frames).map_err(|e| c.why(e))?;
        Ok(Self { world, fade, row: vec![0.0; c.db.dim()], pending: None, note: None })
    }

    fn apply(&mut self, c: &LiveCommand) {
        let w = self.world;
        let blend = |b: Option<usize>| b.unwrap_or(w.tuning.blend_frames);
        let result = match c {
            LiveCommand::Transition { to, blend_frames } => match w.label_index(to).and_then(|l| corpus_id(w, l)) {
                Some(id) => self.fade.retarget(id, blend(*blend_frames)),
                None => return self.note = Some(format!("`{to}` has no database frames")),
            },
            LiveCommand::Play { segment, clip } => {
                let label = w.corpus_label[self.fade.target() as usize];
                match w.take_start(label, *segment, clip.as_deref()) {
                    Some(first) => self.fade.fade_to_frame(first, w.tuning.blend_frames),
                    None => return self.note = Some(format!("no such take in `{}`", w.labels[label])),
                }
            }
            _ => return,
        };
        if let Err(e) = result {
            self.note = Some(w.corpus.why(e));
        }
    }
}

impl Character for Crossfade {
    fn system(&self) -> &'static str {
        "crossfade"
    }

    fn command(&mut self, c: &LiveCommand) -> Outcome {
        match c {
            LiveCommand::Idle { .. } | LiveCommand::Move { .. } => {
                Outcome::Ignored("the crossfade has no latent point to hover or move; its motion goes on".into())
            }
            _ => {
                self.pending = Some(c.clone());
                Outcome::Taken
            }
        }
    }

    fn step(&mut self) -> LiveFrame {
        let w = self.world;
        if self.fade.interruptible() {
            if let Some(c) = self.pending.take() {
                self.apply(&c);
            }
        }
        let f = match self.fade.step(&mut self.row) {
            Ok(f) => f,
            Err(e) => {
                self.note = Some(w.corpus.why(e));
                reprise_matching::FadeFrame { frame: 0, label: 0, switch: false, source_weight: 0.0 }
            }
        };
        LiveFrame {
            controls: w.corpus.unscale(&self.row),
            label: w.row_label[f.frame],
            phase: if f.source_weight > 0.0 { "blend" } else { "play" },
            debug: Debug::Crossfade { frame: f.frame, source_weight: f.source_weight },
            note: self.note.take(),
        }
    }
}
