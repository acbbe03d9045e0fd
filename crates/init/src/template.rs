//! The files `init` writes besides the labels: the pipeline and a demo script.

use std::fmt::Write as _;

use reprise_artifact::segments::Segment;
use reprise_runner::error::{Error, Result};
use reprise_stagekit::wiring::{Need, Wiring};

/// The source `init` was given, as the pipeline will name it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A glTF character, relative to the pipeline directory.
    Gltf(String),
    /// BVH takes: one file or glob (`inputs.bvh = "…"`), or several (a list).
    Bvh(Vec<String>),
    /// A curve table and the command of its rig evaluator.
    Curves {
        /// The table, relative to the pipeline directory.
        table: String,
        /// The rig evaluator's program and arguments.
        rig: Vec<String>,
    },
}

/// A TOML string literal.
pub(crate) fn quoted(text: &str) -> String {
    toml::Value::String(text.to_string()).to_string()
}

/// The parameters `init` sets for a new character where its choice differs from the
/// stage's own default: `(stage, line, comment)`. Everything else is the stage's default
/// (`crates/reprise/tests/init_template.rs` checks that each of these differs from it and
/// names a flag the stage has).
pub const CHOICES: &[(&str, &str, &str)] = &[
    ("gplvm", "heldout_every = 10", "leave out every 10th frame and compare with PCA"),
    ("synthesize", "radius = 0.2", ""),
    ("motion-graph", "quantile = 0.2", ""),
];

/// The demo script's path, relative to the pipeline.
pub const DEMO_SCRIPT: &str = "scripts/demo.toml";

/// The game file's path, relative to the pipeline (where `reprise serve` looks for it).
pub const GAME_FILE: &str = "game.toml";

/// The game's events in the file's order, with what the paper's character does.
const GAME_EVENTS: [(&str, &str); 6] = [
    ("player-turn", "the player's turn (the paper's dragon squints and scowls)"),
    ("ponder", "the character's turn, deliberately long (a ponderous expression)"),
    ("win", "the character won (happy)"),
    ("lose", "the character lost (it roars)"),
    ("missed-block", "its move left the player a winning square (surprise)"),
    ("draw", "a draw"),
];

/// Stages of other jobs, left out of the pipeline `init` writes: inverse rig mapping makes
/// curves from positions (docs/invrig.md) and retargeting makes them from a capture
/// (docs/retarget.md); a new character's source already has curves.
pub const OTHER_JOBS: [&str; 7] = [
    "positions",
    "invrig-fit",
    "invrig-apply",
    "retarget-oracle",
    "retarget-fit",
    "retarget-apply",
    "retarget-compare",
];

/// The pipeline file: a stage table for every stage the runner knows (`known`, in their
/// order; `export-gltf` only for a glTF character; none of [`OTHER_JOBS`]), each with only what differs from its
/// defaults: the source, the labels, the demo script, `fps` if given and [`CHOICES`]; every artifact is
/// wired by its declaration. A user's file a stage needs that `init` cannot name is an
/// error.
pub fn pipeline_text(known: &[Wiring], name: &str, source: &Source, fps: Option<f64>, labels: &str) -> Result<String> {
    let mut t = String::new();
    let what = match source {
        Source::Gltf(_) => "a glTF character",
        Source::Bvh(_) => "BVH takes",
        Source::Curves { .. } => "a curve table",
    };
    let _ = writeln!(t, "# reprise pipeline for {what}, written by `reprise init`: ingest to the comparison report.");
    let _ = writeln!(t, "# Run it with `reprise run --pipeline <this file>`. Paths are relative to this file;");
    let _ = writeln!(
        t,
        "# inputs and outputs are wired by artifact (docs/pipeline.md, \"Wiring\"), so only your own files"
    );
    let _ = writeln!(t, "# are named. Edit the labels file to group clips by what they mean, then run again:");
    let _ = writeln!(t, "# only what changed reruns. Every parameter not written here is the stage's own");
    let _ = writeln!(t, "# default (`reprise-<stage> --help`).\n");
    let _ = writeln!(t, "[pipeline]\nname = {}", quoted(name));
    for w in known {
        if (w.stage == "export-gltf" && !matches!(source, Source::Gltf(_))) || OTHER_JOBS.contains(&w.stage) {
            continue;
        }
        let _ = write!(t, "\n[stage.{}]", w.stage);
        if w.stage == "export-gltf" {
            t.push_str("            # the character with the synthesized scripts added");
        }
        t.push('\n');
        for input in w.inputs.iter().filter(|i| matches!(i.need, Need::Source | Need::OptionalSource)) {
            if let Some(line) = source_line(w.stage, input.role, source, labels) {
                let _ = writeln!(t, "{line}");
            } else if input.need == Need::Source {
                return Err(Error::Init(format!(
                    "stage `{}` needs your own {} (`inputs.{}`), which init does not know how to name",
                    w.stage, input.artifact, input.role
                )));
            }
        }
        let mut params: Vec<String> = CHOICES
            .iter()
            .filter(|(stage, ..)| *stage == w.stage)
            .map(|(_, line, why)| if why.is_empty() { (*line).to_string() } else { format!("{line:<30} # {why}") })
            .collect();
        if w.stage == "ingest" {
            if let Some(fps) = fps {
                params.push(format!("fps = {fps:?}"));
            }
            if let Source::Curves { rig, .. } = source {
                let list: Vec<String> = rig.iter().map(|a| quoted(a)).collect();
                params.push(format!("external_rig = [{}]", list.join(", ")));
            }
        }
        if !params.is_empty() {
            let _ = writeln!(t, "[stage.{}.params]\n{}", w.stage, params.join("\n"));
        }
    }
    Ok(t)
}

/// The `inputs.ROLE = …` line naming a user's file, where `init` knows it.
fn source_line(stage: &str, role: &str, source: &Source, labels: &str) -> Option<String> {
    let path = match (stage, role, source) {
        ("ingest", "gltf", Source::Gltf(path)) | ("ingest", "curves", Source::Curves { table: path, .. }) => {
            quoted(path)
        }
        ("ingest", "bvh", Source::Bvh(takes)) if takes.len() == 1 => quoted(&takes[0]),
        ("ingest", "bvh", Source::Bvh(takes)) => {
            let list: Vec<String> = takes.iter().map(|t| quoted(t)).collect();
            format!("[{}]", list.join(", "))
        }
        ("label", "labels", _) => quoted(labels),
        ("synthesize", "scripts", _) => quoted(DEMO_SCRIPT),
        _ => return None,
    };
    Some(format!("inputs.{role} = {path}"))
}

/// A demo script for `synthesize`: from the first frame of the first label's longest
/// segment, hover, play that segment's clip, hover again. A transition needs a bridge,
/// which only the fit can tell, so it is an example left commented out.
pub fn script_text(segments: &[Segment]) -> Result<String> {
    let first = segments.first().ok_or_else(|| Error::Init("the labels leave no segment to model".into()))?;
    let start = segments
        .iter()
        .filter(|s| s.label == first.label)
        .max_by_key(|s| (s.end - s.start, std::cmp::Reverse(s.segment_id)))
        .unwrap_or(first);
    let other = segments.iter().find(|s| s.label != first.label);
    let mut t = String::from(
        "# A demo script written by `reprise init` (format: docs/stages.md, \"curves and the script format\").\n\
         # Edit freely: `synthesize` plays every [[script]] of this file.\n\n",
    );
    let _ = writeln!(
        t,
        "[[script]]\nname = \"demo\"\nseed = 1\nstart = {{ label = {}, clip = {}, frame = {} }}\n\n\
         [[script.command]]\ntype = \"idle\"\nduration = 1.0\n\n\
         [[script.command]]\ntype = \"play\"\nclip = {}\n\n\
         [[script.command]]\ntype = \"idle\"\nduration = 1.0",
        quoted(&start.label),
        quoted(&start.clip),
        start.start,
        quoted(&start.clip)
    );
    if let Some(other) = other {
        let _ = writeln!(
            t,
            "\n# Once the report shows a bridge between the two labels (its \"bridges\" table), a\n\
             # transition carries the motion across; uncomment to add one:\n\
             # [[script.command]]\n# type = \"transition\"\n# to = {}",
            quoted(&other.label)
        );
    }
    Ok(t)
}

/// A game file for `reprise serve` (docs/live.md, "The game"): each event reacts with a
/// TRANSITION to one of the labels, taken in turn (which label suits which event only
/// the user knows: the file says to edit it), then an IDLE; the game-ending events get a
/// second script that plays the label's longest take.
pub fn game_text(segments: &[Segment]) -> Result<String> {
    let mut labels: Vec<&str> = Vec::new();
    for s in segments {
        if !labels.contains(&s.label.as_str()) {
            labels.push(&s.label);
        }
    }
    if labels.is_empty() {
        return Err(Error::Init("the labels leave no segment to model".into()));
    }
    let longest = |label: &str| {
        segments.iter().filter(|s| s.label == label).max_by_key(|s| (s.frames(), std::cmp::Reverse(s.segment_id)))
    };
    let mut t = String::from(
        "# The Tic-Tac-Toe game of `reprise serve` (the paper's §6), written by `reprise init`.\n\
         # Per game event, a set of scripts; the game picks one at random under the session's seed.\n\
         # A step is a live command (docs/live.md, \"Commands\") and `hold`, the seconds until the\n\
         # next step. The labels below were assigned in turn: give each event the label that\n\
         # suits it, and add scripts (more [[event]] tables) for variety.\n\n\
         ponder_seconds = 3.0   # the character's turn, deliberately long\n\
         mistake_rate = 0.3     # share of its moves that are a random free square: it can lose\n",
    );
    for (i, (event, what)) in GAME_EVENTS.iter().enumerate() {
        let label = labels[i % labels.len()];
        let _ = writeln!(
            t,
            "\n# {what}\n[[{event}]]\nname = \"{event}\"\nsteps = [{{ type = \"transition\", to = {}, hold = 1.0 }}, \
             {{ type = \"idle\", radius = 0.3 }}]",
            quoted(label)
        );
        if let Some(take) = longest(label).filter(|_| matches!(*event, "win" | "lose" | "draw")) {
            let _ = writeln!(
                t,
                "[[{event}]]\nname = \"{event} take\"\nsteps = [{{ type = \"transition\", to = {}, hold = 3.0 }}, \
                 {{ type = \"play\", clip = {} }}]",
                quoted(label),
                quoted(&take.clip)
            );
        }
    }
    Ok(t)
}
