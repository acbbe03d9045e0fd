//! A session: several systems started at the same frame and driven by the same commands,
//! its command log, and the log's replay.
//!
//! **Time.** Frame $f$ is the $f$-th [`Session::step`]. A command given between steps
//! $f-1$ and $f$ is stamped $f$ and reaches every system before it makes frame $f$; each
//! system's frames are a function of (world, start label, seed, stamped commands) alone,
//! so [`replay`] of a [`Recording`] gives the session's frames bit for bit.

use serde::{Deserialize, Serialize};

use crate::command::LiveCommand;
use crate::game::{Action, Game, GameFile, GameState};
use crate::systems::{character, Character, LiveFrame, Outcome};
use crate::world::World;

/// One logged command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stamped {
    /// The frame it reached the systems before.
    pub frame: usize,
    /// The command.
    pub command: LiveCommand,
}

/// One logged game action (what the player did; the reactions it caused are among the
/// commands).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StampedAction {
    /// The frame it was taken before.
    pub frame: usize,
    /// The action.
    pub action: Action,
}

/// What a session was: enough to replay it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recording {
    /// The systems, in the session's order.
    pub systems: Vec<String>,
    /// The start label.
    pub start: String,
    /// The seed.
    pub seed: u64,
    /// Frames played.
    pub frames: usize,
    /// The commands, in order (a game's reactions among them).
    pub commands: Vec<Stamped>,
    /// The game actions, in order (for the record: [`replay`] needs only the commands).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub game: Vec<StampedAction>,
}

/// Several systems driven together.
pub struct Session {
    world: &'static World,
    systems: Vec<Box<dyn Character>>,
    recording: Recording,
    game: Option<Game>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session").field("recording", &self.recording).finish_non_exhaustive()
    }
}

impl Session {
    /// Systems `systems` (ids of [`crate::systems::SYSTEM_IDS`]) starting at label
    /// `start`'s first playable frame ([`World::start_row_for`]: in the motion graph's
    /// component when Motion Graphs is among them), seeded with `seed`.
    ///
    /// # Errors
    /// An unknown system or label, a label with no playable frame, or none or a repeated
    /// system, with why.
    pub fn new(world: &'static World, systems: &[String], start: &str, seed: u64) -> Result<Self, String> {
        let label = world
            .label_index(start)
            .ok_or_else(|| format!("unknown label `{start}`; the labels are: {}", world.labels.join(", ")))?;
        let with_graph = systems.iter().any(|s| s == "motion-graphs");
        let row = world.start_row_for(label, with_graph).ok_or_else(|| {
            if with_graph {
                format!(
                    "label `{start}` has no frame every system can start from (none of its frames is in the motion \
                     graph's largest strongly connected component; without motion-graphs it may)"
                )
            } else {
                format!("label `{start}` has no frame with a next frame in its take")
            }
        })?;
        if systems.is_empty() {
            return Err("a session needs at least one system".into());
        }
        if let Some(s) = systems.iter().enumerate().find(|(i, s)| systems[..*i].contains(s)).map(|(_, s)| s) {
            return Err(format!("system `{s}` given twice"));
        }
        let chars = systems.iter().map(|s| character(world, s, row, seed)).collect::<Result<Vec<_>, _>>()?;
        let recording = Recording {
            systems: systems.to_vec(),
            start: start.into(),
            seed,
            frames: 0,
            commands: vec![],
            game: vec![],
        };
        Ok(Self { world, systems: chars, recording, game: None })
    }

    /// The session with a Tic-Tac-Toe game of `file` (seeded with the session's seed), whose
    /// reactions become its commands.
    pub fn with_game(mut self, file: std::sync::Arc<GameFile>) -> Self {
        self.game = Some(Game::new(file, self.world.fps, self.recording.seed));
        self
    }

    /// Takes the player's game action before the next frame; the game's state after it.
    ///
    /// # Errors
    /// The session has no game, or the game refuses the action ([`Game::act`]).
    pub fn act(&mut self, a: Action) -> Result<&GameState, String> {
        let frame = self.recording.frames;
        let game = self.game.as_mut().ok_or("this session has no game (the server was started without a game file)")?;
        game.act(frame, &a)?;
        self.recording.game.push(StampedAction { frame, action: a });
        Ok(game.state())
    }

    /// The game's state, if the session has a game.
    pub fn game(&self) -> Option<&GameState> {
        self.game.as_ref().map(Game::state)
    }

    /// The world it plays.
    pub fn world(&self) -> &'static World {
        self.world
    }

    /// Frames made so far.
    pub fn frame(&self) -> usize {
        self.recording.frames
    }

    /// Gives `c` (checked against the world's labels) to every system, stamped with the
    /// next frame; each system's outcome in the session's order.
    ///
    /// # Errors
    /// A command the world refuses ([`LiveCommand::check`]); it is not logged.
    pub fn command(&mut self, c: LiveCommand) -> Result<Vec<Outcome>, String> {
        c.check(&self.world.labels)?;
        let outcomes = self.systems.iter_mut().map(|s| s.command(&c)).collect();
        self.recording.commands.push(Stamped { frame: self.recording.frames, command: c });
        Ok(outcomes)
    }

    /// The next frame of every system, in the session's order.
    pub fn step(&mut self) -> Vec<LiveFrame> {
        let due = self.game.as_mut().map(|g| g.due(self.recording.frames)).unwrap_or_default();
        for c in due {
            // Checked against the world's labels when the game file was read.
            let _ = self.command(c);
        }
        self.recording.frames += 1;
        self.systems.iter_mut().map(|s| s.step()).collect()
    }

    /// The session so far.
    pub fn recording(&self) -> &Recording {
        &self.recording
    }
}

/// Plays `rec` again: per frame, every system's frame.
///
/// # Errors
/// As [`Session::new`]; a command the world refuses; commands out of frame order or
/// stamped past the recording's end.
pub fn replay(world: &'static World, rec: &Recording) -> Result<Vec<Vec<LiveFrame>>, String> {
    let mut s = Session::new(world, &rec.systems, &rec.start, rec.seed)?;
    if rec.commands.windows(2).any(|w| w[1].frame < w[0].frame) {
        return Err("the recording's commands are not in frame order".into());
    }
    if let Some(c) = rec.commands.iter().find(|c| c.frame > rec.frames) {
        return Err(format!("a command is stamped frame {} but the recording has {} frames", c.frame, rec.frames));
    }
    let mut next = rec.commands.iter().peekable();
    let mut out = Vec::with_capacity(rec.frames.min(1 << 20));
    for f in 0..rec.frames {
        while let Some(c) = next.next_if(|c| c.frame == f) {
            s.command(c.command.clone())?;
        }
        out.push(s.step());
    }
    Ok(out)
}
