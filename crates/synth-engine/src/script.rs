//! The script format: a TOML file of timed commands (§5.3).
//!
//! ```toml
//! name = "reaction"                                   # optional; default: the file stem
//! seed = 1                                            # the random force's seed
//! start = { label = "neutral", segment = 20, frame = 0 }
//!
//! [[command]]
//! type = "idle"          # hover about the current point (or `poses`) within `radius`
//! duration = 2.0         # seconds
//! radius = 0.3
//! poses = [{ segment = 20, frame = 40 }, { clip = "neutral_take02", frame = 10 }]
//! hover = 0.8            # seconds at each pose
//!
//! [[command]]
//! type = "move"          # to a pose of the current label over `duration` seconds
//! to = { latent = [0.1, -0.4, 0.9] }
//! duration = 1.0
//! path = "graph"         # or "straight"
//!
//! [[command]]
//! type = "transition"    # to another label through the nearest bridge
//! to = "roar"
//! blend_frames = 12
//!
//! [[command]]
//! type = "play"          # a training segment of the current label, through its embedding
//! segment = 14           # or clip = "roar_take01"
//! ```
//!
//! A pose names a training frame of the current label by `segment` (id) or `clip`, and
//! `frame` (the clip's frame number), or a latent point directly (`latent`).

use serde::{Deserialize, Serialize};

/// A pose in the current label.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Segment id.
    pub segment: Option<i64>,
    /// Clip name.
    pub clip: Option<String>,
    /// Frame number in the clip.
    pub frame: Option<i64>,
    /// A latent point instead.
    pub latent: Option<Vec<f64>>,
}

/// The starting pose and label.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Start {
    /// The starting label.
    pub label: String,
    /// Segment id.
    pub segment: Option<i64>,
    /// Clip name.
    pub clip: Option<String>,
    /// Frame number.
    pub frame: Option<i64>,
    /// A latent point instead.
    pub latent: Option<Vec<f64>>,
}

impl Start {
    /// The pose part.
    pub fn pose(&self) -> Pose {
        Pose { segment: self.segment, clip: self.clip.clone(), frame: self.frame, latent: self.latent.clone() }
    }
}

/// How MOVE goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum PathKind {
    /// Shortest path through the training points (cost ‖Δ‖^p).
    #[default]
    Graph,
    /// Straight line.
    Straight,
}

/// One command.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Command {
    /// Hover about poses.
    Idle {
        /// Seconds.
        duration: f64,
        /// Radius (latent units); default the engine's.
        radius: Option<f64>,
        /// Poses to hover about in turn; default the current point.
        #[serde(default)]
        poses: Vec<Pose>,
        /// Seconds at each pose (default: the whole duration over the poses).
        hover: Option<f64>,
    },
    /// Go to a pose.
    Move {
        /// Target.
        to: Pose,
        /// Seconds.
        duration: f64,
        /// Path shape.
        #[serde(default)]
        path: PathKind,
        /// Radius; default the engine's.
        radius: Option<f64>,
    },
    /// Switch label through a bridge.
    Transition {
        /// Target label.
        to: String,
        /// Rig-space blend length in frames (default 12).
        blend_frames: Option<usize>,
    },
    /// Play a training segment.
    Play {
        /// Segment id.
        segment: Option<i64>,
        /// Or the clip.
        clip: Option<String>,
    },
}

/// The longest command a script may ask for, seconds (an hour: the engine allocates
/// `duration × fps` frames per command, so a typo such as `duration = 1e9` is refused
/// when the script is read, naming the command, instead of exhausting memory).
pub const MAX_SECONDS: f64 = 3600.0;

/// The longest blend a `transition` may ask for, frames (an hour at 1000 fps).
pub const MAX_BLEND_FRAMES: usize = 3_600_000;

/// A parsed script.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    /// Name (default: the file stem).
    pub name: Option<String>,
    /// Seed of the random force (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Where it starts.
    pub start: Start,
    /// The commands, in order.
    #[serde(default, rename = "command")]
    pub commands: Vec<Command>,
}

impl Command {
    /// The command as a person wrote it, for messages: `idle 1.5 s`, `transition to `happy``.
    pub fn describe(&self) -> String {
        match self {
            Self::Idle { duration, .. } => format!("idle {duration} s"),
            Self::Move { duration, .. } => format!("move over {duration} s"),
            Self::Transition { to, .. } => format!("transition to `{to}`"),
            Self::Play { segment, clip } => format!("play {}", segment_or_clip(*segment, clip.as_deref())),
        }
    }
}

/// `segment 3`, `clip `x``, `segment 3 of clip `x`` or `no segment or clip`, for messages.
pub fn segment_or_clip(segment: Option<i64>, clip: Option<&str>) -> String {
    match (segment, clip) {
        (Some(s), Some(c)) => format!("segment {s} of clip `{c}`"),
        (Some(s), None) => format!("segment {s}"),
        (None, Some(c)) => format!("clip `{c}`"),
        (None, None) => "no segment or clip".into(),
    }
}

impl Script {
    /// Parses TOML text; errors carry the line and column.
    pub fn parse(text: &str) -> Result<Self, String> {
        let s: Script = toml::from_str(text).map_err(|e| e.to_string())?;
        s.validate()?;
        Ok(s)
    }

    /// Parses a file of one script, or of several as `[[script]]` tables (each needing a
    /// `name`); `stem` names a single unnamed script.
    pub fn parse_file(text: &str, stem: &str) -> Result<Vec<Self>, String> {
        let table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        let Some(list) = table.get("script") else {
            let mut s = Self::parse(text)?;
            s.name.get_or_insert_with(|| stem.to_string());
            return Ok(vec![s]);
        };
        if table.len() != 1 {
            return Err("a file with [[script]] tables may hold nothing else".into());
        }
        let list = list.as_array().ok_or("`script` must be an array of tables ([[script]])")?;
        let scripts = list
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let s = Script::deserialize(v.clone()).map_err(|e| format!("script {}: {e}", i + 1))?;
                if s.name.is_none() {
                    return Err(format!("script {} needs a `name`", i + 1));
                }
                s.validate().map_err(|e| format!("script `{}`: {e}", s.name.as_deref().unwrap_or("")))?;
                Ok(s)
            })
            .collect::<Result<Vec<_>, String>>()?;
        let mut names: Vec<&str> = scripts.iter().filter_map(|s| s.name.as_deref()).collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("two scripts are named `{}`", w[0]));
        }
        Ok(scripts)
    }

    fn validate(&self) -> Result<(), String> {
        let s = self;
        let pos = |v: f64| v > 0.0 && v.is_finite();
        let secs = |v: f64| pos(v) && v <= MAX_SECONDS;
        let mut label = s.start.label.as_str();
        for (i, c) in s.commands.iter().enumerate() {
            let bad = |what: &str| Err(format!("command {} ({}): {what}", i + 1, c.describe()));
            match c {
                Command::Idle { duration, radius, hover, .. } => {
                    if !secs(*duration) || radius.is_some_and(|r| !pos(r)) || hover.is_some_and(|h| !secs(h)) {
                        return bad(&format!(
                            "duration, radius and hover must be positive (duration and hover at most {MAX_SECONDS} s)"
                        ));
                    }
                }
                Command::Move { duration, radius, .. } => {
                    if !secs(*duration) || radius.is_some_and(|r| !pos(r)) {
                        return bad(&format!(
                            "duration and radius must be positive (duration at most {MAX_SECONDS} s)"
                        ));
                    }
                }
                Command::Transition { blend_frames, to } => {
                    if blend_frames.is_some_and(|b| b == 0 || b > MAX_BLEND_FRAMES) {
                        return bad(&format!("blend_frames must be at least 1 and at most {MAX_BLEND_FRAMES}"));
                    }
                    if to == label {
                        let since = if s.commands[..i].iter().any(|c| matches!(c, Command::Transition { .. })) {
                            "an earlier TRANSITION went there"
                        } else {
                            "it starts there"
                        };
                        return bad(&format!(
                            "the character is already in `{to}` ({since}); a TRANSITION must change the label \
                             (use IDLE or MOVE to stay)"
                        ));
                    }
                    label = to;
                }
                Command::Play { segment, clip } => {
                    if segment.is_some() == clip.is_some() {
                        return bad("give exactly one of segment and clip");
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A TRANSITION to the label the character is in made 0 frames and said nothing; now
    /// the script is refused, naming the command in words (not a Rust debug form).
    #[test]
    fn a_transition_to_the_current_label_is_refused() {
        let text = |to: &str| {
            format!(
                "start = {{ label = \"roar\" }}\n[[command]]\ntype = \"transition\"\nto = \"happy\"\n\
                 [[command]]\ntype = \"idle\"\nduration = 1.0\n[[command]]\ntype = \"transition\"\nto = \"{to}\"\n"
            )
        };
        let e = Script::parse(&text("happy")).unwrap_err();
        assert_eq!(
            e,
            "command 3 (transition to `happy`): the character is already in `happy` (an earlier TRANSITION went \
             there); a TRANSITION must change the label (use IDLE or MOVE to stay)"
        );
        assert!(Script::parse(&text("roar")).is_ok(), "back to the start label is a change");
        let e = Script::parse("start = { label = \"roar\" }\n[[command]]\ntype = \"transition\"\nto = \"roar\"\n")
            .unwrap_err();
        assert!(e.contains("(it starts there)"), "{e}");
        let e =
            Script::parse("start = { label = \"a\" }\n[[command]]\ntype = \"idle\"\nduration = -1.0\n").unwrap_err();
        assert!(e.starts_with("command 1 (idle -1 s): duration") && !e.contains("Idle {"), "{e}");
        assert_eq!(segment_or_clip(None, Some("x")), "clip `x`");
        assert_eq!(segment_or_clip(Some(2), None), "segment 2");
    }

    /// Every command parses; unknown keys and bad values are errors naming the place.
    #[test]
    fn parses_and_refuses() {
        let s = Script::parse(
            r#"
            seed = 3
            start = { label = "roar", segment = 2, frame = 0 }
            [[command]]
            type = "idle"
            duration = 1.5
            [[command]]
            type = "move"
            to = { latent = [0.0, 1.0, 2.0] }
            duration = 1.0
            path = "straight"
            [[command]]
            type = "transition"
            to = "happy"
            [[command]]
            type = "play"
            clip = "happy_take01"
            "#,
        )
        .unwrap();
        assert_eq!(s.commands.len(), 4);
        assert!(matches!(s.commands[1], Command::Move { path: PathKind::Straight, .. }));
        let e = Script::parse("start = { label = \"a\" }\n[[command]]\ntype = \"idle\"\nduration = 1.0\nradus = 2.0\n");
        assert!(e.unwrap_err().contains("radus"));
        let e = Script::parse("start = { label = \"a\" }\n[[command]]\ntype = \"play\"\n");
        assert!(e.unwrap_err().contains("exactly one"));
    }
}
