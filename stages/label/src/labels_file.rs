//! The labels file, in TOML or CSV.
//!
//! TOML holds three lists, each entry named in errors by its list and position
//! (`range 2` is the second `[[range]]`):
//! ```toml
//! [[rule]]      # whole clips whose name matches a glob get a label; first match wins
//! pattern = "happy_take*"
//! label = "happy"
//! [[range]]     # an inclusive frame range of one clip; overrides rules
//! clip = "mix_take01"
//! start = 0
//! end = 119
//! label = "roar"
//! [[exclude]]   # frames no label may use: a clip or a pattern, optionally a range
//! clip = "grumpy_take05"
//! start = 10    # optional, with end
//! end = 40
//! reason = "camera cheat"
//! ```
//! CSV has the columns `clip,start,end,label` (one range per line; empty start and end
//! mean the whole clip) and optionally `reason`. In both forms the label `!exclude`
//! excludes (a TOML rule or range with it is an exclusion); an empty label, one with
//! spaces around it, or any other starting with `!` is refused.

use std::path::Path;

use globset::{Glob, GlobMatcher};
use reprise_stagekit::{StageError, StageResult};
use serde::Deserialize;

/// Which clips an entry applies to.
#[derive(Debug, Clone)]
pub(crate) enum Target {
    /// One clip by name.
    Clip(String),
    /// Every clip whose name matches.
    Pattern(GlobMatcher),
}

impl Target {
    pub(crate) fn matches(&self, clip: &str) -> bool {
        match self {
            Self::Clip(name) => name == clip,
            Self::Pattern(glob) => glob.is_match(clip),
        }
    }
    pub(crate) fn describe(&self) -> String {
        match self {
            Self::Clip(name) => format!("clip `{name}`"),
            Self::Pattern(glob) => format!("pattern `{}`", glob.glob()),
        }
    }
}

/// One labeling or exclusion entry.
#[derive(Debug, Clone)]
pub(crate) struct Entry {
    /// Where it is in the file, for messages: `rule 2`, `range 1`, `line 5`.
    pub(crate) origin: String,
    pub(crate) target: Target,
    /// Inclusive frame range; `None` = the whole clip.
    pub(crate) range: Option<(i64, i64)>,
    /// The label, or `None` for an exclusion.
    pub(crate) label: Option<String>,
    /// Why frames are excluded (exclusions only).
    pub(crate) reason: String,
}

impl Entry {
    /// Ranges and single-clip entries are explicit; patterns are rules.
    pub(crate) fn is_rule(&self) -> bool {
        matches!(self.target, Target::Pattern(_)) && self.label.is_some()
    }
}

/// The whole labels file.
#[derive(Debug, Clone)]
pub(crate) struct LabelsFile {
    pub(crate) entries: Vec<Entry>,
    /// Labels in order of first appearance.
    pub(crate) labels: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlFile {
    #[serde(default)]
    rule: Vec<TomlRule>,
    #[serde(default)]
    range: Vec<TomlRange>,
    #[serde(default)]
    exclude: Vec<TomlExclude>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlRule {
    pattern: String,
    label: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlRange {
    clip: String,
    start: i64,
    end: i64,
    label: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlExclude {
    clip: Option<String>,
    pattern: Option<String>,
    start: Option<i64>,
    end: Option<i64>,
    #[serde(default)]
    reason: String,
}

fn glob(path: &Path, origin: &str, pattern: &str) -> StageResult<GlobMatcher> {
    Glob::new(pattern)
        .map(|g| g.compile_matcher())
        .map_err(|e| StageError::Input(format!("{}: {origin}: bad pattern `{pattern}`: {e}", path.display())))
}

fn range(path: &Path, origin: &str, start: Option<i64>, end: Option<i64>) -> StageResult<Option<(i64, i64)>> {
    match (start, end) {
        (None, None) => Ok(None),
        (Some(s), Some(e)) if s <= e && s >= 0 => Ok(Some((s, e))),
        (Some(s), Some(e)) => Err(StageError::Input(format!(
            "{}: {origin}: frame range {s}..={e} is empty or negative; start and end are inclusive frame numbers from 0",
            path.display()
        ))),
        _ => Err(StageError::Input(format!("{}: {origin}: give both start and end, or neither", path.display()))),
    }
}

impl LabelsFile {
    /// Reads a `.toml` or `.csv` labels file.
    pub(crate) fn read(path: &Path) -> StageResult<Self> {
        let text = reprise_artifact::input::read_text(path, reprise_artifact::input::MAX_TEXT_BYTES)
            .map_err(|e| StageError::Input(e.to_string()))?;
        Self::parse(path, &text)
    }

    /// Parses `text` as the labels file `path` (its extension says the format).
    pub(crate) fn parse(path: &Path, text: &str) -> StageResult<Self> {
        let entries = match path.extension().and_then(|e| e.to_str()) {
            Some("toml") => Self::parse_toml(path, text)?,
            Some("csv") => Self::parse_csv(path, text)?,
            _ => return Err(StageError::Input(format!("{}: a labels file is .toml or .csv", path.display()))),
        };
        let mut labels: Vec<String> = Vec::new();
        for label in entries.iter().filter_map(|e| e.label.as_ref()) {
            if !labels.contains(label) {
                labels.push(label.clone());
            }
        }
        if labels.is_empty() {
            return Err(StageError::Input(format!("{}: no labels: the file has no rule or range", path.display())));
        }
        Ok(Self { entries, labels })
    }

    fn parse_toml(path: &Path, text: &str) -> StageResult<Vec<Entry>> {
        let file: TomlFile = toml::from_str(text).map_err(|e| StageError::Input(format!("{}: {e}", path.display())))?;
        let mut entries = Vec::new();
        for (i, r) in file.rule.into_iter().enumerate() {
            let origin = format!("rule {}", i + 1);
            let target = Target::Pattern(glob(path, &origin, &r.pattern)?);
            let label = label_name(path, &origin, r.label)?;
            entries.push(Entry { origin, target, range: None, label, reason: String::new() });
        }
        for (i, r) in file.range.into_iter().enumerate() {
            let origin = format!("range {}", i + 1);
            let range = range(path, &origin, Some(r.start), Some(r.end))?;
            let label = label_name(path, &origin, r.label)?;
            entries.push(Entry { origin, target: Target::Clip(r.clip), range, label, reason: String::new() });
        }
        for (i, x) in file.exclude.into_iter().enumerate() {
            let origin = format!("exclude {}", i + 1);
            let target = match (x.clip, x.pattern) {
                (Some(clip), None) => Target::Clip(clip),
                (None, Some(p)) => Target::Pattern(glob(path, &origin, &p)?),
                _ => {
                    return Err(StageError::Input(format!(
                        "{}: {origin}: give exactly one of `clip` or `pattern`",
                        path.display()
                    )))
                }
            };
            let range = range(path, &origin, x.start, x.end)?;
            entries.push(Entry { origin, target, range, label: None, reason: x.reason });
        }
        Ok(entries)
    }

    fn parse_csv(path: &Path, text: &str) -> StageResult<Vec<Entry>> {
        let err = |m: String| StageError::Input(format!("{}: {m}", path.display()));
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
        let headers: Vec<String> = reader.headers().map_err(|e| err(e.to_string()))?.iter().map(String::from).collect();
        let col = |name: &str| headers.iter().position(|h| h == name);
        for h in &headers {
            if !["clip", "start", "end", "label", "reason"].contains(&h.as_str()) {
                return Err(err(format!("line 1: unknown column `{h}`; expected clip,start,end,label[,reason]")));
            }
        }
        let [clip, start, end, label] = ["clip", "start", "end", "label"]
            .map(|n| col(n).ok_or_else(|| err(format!("line 1: missing column `{n}`"))));
        let (clip, start, end, label, reason) = (clip?, start?, end?, label?, col("reason"));
        let mut entries = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| err(e.to_string()))?;
            let origin = format!("line {}", record.position().map_or(0, csv::Position::line));
            let cell = |i: usize| record.get(i).unwrap_or("").to_string();
            let frame = |i: usize| -> StageResult<Option<i64>> {
                let c = cell(i);
                if c.is_empty() {
                    return Ok(None);
                }
                c.parse()
                    .map(Some)
                    .map_err(|_| err(format!("{origin}, column `{}`: `{c}` is not a frame number", headers[i])))
            };
            let range = range(path, &origin, frame(start)?, frame(end)?)?;
            let name = cell(label);
            if cell(clip).is_empty() || name.is_empty() {
                return Err(err(format!("{origin}: clip and label must not be empty")));
            }
            let label = label_name(path, &origin, name)?;
            entries.push(Entry {
                origin,
                target: Target::Clip(cell(clip)),
                range,
                label,
                reason: reason.map(cell).unwrap_or_default(),
            });
        }
        Ok(entries)
    }
}

/// The label `!exclude` (in TOML and CSV alike) excludes: `None`. A label must be
/// non-empty, without surrounding spaces, and may not start with `!` otherwise (reserved).
fn label_name(path: &Path, origin: &str, name: String) -> StageResult<Option<String>> {
    let err = |why: &str| Err(StageError::Input(format!("{}: {origin}: label `{name}` {why}", path.display())));
    if name == EXCLUDE {
        Ok(None)
    } else if name.trim().is_empty() {
        err("is empty; give a name, or `!exclude` to exclude the frames")
    } else if name.trim() != name {
        err("has spaces around it")
    } else if name.starts_with('!') {
        err("starts with `!`, which is reserved: `!exclude` is the only such label")
    } else {
        Ok(Some(name))
    }
}

/// The label that excludes frames instead of labeling them.
const EXCLUDE: &str = "!exclude";
