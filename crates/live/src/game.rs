//! The paper's Tic-Tac-Toe (§6): the player (X) against the character (O), the character's
//! face reacting to the game. "During Toothless's turn, he holds a ponderous expression …
//! we intentionally extend Toothless's deliberation time"; during the player's turn "he
//! squints and scowls"; he roars when he loses, is happy when he wins, and surprised when
//! he "misses a move to block the player from winning". Each reaction is a set of scripts of
//! live commands; the game picks one at random (under the session's seed).
//!
//! **The game file** (TOML; every label checked against the world's when it is read):
//!
//! ```toml
//! ponder_seconds = 3.0   # the character's deliberately long turn
//! mistake_rate = 0.3     # share of its moves that are a random free cell, not its best
//!
//! [[ponder]]             # one script of the `ponder` reaction; more [[ponder]] are more scripts
//! name = "curious"
//! steps = [
//!   { type = "transition", to = "curious", hold = 1.0 },
//!   { type = "idle", radius = 0.3 },
//! ]
//! ```
//!
//! A step is a live command ([`LiveCommand`], the same JSON a client sends) and `hold`, the
//! seconds until the next step (default 0). The reactions ([`Event`]): `player-turn`,
//! `ponder`, `win` (the character won), `lose` (it lost), `missed-block` (after its move the
//! player can win at once) and `draw`. A reaction with no script is no reaction.
//!
//! **Time and replay.** The game runs on the session's frames: a reaction's steps are
//! issued as ordinary commands at the frames their holds give, and the character moves
//! `ponder_seconds` after the player. The session logs those commands, so a recording
//! replays without the game file (which may have changed since).

use std::collections::VecDeque;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::command::LiveCommand;

/// The largest game file read, bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// The most scripts a reaction may have.
pub const MAX_SCRIPTS: usize = 64;
/// The most steps a script may have.
pub const MAX_STEPS: usize = 64;
/// The longest hold or deliberation, seconds.
pub const MAX_SECONDS: f64 = 60.0;

/// A game event the character reacts to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Event {
    /// The player is to move: squint and scowl.
    PlayerTurn,
    /// The character deliberates.
    Ponder,
    /// The character won.
    Win,
    /// The character lost.
    Lose,
    /// The character's move left the player a winning move.
    MissedBlock,
    /// The board is full with no line.
    Draw,
}

impl Event {
    /// Every event, in the file's order.
    pub const ALL: [Event; 6] =
        [Event::PlayerTurn, Event::Ponder, Event::Win, Event::Lose, Event::MissedBlock, Event::Draw];

    /// The event's name in the game file and the game state.
    pub fn name(self) -> &'static str {
        match self {
            Event::PlayerTurn => "player-turn",
            Event::Ponder => "ponder",
            Event::Win => "win",
            Event::Lose => "lose",
            Event::MissedBlock => "missed-block",
            Event::Draw => "draw",
        }
    }

    fn index(self) -> usize {
        Event::ALL.iter().position(|&e| e == self).expect("listed")
    }
}

/// One step of a reaction script.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Step {
    /// The command.
    pub command: LiveCommand,
    /// Seconds until the next step.
    pub hold: f64,
}

/// One reaction script.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Script {
    /// Its name (default `<event> <n>`).
    pub name: String,
    /// Its steps, in order.
    pub steps: Vec<Step>,
}

/// A game file, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct GameFile {
    /// The character's deliberation, seconds.
    pub ponder_seconds: f64,
    /// Share of the character's moves played at random.
    pub mistake_rate: f64,
    /// Scripts per event, in [`Event::ALL`]'s order.
    pub scripts: [Vec<Script>; 6],
}

/// Why a game file cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {what}")]
pub struct GameFileError {
    /// The file.
    pub file: String,
    /// What is wrong, and where in the file.
    pub what: String,
}

impl GameFile {
    /// Reads and checks the game file at `path` against the world's `labels`.
    ///
    /// # Errors
    /// The file is missing, too large, not TOML, or wrong ([`GameFile::parse`]).
    pub fn read(path: &Path, labels: &[String]) -> Result<Self, GameFileError> {
        let err = |what: String| GameFileError { file: path.display().to_string(), what };
        let text = reprise_artifact::input::read_text(path, MAX_FILE_BYTES).map_err(|e| err(e.to_string()))?;
        Self::parse(&text, labels).map_err(err)
    }

    /// Parses a game file's text, checking every step's command against `labels`.
    ///
    /// # Errors
    /// What is wrong, naming the key, the script and the step.
    pub fn parse(text: &str, labels: &[String]) -> Result<Self, String> {
        let mut table: toml::Table = text.parse().map_err(|e| format!("not TOML: {e}"))?;
        let seconds = |t: &mut toml::Table, key: &str, default: f64, lo: f64, hi: f64| -> Result<f64, String> {
            match t.remove(key) {
                None => Ok(default),
                Some(v) => match v.as_float().or(v.as_integer().map(|i| i as f64)) {
                    Some(x) if x.is_finite() && (lo..=hi).contains(&x) => Ok(x),
                    _ => Err(format!("`{key}` must be a number in [{lo}, {hi}], not {v}")),
                },
            }
        };
        let ponder_seconds = seconds(&mut table, "ponder_seconds", 3.0, 0.0, MAX_SECONDS)?;
        let mistake_rate = seconds(&mut table, "mistake_rate", 0.3, 0.0, 1.0)?;
        let mut scripts: [Vec<Script>; 6] = Default::default();
        for event in Event::ALL {
            let Some(v) = table.remove(event.name()) else { continue };
            let list =
                v.as_array().ok_or_else(|| format!("`{}` must be an array of tables ([[{0}]])", event.name()))?;
            if list.len() > MAX_SCRIPTS {
                return Err(format!("`{}` has {} scripts; at most {MAX_SCRIPTS}", event.name(), list.len()));
            }
            for (i, s) in list.iter().enumerate() {
                let at = format!("[[{}]] script {}", event.name(), i + 1);
                scripts[event.index()].push(parse_script(s, &at, labels)?);
            }
        }
        if let Some(key) = table.keys().next() {
            let known: Vec<&str> = Event::ALL.iter().map(|e| e.name()).collect();
            return Err(format!(
                "unknown key `{key}`; the keys are ponder_seconds, mistake_rate and the reactions {}",
                known.join(", ")
            ));
        }
        Ok(Self { ponder_seconds, mistake_rate, scripts })
    }

    /// The scripts of `event`.
    pub fn scripts(&self, event: Event) -> &[Script] {
        &self.scripts[event.index()]
    }
}

fn parse_script(v: &toml::Value, at: &str, labels: &[String]) -> Result<Script, String> {
    let mut t = v.as_table().cloned().ok_or_else(|| format!("{at}: a script is a table with `steps`"))?;
    let name = match t.remove("name") {
        None => at.to_string(),
        Some(toml::Value::String(s)) if s.len() <= 200 => s,
        Some(other) => return Err(format!("{at}: `name` must be a string of at most 200 bytes, not {other}")),
    };
    let steps = t.remove("steps").ok_or_else(|| format!("{at}: no `steps`"))?;
    if let Some(key) = t.keys().next() {
        return Err(format!("{at}: unknown key `{key}`; a script has `name` and `steps`"));
    }
    let steps = steps.as_array().ok_or_else(|| format!("{at}: `steps` must be an array of commands"))?;
    if steps.is_empty() || steps.len() > MAX_STEPS {
        return Err(format!("{at}: {} steps; a script has 1 to {MAX_STEPS}", steps.len()));
    }
    let steps = steps
        .iter()
        .enumerate()
        .map(|(j, s)| parse_step(s, labels).map_err(|e| format!("{at}, step {}: {e}", j + 1)))
        .collect::<Result<_, _>>()?;
    Ok(Script { name, steps })
}

fn parse_step(v: &toml::Value, labels: &[String]) -> Result<Step, String> {
    let mut t = v.as_table().cloned().ok_or("a step is a command table, e.g. { type = \"idle\" }")?;
    let hold = match t.remove("hold") {
        None => 0.0,
        Some(h) => match h.as_float().or(h.as_integer().map(|i| i as f64)) {
            Some(x) if x.is_finite() && (0.0..=MAX_SECONDS).contains(&x) => x,
            _ => return Err(format!("`hold` must be seconds in [0, {MAX_SECONDS}], not {h}")),
        },
    };
    let command: LiveCommand = toml::Value::Table(t).try_into().map_err(|e| format!("not a command: {e}"))?;
    command.check(labels)?;
    Ok(Step { command, hold })
}

/// A square of the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Mark {
    /// Free.
    #[serde(rename = ".")]
    Free,
    /// The player's.
    #[serde(rename = "X")]
    Player,
    /// The character's.
    #[serde(rename = "O")]
    Character,
}

/// Whose turn it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Turn {
    /// The player's.
    Player,
    /// The character's: it moves `ponder_seconds` after the player.
    Character,
    /// The game is over.
    Over,
}

/// The eight lines of three.
const LINES: [[usize; 3]; 8] = [[0, 1, 2], [3, 4, 5], [6, 7, 8], [0, 3, 6], [1, 4, 7], [2, 5, 8], [0, 4, 8], [2, 4, 6]];

/// The line `m` holds on `board`, if any.
fn line_of(board: &[Mark; 9], m: Mark) -> Option<[usize; 3]> {
    LINES.iter().copied().find(|l| l.iter().all(|&i| board[i] == m))
}

/// Free squares where `m` would complete a line.
fn winning_moves(board: &[Mark; 9], m: Mark) -> Vec<usize> {
    (0..9)
        .filter(|&i| board[i] == Mark::Free)
        .filter(|&i| {
            let mut b = *board;
            b[i] = m;
            line_of(&b, m).is_some()
        })
        .collect()
}

fn other(m: Mark) -> Mark {
    if m == Mark::Player {
        Mark::Character
    } else {
        Mark::Player
    }
}

/// The game's value to `m`, `m` to move at ply `depth`, under perfect play: $10 - d$ for a
/// win at ply $d$, 0 a draw, $-(10 - d)$ a loss (a sooner win, a later loss, is better).
fn value(board: &mut [Mark; 9], m: Mark, depth: i32) -> i32 {
    if line_of(board, other(m)).is_some() {
        return -(10 - depth);
    }
    let mut best = i32::MIN;
    for i in 0..9 {
        if board[i] == Mark::Free {
            board[i] = m;
            best = best.max(-value(board, other(m), depth + 1));
            board[i] = Mark::Free;
        }
    }
    if best == i32::MIN {
        0
    } else {
        best
    }
}

/// The free squares of best value for `m` to move.
pub fn best_moves(board: &[Mark; 9], m: Mark) -> Vec<usize> {
    let mut b = *board;
    let mut scored = Vec::new();
    for i in 0..9 {
        if b[i] == Mark::Free {
            b[i] = m;
            scored.push((i, -value(&mut b, other(m), 1)));
            b[i] = Mark::Free;
        }
    }
    let top = scored.iter().map(|s| s.1).max();
    scored.into_iter().filter(|s| Some(s.1) == top).map(|s| s.0).collect()
}

/// What the page shows of the game.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GameState {
    /// Changes with every change of the state.
    pub version: u64,
    /// Games started.
    pub game: u64,
    /// The board, row by row.
    pub board: [Mark; 9],
    /// Whose turn.
    pub turn: Turn,
    /// Who won: `player`, `character` or `draw`, once over.
    pub outcome: Option<&'static str>,
    /// The winning line.
    pub line: Option<[usize; 3]>,
    /// The last reaction, its script's name, and the frame it began.
    pub reaction: Option<(Event, String, usize)>,
    /// Whether the character's last move was a deliberate mistake (a random square).
    pub mistake: bool,
}

/// A player's action, sent like a command (`{"type": "new-game"}`, `{"type": "mark", "cell": 4}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Action {
    /// A new game; the character moves first if asked.
    NewGame {
        /// The character moves first.
        #[serde(default)]
        character_first: bool,
    },
    /// The player marks a square (0–8, row by row).
    Mark {
        /// The square.
        cell: usize,
    },
}

/// A game in progress: the board, the character's play, and the reaction being played.
#[derive(Debug, Clone)]
pub struct Game {
    file: std::sync::Arc<GameFile>,
    fps: f64,
    rng: ChaCha8Rng,
    state: GameState,
    /// The frame the character moves at, on its turn.
    move_at: usize,
    /// Reaction steps still to issue: (frame, command).
    queue: VecDeque<(usize, LiveCommand)>,
}

impl Game {
    /// No game yet (a [`Action::NewGame`] starts one), on a session at `fps`, seeded.
    pub fn new(file: std::sync::Arc<GameFile>, fps: f64, seed: u64) -> Self {
        Self {
            file,
            fps,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x7469_6374_6163_746f),
            state: GameState {
                version: 0,
                game: 0,
                board: [Mark::Free; 9],
                turn: Turn::Over,
                outcome: None,
                line: None,
                reaction: None,
                mistake: false,
            },
            move_at: 0,
            queue: VecDeque::new(),
        }
    }

    /// The state.
    pub fn state(&self) -> &GameState {
        &self.state
    }

    /// Takes the player's action at frame `now`.
    ///
    /// # Errors
    /// A square that is not free or not 0–8, or a move out of turn, with why.
    pub fn act(&mut self, now: usize, a: &Action) -> Result<(), String> {
        match *a {
            Action::NewGame { character_first } => {
                let s = &mut self.state;
                s.game += 1;
                (s.board, s.outcome, s.line, s.mistake) = ([Mark::Free; 9], None, None, false);
                if character_first {
                    self.character_turn(now);
                } else {
                    self.state.turn = Turn::Player;
                    self.react(Event::PlayerTurn, now);
                }
            }
            Action::Mark { cell } => {
                if self.state.turn != Turn::Player {
                    return Err(match self.state.turn {
                        Turn::Over => "no game under way: start a new game".into(),
                        _ => "not your turn: the character is thinking".into(),
                    });
                }
                if cell >= 9 || self.state.board[cell] != Mark::Free {
                    return Err(format!("square {cell} is not a free square (0-8, row by row)"));
                }
                self.state.board[cell] = Mark::Player;
                self.state.mistake = false;
                if let Some(line) = line_of(&self.state.board, Mark::Player) {
                    self.over(Some(line), "player", Event::Lose, now);
                } else if self.full() {
                    self.over(None, "draw", Event::Draw, now);
                } else {
                    self.character_turn(now);
                }
            }
        }
        self.state.version += 1;
        Ok(())
    }

    /// The commands due at frame `now` (the character moves first if its time has come).
    pub fn due(&mut self, now: usize) -> Vec<LiveCommand> {
        if self.state.turn == Turn::Character && now >= self.move_at {
            self.character_moves(now);
            self.state.version += 1;
        }
        let mut out = Vec::new();
        while self.queue.front().is_some_and(|(f, _)| *f <= now) {
            out.extend(self.queue.pop_front().map(|(_, c)| c));
        }
        out
    }

    fn full(&self) -> bool {
        self.state.board.iter().all(|&m| m != Mark::Free)
    }

    fn character_turn(&mut self, now: usize) {
        self.state.turn = Turn::Character;
        self.move_at = now + (self.file.ponder_seconds * self.fps).round() as usize;
        self.react(Event::Ponder, now);
    }

    fn character_moves(&mut self, now: usize) {
        let board = self.state.board;
        let mistake = self.rng.gen_bool(self.file.mistake_rate);
        let choices: Vec<usize> = if mistake {
            (0..9).filter(|&i| board[i] == Mark::Free).collect()
        } else {
            best_moves(&board, Mark::Character)
        };
        let cell = choices[self.rng.gen_range(0..choices.len())];
        self.state.board[cell] = Mark::Character;
        self.state.mistake = mistake;
        if let Some(line) = line_of(&self.state.board, Mark::Character) {
            self.over(Some(line), "character", Event::Win, now);
        } else if self.full() {
            self.over(None, "draw", Event::Draw, now);
        } else {
            self.state.turn = Turn::Player;
            let missed = !winning_moves(&self.state.board, Mark::Player).is_empty();
            self.react(if missed { Event::MissedBlock } else { Event::PlayerTurn }, now);
        }
    }

    fn over(&mut self, line: Option<[usize; 3]>, outcome: &'static str, e: Event, now: usize) {
        (self.state.turn, self.state.line, self.state.outcome) = (Turn::Over, line, Some(outcome));
        self.react(e, now);
    }

    /// Plays one of `e`'s scripts, chosen at random, from frame `now` (dropping the steps
    /// of the reaction under way); none if `e` has no script.
    fn react(&mut self, e: Event, now: usize) {
        let scripts = self.file.scripts(e);
        if scripts.is_empty() {
            self.state.reaction = None;
            return;
        }
        let s = &scripts[self.rng.gen_range(0..scripts.len())];
        self.queue.clear();
        let mut at = now;
        for step in &s.steps {
            self.queue.push_back((at, step.command.clone()));
            at += (step.hold * self.fps).round() as usize;
        }
        self.state.reaction = Some((e, s.name.clone(), now));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels() -> Vec<String> {
        ["neutral", "curious", "grumpy", "happy", "roar", "surprise"].map(String::from).to_vec()
    }

    const FILE: &str = r#"
ponder_seconds = 0.5
mistake_rate = 0.0
[[player-turn]]
steps = [{ type = "transition", to = "grumpy", hold = 0.25 }, { type = "idle", radius = 0.3 }]
[[ponder]]
name = "think"
steps = [{ type = "transition", to = "curious" }]
[[win]]
steps = [{ type = "transition", to = "happy" }]
[[lose]]
steps = [{ type = "transition", to = "roar" }]
[[missed-block]]
steps = [{ type = "transition", to = "surprise" }]
"#;

    fn game(text: &str, seed: u64) -> Game {
        Game::new(std::sync::Arc::new(GameFile::parse(text, &labels()).unwrap()), 24.0, seed)
    }

    fn to(c: &LiveCommand) -> &str {
        c.label().unwrap_or("-")
    }

    #[test]
    fn perfect_play_blocks_takes_wins_and_never_loses() {
        use Mark::{Character as O, Free as F, Player as X};
        // X threatens 0-1-2: O must block at 2.
        assert_eq!(best_moves(&[X, X, F, F, O, F, F, F, F], O), vec![2]);
        // O can win at 8 (0-4-8) rather than block.
        assert_eq!(best_moves(&[O, X, X, F, O, F, X, F, F], O), vec![8]);
        // From the empty board every square draws under perfect play.
        assert_eq!(value(&mut [F; 9], X, 0), 0);
        assert_eq!(best_moves(&[F; 9], X).len(), 9);
        assert_eq!(winning_moves(&[X, X, F, X, F, F, F, F, F], X), vec![2, 6]);
    }

    #[test]
    fn a_game_reacts_on_the_session_frames() {
        let mut g = game(FILE, 1);
        g.act(0, &Action::NewGame { character_first: false }).unwrap();
        // The player's turn: grumpy now, then idle 0.25 s (6 frames) later.
        assert_eq!(g.due(0).iter().map(to).collect::<Vec<_>>(), ["grumpy"]);
        assert!(g.due(5).is_empty());
        assert!(matches!(g.due(6)[..], [LiveCommand::Idle { .. }]));
        assert!(g.act(7, &Action::Mark { cell: 9 }).unwrap_err().contains("not a free square"));
        g.act(10, &Action::Mark { cell: 0 }).unwrap();
        assert_eq!(g.state().turn, Turn::Character);
        assert!(g.act(11, &Action::Mark { cell: 1 }).unwrap_err().contains("not your turn"));
        // Pondering for 0.5 s = 12 frames, then it moves (perfect play answers a corner
        // with the centre) and it is the player's turn again.
        assert_eq!(g.due(10).iter().map(to).collect::<Vec<_>>(), ["curious"]);
        assert!(g.due(21).is_empty() && g.state().turn == Turn::Character);
        assert_eq!(g.due(22).iter().map(to).collect::<Vec<_>>(), ["grumpy"]);
        assert_eq!(g.state().board[4], Mark::Character);
        assert_eq!(g.state().reaction.as_ref().map(|r| r.0), Some(Event::PlayerTurn));
    }

    #[test]
    fn a_perfect_character_never_loses_and_a_careless_one_misses_blocks() {
        // The player plays the first free square, or a winning one.
        let play = |g: &mut Game| {
            let mut events = Vec::new();
            g.act(0, &Action::NewGame { character_first: false }).unwrap();
            let mut now = 0;
            while g.state().turn != Turn::Over {
                now += 1;
                g.due(now);
                if let Some(r) = &g.state().reaction {
                    if events.last() != Some(&r.0) {
                        events.push(r.0);
                    }
                }
                if g.state().turn == Turn::Player {
                    let b = g.state().board;
                    let cell = winning_moves(&b, Mark::Player)
                        .first()
                        .copied()
                        .unwrap_or_else(|| (0..9).find(|&i| b[i] == Mark::Free).unwrap());
                    g.act(now, &Action::Mark { cell }).unwrap();
                    events.push(g.state().reaction.as_ref().unwrap().0);
                }
            }
            (g.state().outcome.unwrap(), events)
        };
        for seed in 0..20 {
            let (outcome, _) = play(&mut game(FILE, seed));
            assert_ne!(outcome, "player", "seed {seed}");
        }
        let careless = FILE.replace("mistake_rate = 0.0", "mistake_rate = 1.0");
        let runs: Vec<_> = (0..20).map(|seed| play(&mut game(&careless, seed))).collect();
        let lost = runs.iter().filter(|r| r.0 == "player").collect::<Vec<_>>();
        assert!(!lost.is_empty(), "a character playing at random loses some games");
        for (_, events) in lost {
            assert_eq!(events.last(), Some(&Event::Lose));
            assert!(events.contains(&Event::MissedBlock), "{events:?}");
        }
        // The same seed plays the same game.
        assert_eq!(play(&mut game(&careless, 3)), play(&mut game(&careless, 3)));
    }

    #[test]
    fn bad_game_files_say_where() {
        let cases = [
            ("x = 1", "unknown key `x`"),
            ("ponder_seconds = -1", "`ponder_seconds` must be"),
            ("mistake_rate = 2", "`mistake_rate` must be"),
            (
                "[[win]]\nsteps = [{ type = \"transition\", to = \"hapy\" }]",
                "[[win]] script 1, step 1: unknown label `hapy`",
            ),
            ("[[win]]\nsteps = [{ type = \"jump\" }]", "step 1: not a command"),
            ("[[win]]\nsteps = []", "0 steps"),
            ("[[lose]]\nsteps = [{ type = \"idle\", hold = 1e9 }]", "`hold` must be"),
            ("[[lose]]\nfile = \"/etc/passwd\"\nsteps = [{ type = \"idle\" }]", "unknown key `file`"),
            ("win = 3", "must be an array of tables"),
            ("[[ponder", "not TOML"),
        ];
        for (text, want) in cases {
            let e = GameFile::parse(text, &labels()).expect_err(text);
            assert!(e.contains(want), "{text}: {e}");
        }
        let f = GameFile::parse(FILE, &labels()).unwrap();
        assert_eq!(f.scripts(Event::Ponder)[0].name, "think");
        assert_eq!(f.scripts(Event::PlayerTurn)[0].name, "[[player-turn]] script 1");
        assert!(f.scripts(Event::Draw).is_empty());
    }
}
