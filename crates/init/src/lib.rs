//! `reprise init`: a working pipeline for a new character, from its source alone.
//!
//! From a glTF character, BVH takes (files or a glob) or a curve table, `init` writes
//! `pipeline.toml` (every stage from ingest to the report, with the shipped parameters),
//! a labels file with one label per clip unless one is given, and a demo script for
//! `synthesize`. Before writing anything it runs the pipeline's own `ingest` and `label`
//! stages on the source in a temporary directory, so the generated pipeline is checked
//! against the data: clips come from the source (glTF animations, BVH file stems, a
//! curve table's `clip` column), clips too short to model are excluded with a comment
//! that says so, and the demo script names a label and a clip that exist. Existing files
//! are refused unless `--force`; each file is written to a temporary name and renamed.

#![warn(missing_docs)]
// init reports through the runner's error type, so `reprise` prints its failures and maps
// their exit codes as it does its own; that type is as large as the runner's widest error.
#![allow(clippy::result_large_err)]

mod labels;
mod probe;
pub mod still;
mod template;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use reprise_artifact::segments::Segment;
use reprise_runner::cli::InitArgs;
use reprise_runner::error::{Error, Result};
use reprise_runner::locate::BinDirs;
use reprise_runner::paths::{absolute, relative, ArtifactPath};
use reprise_runner::pipeline::Pipeline;

pub use labels::{plan_labels, ClipInfo, Fate, LabelsPlan};
pub use template::{pipeline_text, script_text, Source, CHOICES, DEMO_SCRIPT, OTHER_JOBS};

/// The fewest frames a label needs: two 12-frame blend windows (the window of the
/// Motion Graphs baseline, the transition benchmark and the evaluation). A shorter clip
/// joins the clips that share the first word of its name, or is excluded.
pub const MIN_LABEL_FRAMES: i64 = 24;

/// Runs `reprise init`; what it wrote goes to `out`.
pub fn init(args: &InitArgs, dirs: &BinDirs, out: &mut dyn Write) -> Result<()> {
    let cwd = std::env::current_dir().map_err(|source| Error::Io { path: ".".into(), source })?;
    let pipeline_path = absolute(&cwd, &args.pipeline.pipeline);
    let dir = pipeline_path.parent().map_or_else(|| cwd.clone(), Path::to_path_buf);
    if let Some(fps) = args.fps.filter(|f| !(f.is_finite() && *f > 0.0)) {
        return Err(Error::Init(format!("--fps must be a positive number of frames per second, got {fps}")));
    }
    let source = resolve_source(args, &cwd, &dir)?;
    let name = match &args.name {
        Some(name) if reprise_runner::pipeline::valid_name(name) => name.clone(),
        Some(name) => {
            return Err(Error::Init(format!("--name `{name}`: use only lowercase letters, digits, `_` and `-`")))
        }
        None => default_name(args),
    };
    let labels_path = args.labels.as_ref().map(|l| absolute(&cwd, l));
    if let Some(path) = labels_path.as_ref().filter(|p| !p.is_file()) {
        return Err(Error::Init(format!("--labels `{}`: no such file", path.display())));
    }
    let generated_labels = dir.join("labels.toml");
    let scripts_path = dir.join(template::DEMO_SCRIPT);
    let game_path = dir.join(template::GAME_FILE);
    let mut to_write = vec![pipeline_path.clone(), scripts_path.clone(), game_path.clone()];
    if labels_path.is_none() {
        to_write.push(generated_labels.clone());
    }
    if !args.force {
        if let Some(existing) = to_write.iter().find(|p| p.exists()) {
            return Err(Error::InitExists { path: existing.clone() });
        }
    }
    let labels_ref = relative(&dir, labels_path.as_ref().unwrap_or(&generated_labels));
    let text = pipeline_text(dirs.known, &name, &source, args.fps, &labels_ref)?;
    let file = args.pipeline.pipeline.display().to_string();
    let pipeline = Pipeline::parse_wired(&text, &file, &dir, dirs.known)?;

    // Ingest, label, scale and reduce the source in a scratch directory, as `reprise run`
    // will; the stages run in the pipeline's directory, made now and removed again if
    // nothing gets written to it.
    let made_dir = !dir.exists();
    std::fs::create_dir_all(&dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
    let written = probe_and_write(
        dirs,
        &pipeline,
        &Files {
            labels: labels_path.as_deref(),
            labels_ref: &labels_ref,
            generated_labels: &generated_labels,
            scripts: &scripts_path,
            game: &game_path,
            pipeline: &pipeline_path,
        },
        &text,
    );
    if written.is_err() && made_dir {
        let _ = std::fs::remove_dir(&dir);
    }
    let (clips, plan, segments) = written?;
    let _ = write!(out, "{}", summary(&pipeline_path, &clips, plan.as_ref(), &segments, &cwd));
    Ok(())
}

/// Where `init` writes, and the labels it was given.
struct Files<'a> {
    /// `--labels`, absolute.
    labels: Option<&'a Path>,
    /// The labels file as the pipeline names it.
    labels_ref: &'a str,
    /// Where a generated labels file goes.
    generated_labels: &'a Path,
    /// The demo script.
    scripts: &'a Path,
    /// The game file for `reprise serve`.
    game: &'a Path,
    /// The pipeline file.
    pipeline: &'a Path,
}

/// Probes the source, then writes the labels (if generated), the script and the pipeline
/// `text`: the clips, the generated labels and the segments they make.
fn probe_and_write(
    dirs: &BinDirs,
    pipeline: &Pipeline,
    files: &Files<'_>,
    text: &str,
) -> Result<(Vec<ClipInfo>, Option<LabelsPlan>, Vec<Segment>)> {
    let dir = &pipeline.dir;
    let labels_ref = files.labels_ref;
    let probe = probe::Probe::new(pipeline, dirs)?;
    probe.run("ingest", None)?;
    let clips: Vec<ClipInfo> = reprise_artifact::clips::read(&probe.file("clips.parquet"))
        .map_err(|e| Error::Init(format!("reading what ingest wrote: {e}")))?
        .into_iter()
        .map(|c| ClipInfo { name: c.clip, frames: c.frames })
        .collect();
    let (plan, segments) = match files.labels {
        Some(_) => {
            let thin = probe.thin_labels(&ArtifactPath::new(dir, labels_ref))?;
            if let Some((label, why)) = thin.iter().next() {
                return Err(Error::Init(format!(
                    "{labels_ref}: label `{label}` {why}; exclude its clips or give it more of the motion"
                )));
            }
            (None, probe.segments()?)
        }
        None => {
            let mut plan = plan_labels(&clips, MIN_LABEL_FRAMES, &BTreeMap::new())?;
            let thin = probe.thin_labels(&probe.labels_file(&plan.text)?)?;
            if !thin.is_empty() {
                plan = plan_labels(&clips, MIN_LABEL_FRAMES, &thin)?;
                probe.run("label", Some(probe.labels_file(&plan.text)?))?;
            }
            (Some(plan), probe.segments()?)
        }
    };
    let script = script_text(&segments)?;
    let game = template::game_text(&segments)?;

    if let Some(plan) = &plan {
        write_atomic(files.generated_labels, &plan.text)?;
    }
    write_atomic(files.scripts, &script)?;
    write_atomic(files.game, &game)?;
    write_atomic(files.pipeline, text)?;
    Ok((clips, plan, segments))
}

/// The source as the pipeline names it (relative to `dir`), each file checked to exist.
fn resolve_source(args: &InitArgs, cwd: &Path, dir: &Path) -> Result<Source> {
    let file = |given: &Path, what: &str| -> Result<String> {
        let path = absolute(cwd, given);
        if path.is_file() {
            Ok(relative(dir, &path))
        } else {
            Err(Error::Init(format!("--{what} `{}`: no such file", given.display())))
        }
    };
    if let Some(gltf) = &args.gltf {
        return Ok(Source::Gltf(file(gltf, "gltf")?));
    }
    if let Some(table) = &args.curves {
        if args.external_rig.is_empty() {
            return Err(Error::Init(format!(
                "--curves `{}`: a curve table carries no rig, and the stages after label evaluate one (scale, \
                 bridges, evaluate); give its evaluator with --external-rig PROGRAM[,ARG…] (docs/inputs.md, \"Your own \
                 rig engine\")",
                table.display()
            )));
        }
        return Ok(Source::Curves { table: file(table, "curves")?, rig: args.external_rig.clone() });
    }
    let mut takes = Vec::new();
    for given in &args.bvh {
        if reprise_runner::paths::is_glob(given) {
            let (parent, pattern) = given.rsplit_once('/').unwrap_or((".", given));
            reprise_runner::paths::expand_glob(cwd, given)
                .map_err(|why| Error::Init(format!("--bvh `{given}`: {why}")))?;
            let folder = relative(dir, &absolute(cwd, Path::new(parent)));
            takes.push(if folder == "." { pattern.to_string() } else { format!("{folder}/{pattern}") });
        } else {
            takes.push(file(Path::new(given), "bvh")?);
        }
    }
    if takes.is_empty() {
        return Err(Error::Init("give a source: --gltf FILE, --bvh FILE… (or a quoted glob) or --curves FILE".into()));
    }
    Ok(Source::Bvh(takes))
}

/// The pipeline's name from the source's file name: lowercase, other characters as `-`.
fn default_name(args: &InitArgs) -> String {
    let from = args.gltf.as_deref().or(args.curves.as_deref()).map(Path::to_path_buf).or_else(|| {
        let first = Path::new(args.bvh.first()?);
        if args.bvh.len() == 1 && !reprise_runner::paths::is_glob(&args.bvh[0]) {
            Some(first.to_path_buf())
        } else {
            std::path::absolute(first).ok()?.parent().map(Path::to_path_buf)
        }
    });
    let stem = from.as_deref().and_then(Path::file_stem).map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let name = slug(&stem, '-');
    if name.is_empty() {
        "character".into()
    } else {
        name
    }
}

/// `text` in lowercase letters, digits and `_`, every other run of characters as `sep`,
/// without leading or trailing separators.
pub(crate) fn slug(text: &str, sep: char) -> String {
    let mut out = String::new();
    for c in text.chars() {
        if c.is_ascii_alphanumeric() || c == '_' {
            out.push(c.to_ascii_lowercase());
        } else if !out.is_empty() && !out.ends_with(sep) {
            out.push(sep);
        }
    }
    out.trim_end_matches(sep).to_string()
}

/// Writes `text` to `path` through a temporary file in the same directory and a rename.
fn write_atomic(path: &Path, text: &str) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let parent = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(io)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = parent.join(format!(".{name}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, text).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}

/// What `init` did, and the next command.
fn summary(pipeline: &Path, clips: &[ClipInfo], plan: Option<&LabelsPlan>, segments: &[Segment], cwd: &Path) -> String {
    let mut frames: Vec<(&str, i64)> = Vec::new();
    for s in segments {
        match frames.iter_mut().find(|(l, _)| *l == s.label) {
            Some((_, n)) => *n += s.end - s.start + 1,
            None => frames.push((&s.label, s.end - s.start + 1)),
        }
    }
    let shown = relative(cwd, pipeline);
    let dir = pipeline.parent().unwrap_or(Path::new("."));
    let mut t = format!("wrote {shown}\n");
    if let Some(plan) = plan {
        let _ = writeln!(t, "wrote {} (edit it: one label per clip to start)", relative(cwd, &dir.join("labels.toml")));
        for (clip, fate) in &plan.clips {
            match fate {
                Fate::Own(_) => {}
                Fate::Grouped(l) => {
                    let _ = writeln!(t, "  `{}` ({} frames) shares label `{l}`", clip.name, clip.frames);
                }
                Fate::Excluded(why) => {
                    let _ = writeln!(t, "  `{}` excluded: {why}", clip.name);
                }
            }
        }
    }
    let list: Vec<String> = frames.iter().map(|(l, n)| format!("{l} ({n})")).collect();
    let _ = writeln!(t, "{} labels from {} clips, frames: {}", frames.len(), clips.len(), list.join(", "));
    let _ = writeln!(t, "wrote {}", relative(cwd, &dir.join(template::DEMO_SCRIPT)));
    let _ = writeln!(t, "next: reprise run --pipeline {shown}");
    t
}
