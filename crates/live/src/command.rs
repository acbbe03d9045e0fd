//! The commands a live character takes, as a client sends them (JSON, one object per
//! message) and as a session's log records them.
//!
//! ```json
//! {"type": "transition", "to": "roar"}
//! {"type": "transition", "to": "roar", "blend_frames": 8}
//! {"type": "idle", "radius": 0.3}
//! {"type": "move", "to": {"segment": 20, "frame": 40}, "duration": 1.0}
//! {"type": "play", "clip": "roar_take01"}
//! ```
//!
//! `transition` is "go to this label", which every system answers its own way. The others
//! are the paper's: reprise obeys them all; a system without a latent point (Motion Graphs,
//! motion matching, crossfade) answers `play` by going to the take, and has nothing to do
//! for `idle` and `move` (it says so; its motion goes on).

use reprise_synth_engine::script::{PathKind, Pose};
use serde::{Deserialize, Serialize};

/// The longest MOVE a live command may ask for, seconds.
pub const MAX_MOVE_SECONDS: f64 = 60.0;
/// The longest blend a live TRANSITION may ask for, frames.
pub const MAX_BLEND_FRAMES: usize = 240;
/// The largest IDLE or MOVE radius, latent units (the latent spaces span a few units).
pub const MAX_RADIUS: f64 = 100.0;
/// The most latent dimensions a pose may give.
pub const MAX_LATENT_DIMS: usize = 64;

/// One command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum LiveCommand {
    /// Go to a label.
    Transition {
        /// The label.
        to: String,
        /// The blend, frames (reprise and the crossfade; default theirs).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        blend_frames: Option<usize>,
    },
    /// Hover about the current point until the next command (reprise).
    Idle {
        /// Radius, latent units (default the engine's).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        radius: Option<f64>,
    },
    /// Go to a pose of the current label (reprise), then hover there.
    Move {
        /// The pose: a training frame (`segment` or `clip`, and `frame`) or a `latent` point.
        to: Pose,
        /// At least this many seconds.
        #[serde(default = "one_second")]
        duration: f64,
        /// Through the training points (`graph`) or `straight`.
        #[serde(default)]
        path: PathKind,
    },
    /// Play a take of the current label (`segment` id or `clip` name), then go on.
    Play {
        /// Segment id.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        segment: Option<i64>,
        /// Clip name.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        clip: Option<String>,
    },
}

/// A client's message: a command, or a game action ([`crate::game::Action`]: `new-game`,
/// `mark`).
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// A command.
    Command(LiveCommand),
    /// A game action.
    Game(crate::game::Action),
}

impl Message {
    /// Parses one message: a game action by its `type`, otherwise a command
    /// ([`LiveCommand::parse`]).
    pub fn parse(text: &str, labels: &[String]) -> Result<Self, String> {
        #[derive(Deserialize)]
        struct Tag {
            #[serde(rename = "type")]
            kind: Option<String>,
        }
        let tag: Option<String> = serde_json::from_str::<Tag>(text).ok().and_then(|t| t.kind);
        match tag.as_deref() {
            Some("new-game" | "mark") => {
                serde_json::from_str(text).map(Message::Game).map_err(|e| format!("not a game action: {e}"))
            }
            _ => LiveCommand::parse(text, labels).map(Message::Command),
        }
    }
}

fn one_second() -> f64 {
    1.0
}

impl LiveCommand {
    /// Parses and checks one message: the shape, finite numbers in range, and a label
    /// among `labels`. The error says what is wrong, for the client.
    pub fn parse(text: &str, labels: &[String]) -> Result<Self, String> {
        let c: Self = serde_json::from_str(text).map_err(|e| format!("not a command: {e}"))?;
        c.check(labels)?;
        Ok(c)
    }

    /// Checks numbers and names (see [`LiveCommand::parse`]).
    pub fn check(&self, labels: &[String]) -> Result<(), String> {
        let radius_ok = |r: Option<f64>| r.is_none_or(|r| r.is_finite() && r > 0.0 && r <= MAX_RADIUS);
        match self {
            LiveCommand::Transition { to, blend_frames } => {
                if !labels.iter().any(|l| l == to) {
                    return Err(format!("unknown label `{to}`; the labels are: {}", labels.join(", ")));
                }
                if blend_frames.is_some_and(|k| k == 0 || k > MAX_BLEND_FRAMES) {
                    return Err(format!("blend_frames must be 1..={MAX_BLEND_FRAMES}"));
                }
            }
            LiveCommand::Idle { radius } if !radius_ok(*radius) => {
                return Err(format!("radius must be in (0, {MAX_RADIUS}]"));
            }
            LiveCommand::Idle { .. } => {}
            LiveCommand::Move { to, duration, .. } => {
                if !(duration.is_finite() && *duration > 0.0 && *duration <= MAX_MOVE_SECONDS) {
                    return Err(format!("duration must be in (0, {MAX_MOVE_SECONDS}] seconds"));
                }
                if let Some(x) = &to.latent {
                    if x.len() > MAX_LATENT_DIMS || x.iter().any(|v| !v.is_finite()) {
                        return Err(format!("a latent pose is at most {MAX_LATENT_DIMS} finite numbers"));
                    }
                } else if to.frame.is_none() {
                    return Err("a pose needs `frame` (with `segment` or `clip`) or `latent`".into());
                }
            }
            LiveCommand::Play { segment, clip } => {
                if segment.is_none() && clip.is_none() {
                    return Err("play needs `segment` or `clip`".into());
                }
            }
        }
        Ok(())
    }

    /// The label a `transition` goes to.
    pub fn label(&self) -> Option<&str> {
        match self {
            LiveCommand::Transition { to, .. } => Some(to),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels() -> Vec<String> {
        vec!["neutral".into(), "roar".into()]
    }

    #[test]
    fn good_commands_parse_and_round_trip() {
        for text in [
            r#"{"type":"transition","to":"roar"}"#,
            r#"{"type":"transition","to":"roar","blend_frames":8}"#,
            r#"{"type":"idle"}"#,
            r#"{"type":"idle","radius":0.3}"#,
            r#"{"type":"move","to":{"segment":2,"frame":4},"duration":1.5,"path":"straight"}"#,
            r#"{"type":"move","to":{"latent":[0.1,0.2,0.3]}}"#,
            r#"{"type":"play","clip":"roar_take01"}"#,
        ] {
            let c = LiveCommand::parse(text, &labels()).unwrap_or_else(|e| panic!("{text}: {e}"));
            let again = serde_json::to_string(&c).unwrap();
            assert_eq!(LiveCommand::parse(&again, &labels()).unwrap(), c, "{again}");
        }
    }

    #[test]
    fn messages_are_commands_or_game_actions() {
        use crate::game::Action;
        let m = |t: &str| Message::parse(t, &labels());
        assert_eq!(m(r#"{"type":"mark","cell":4}"#).unwrap(), Message::Game(Action::Mark { cell: 4 }));
        assert_eq!(m(r#"{"type":"new-game"}"#).unwrap(), Message::Game(Action::NewGame { character_first: false }));
        assert!(matches!(m(r#"{"type":"idle"}"#).unwrap(), Message::Command(LiveCommand::Idle { .. })));
        assert!(m(r#"{"type":"mark","cell":-1}"#).unwrap_err().contains("not a game action"));
        assert!(m(r#"{"type":"mark","cell":1,"x":2}"#).unwrap_err().contains("unknown field"));
        assert!(m(r#"{"type":"sneeze"}"#).unwrap_err().contains("not a command"));
    }

    #[test]
    fn bad_commands_say_what_is_wrong() {
        let cases = [
            ("", "not a command"),
            ("[1,2]", "not a command"),
            (r#"{"type":"jump"}"#, "not a command"),
            (r#"{"type":"transition"}"#, "not a command"),
            (r#"{"type":"transition","to":"sneeze"}"#, "unknown label `sneeze`"),
            (r#"{"type":"transition","to":"roar","blend_frames":0}"#, "blend_frames"),
            (r#"{"type":"transition","to":"roar","blend_frames":100000}"#, "blend_frames"),
            (r#"{"type":"transition","to":"roar","file":"/etc/passwd"}"#, "unknown field"),
            (r#"{"type":"idle","radius":-1}"#, "radius"),
            (r#"{"type":"idle","radius":1e300}"#, "radius"),
            (r#"{"type":"move","to":{"latent":[1e999]}}"#, "not a command"),
            (r#"{"type":"move","to":{"segment":1}}"#, "needs `frame`"),
            (r#"{"type":"move","to":{"segment":1,"frame":2},"duration":1e9}"#, "duration"),
            (r#"{"type":"play"}"#, "needs `segment` or `clip`"),
        ];
        for (text, want) in cases {
            let e = LiveCommand::parse(text, &labels()).expect_err(text);
            assert!(e.contains(want), "{text}: {e}");
        }
    }
}
