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

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use reprise_artifact::segments::Segment;

use crate::child::{self, Outcome};
use crate::cli::InitArgs;
use crate::error::{Error, Result};
use crate::locate::{locate, BinDirs};
use crate::paths::{absolute, relative, ArtifactPath};
use crate::pipeline::Pipeline;

/// The fewest frames a label needs: two 12-frame blend windows (the window of the
/// Motion Graphs baseline, the transition benchmark and the evaluation). A shorter clip
/// joins the clips that share the first word of its name, or is excluded.
pub const MIN_LABEL_FRAMES: i64 = 24;

/// The latent dimension of the generated pipeline's GPLVMs (`[stage.gplvm.params] q`): a
/// label whose PCA keeps fewer dimensions cannot be fitted and is excluded.
pub const GPLVM_Q: usize = 3;

/// The source `init` was given, as the pipeline will name it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A glTF character, relative to the pipeline directory.
    Gltf(String),
    /// BVH takes: one file or glob (`inputs.bvh = "…"`), or several (a list).
    Bvh(Vec<String>),
    /// A curve table and the command of its rig evaluator.
    Curves { table: String, rig: Vec<String> },
}

/// One clip of the source: its name and frame count at the pipeline's rate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClipInfo {
    /// The clip's name.
    pub name: String,
    /// Frames after resampling.
    pub frames: i64,
}

/// What the generated labels file does with one clip.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fate {
    /// Its own label.
    Own(String),
    /// A label shared with the other short clips whose names start with the same word.
    Grouped(String),
    /// Excluded, and why.
    Excluded(String),
}

/// A generated labels file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelsPlan {
    /// The file's text.
    pub text: String,
    /// Each clip and what became of it, in clip order.
    pub clips: Vec<(ClipInfo, Fate)>,
}

impl LabelsPlan {
    /// The distinct labels, in order of first use.
    #[must_use]
    pub fn labels(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for (_, fate) in &self.clips {
            if let Fate::Own(l) | Fate::Grouped(l) = fate {
                if !out.contains(&l.as_str()) {
                    out.push(l);
                }
            }
        }
        out
    }
}

/// Runs `reprise init`; what it wrote goes to `out`.
pub fn init(args: &InitArgs, dirs: &BinDirs, out: &mut dyn Write) -> Result<()> {
    let cwd = std::env::current_dir().map_err(|source| Error::Io { path: ".".into(), source })?;
    let pipeline_path = absolute(&cwd, &args.pipeline.pipeline);
    let dir = pipeline_path.parent().map_or_else(|| cwd.clone(), Path::to_path_buf);
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(Error::Init(format!("--fps must be a positive number of frames per second, got {}", args.fps)));
    }
    let source = resolve_source(args, &cwd, &dir)?;
    let name = match &args.name {
        Some(name) if crate::pipeline::valid_name(name) => name.clone(),
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
    let scripts_path = dir.join("scripts").join("demo.toml");
    let mut to_write = vec![pipeline_path.clone(), scripts_path.clone()];
    if labels_path.is_none() {
        to_write.push(generated_labels.clone());
    }
    if !args.force {
        if let Some(existing) = to_write.iter().find(|p| p.exists()) {
            return Err(Error::InitExists { path: existing.clone() });
        }
    }
    let labels_ref = relative(&dir, labels_path.as_ref().unwrap_or(&generated_labels));
    let text = pipeline_text(&name, &source, args.fps, &labels_ref);
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
    let probe = Probe::new(pipeline, dirs)?;
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

    if let Some(plan) = &plan {
        write_atomic(files.generated_labels, &plan.text)?;
    }
    write_atomic(files.scripts, &script)?;
    write_atomic(files.pipeline, text)?;
    Ok((clips, plan, segments))
}

/// The pipeline's first stages run on the source in a scratch directory.
struct Probe<'a> {
    pipeline: &'a Pipeline,
    dirs: &'a BinDirs,
    scratch: tempfile::TempDir,
    interrupt: child::Interrupt,
}

impl<'a> Probe<'a> {
    fn new(pipeline: &'a Pipeline, dirs: &'a BinDirs) -> Result<Self> {
        let scratch = tempfile::Builder::new()
            .prefix("reprise-init")
            .tempdir()
            .map_err(|source| Error::Io { path: std::env::temp_dir(), source })?;
        Ok(Self { pipeline, dirs, scratch, interrupt: child::Interrupt::watch() })
    }

    /// A file of the scratch directory.
    fn file(&self, name: &str) -> std::path::PathBuf {
        self.scratch.path().join(name)
    }

    /// A generated labels file, written to the scratch directory.
    fn labels_file(&self, text: &str) -> Result<ArtifactPath> {
        let path = self.file("labels.toml");
        std::fs::write(&path, text).map_err(|source| Error::Io { path: path.clone(), source })?;
        Ok(ArtifactPath::new(&self.pipeline.dir, &path.to_string_lossy()))
    }

    /// Runs the pipeline's stage `name` with its outputs in the scratch directory, its
    /// inputs from there when a stage writes them, and `labels` as its labels file. Its
    /// output is kept and shown only when it fails.
    fn run(&self, name: &str, labels: Option<ArtifactPath>) -> Result<()> {
        let mut stage = self
            .pipeline
            .stage(name)
            .cloned()
            .ok_or_else(|| Error::Init(format!("the pipeline has no `{name}` stage")))?;
        let in_scratch = |path: &ArtifactPath| {
            let file = Path::new(&path.rel).file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            ArtifactPath::new(&self.pipeline.dir, &self.file(&file).to_string_lossy())
        };
        for (_, path) in &mut stage.outputs {
            *path = in_scratch(path);
        }
        let written =
            |p: &ArtifactPath| self.pipeline.stages.iter().any(|s| s.outputs.iter().any(|(_, o)| o.abs == p.abs));
        for (role, path) in &mut stage.inputs {
            match &labels {
                Some(given) if role == "labels" => *path = given.clone(),
                _ if written(path) => *path = in_scratch(path),
                _ => {}
            }
        }
        let bin = locate(&stage.bin, self.dirs).map_err(|searched| Error::StageBinaryMissing {
            stage: stage.name.clone(),
            bin: stage.bin.declared().into(),
            searched,
        })?;
        let log = self.file(&format!("{name}.log"));
        let call = child::Call { log: Some(&log), ..child::Call::default() };
        let outcome = child::invoke(&stage, &bin, &self.pipeline.dir, call, &self.interrupt)?;
        let failed = |what: String, code: i32| Error::InitProbe {
            stage: name.into(),
            what,
            output: std::fs::read_to_string(&log).unwrap_or_default().trim_end().to_string(),
            code,
        };
        match outcome {
            Outcome::Success => Ok(()),
            Outcome::Failed(code) => Err(failed(format!("exit code {code}"), code)),
            Outcome::Killed(signal) => Err(failed(
                format!("killed by signal {signal} ({})", child::signal_name(signal)),
                reprise_stagekit::exit::STAGE_CRASHED,
            )),
            Outcome::Interrupted(signal) => {
                Err(Error::Interrupted { stage: Some(name.into()), signal, name: child::signal_name(signal) })
            }
        }
    }

    /// Labels with `labels`, then scales and reduces: the labels whose PCA keeps fewer
    /// than [`GPLVM_Q`] dimensions, with why.
    fn thin_labels(&self, labels: &ArtifactPath) -> Result<BTreeMap<String, String>> {
        self.run("label", Some(labels.clone()))?;
        self.run("scale", None)?;
        self.run("pca", None)?;
        let (_, models) = reprise_artifact::pca::read_models(&self.file("pca_models.parquet"))
            .map_err(|e| Error::Init(format!("reading what pca wrote: {e}")))?;
        Ok(models
            .iter()
            .filter(|m| m.variant == reprise_artifact::pca::SCALED && m.d() < GPLVM_Q)
            .map(|m| {
                let why = format!(
                    "moves in {} dimension(s) (its PCA keeps d = {}), fewer than the GPLVM's q = {GPLVM_Q}",
                    m.d(),
                    m.d()
                );
                (m.label.clone(), why)
            })
            .collect())
    }

    /// The segments the last label run wrote.
    fn segments(&self) -> Result<Vec<Segment>> {
        reprise_artifact::segments::read(&self.file("segments.parquet"))
            .map_err(|e| Error::Init(format!("reading what label wrote: {e}")))
    }
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
        if crate::paths::is_glob(given) {
            let (parent, pattern) = given.rsplit_once('/').unwrap_or((".", given));
            crate::paths::expand_glob(cwd, given).map_err(|why| Error::Init(format!("--bvh `{given}`: {why}")))?;
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
        if args.bvh.len() == 1 && !crate::paths::is_glob(&args.bvh[0]) {
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
fn slug(text: &str, sep: char) -> String {
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

/// A TOML string literal.
fn quoted(text: &str) -> String {
    toml::Value::String(text.to_string()).to_string()
}

/// The pipeline file: every stage from ingest to the report with the parameters the
/// shipped pipelines use (`datasets/robot-expressive/pipeline.toml`), the source and
/// the labels named, everything else wired by artifact.
#[must_use]
pub fn pipeline_text(name: &str, source: &Source, fps: f64, labels: &str) -> String {
    let mut t = String::new();
    let (what, input) = match source {
        Source::Gltf(path) => ("a glTF character", format!("inputs.gltf = {}", quoted(path))),
        Source::Bvh(takes) if takes.len() == 1 => ("BVH takes", format!("inputs.bvh = {}", quoted(&takes[0]))),
        Source::Bvh(takes) => {
            let list: Vec<String> = takes.iter().map(|t| quoted(t)).collect();
            ("BVH takes", format!("inputs.bvh = [{}]", list.join(", ")))
        }
        Source::Curves { table, .. } => ("a curve table", format!("inputs.curves = {}", quoted(table))),
    };
    let _ = writeln!(t, "# reprise pipeline for {what}, written by `reprise init`: ingest to the comparison report.");
    let _ = writeln!(t, "# Run it with `reprise run --pipeline <this file>`. Paths are relative to this file;");
    let _ = writeln!(
        t,
        "# inputs and outputs are wired by artifact (docs/pipeline.md, \"Wiring\"), so only your own files"
    );
    let _ = writeln!(t, "# are named. Edit the labels file to group clips by what they mean, then run again:");
    let _ = writeln!(t, "# only what changed reruns.\n");
    let _ = writeln!(t, "[pipeline]\nname = {}\n", quoted(name));
    let _ = writeln!(t, "[stage.ingest]\n{input}\n[stage.ingest.params]\nfps = {fps:?}");
    if let Source::Curves { rig, .. } = source {
        let list: Vec<String> = rig.iter().map(|a| quoted(a)).collect();
        let _ = writeln!(t, "external_rig = [{}]", list.join(", "));
    }
    let _ = writeln!(t, "\n[stage.label]\ninputs.labels = {}\n", quoted(labels));
    t.push_str(SHARED_STAGES);
    if matches!(source, Source::Gltf(_)) {
        let _ = writeln!(t, "\n[stage.export-gltf]            # the character with the synthesized scripts added");
    }
    t
}

/// Every stage after label, with only the parameters whose value differs from the stage's
/// own default (`crates/reprise/tests/init_template.rs` checks that each one does), so the
/// template copies no default that could drift.
const SHARED_STAGES: &str = r#"# Every parameter not written here is the stage's own default (`reprise-<stage> --help`).
[stage.scale]

[stage.pca]

[stage.gplvm]
[stage.gplvm.params]
heldout_every = 10             # leave out every 10th frame and compare with PCA

[stage.bridges]

[stage.synthesize]
inputs.scripts = "scripts/demo.toml"
[stage.synthesize.params]
radius = 0.2

[stage.motion-graph]
[stage.motion-graph.params]
quantile = 0.2

[stage.transitions]

[stage.motion-match]

[stage.evaluate]
"#;

/// Labels for `clips`: a clip of at least `min_frames` frames is its own label, named
/// after it; shorter clips whose names start with the same word share a label named by
/// that word when they have `min_frames` together (or join a clip's label of that name);
/// the rest are excluded, as are the clips of every label in `thin` (label → why). The
/// file says, in comments and reasons, what was grouped or excluded and why. Fewer than
/// two labels is an error: bridges and the benchmark need two.
pub fn plan_labels(clips: &[ClipInfo], min_frames: i64, thin: &BTreeMap<String, String>) -> Result<LabelsPlan> {
    let mut fates: Vec<Fate> = Vec::with_capacity(clips.len());
    let mut own: Vec<String> = Vec::new();
    for clip in clips {
        if clip.frames < min_frames {
            fates.push(Fate::Excluded(String::new()));
            continue;
        }
        let base = Some(slug(&clip.name, '_')).filter(|s| !s.is_empty()).unwrap_or_else(|| "clip".into());
        let mut label = base.clone();
        let mut n = 2;
        while own.contains(&label) {
            label = format!("{base}_{n}");
            n += 1;
        }
        own.push(label.clone());
        fates.push(Fate::Own(label));
    }
    let word = |name: &str| slug(name, '_').split('_').find(|w| !w.is_empty()).unwrap_or("clip").to_string();
    let mut words: Vec<(String, i64)> = Vec::new();
    for (clip, fate) in clips.iter().zip(&fates) {
        if matches!(fate, Fate::Excluded(_)) {
            let w = word(&clip.name);
            match words.iter_mut().find(|(x, _)| *x == w) {
                Some((_, total)) => *total += clip.frames,
                None => words.push((w, clip.frames)),
            }
        }
    }
    for (clip, fate) in clips.iter().zip(fates.iter_mut()) {
        if !matches!(fate, Fate::Excluded(_)) {
            continue;
        }
        let w = word(&clip.name);
        let total = words.iter().find(|(x, _)| *x == w).map_or(0, |(_, t)| *t);
        *fate = if own.contains(&w) || total >= min_frames {
            Fate::Grouped(w)
        } else {
            Fate::Excluded(format!(
                "{} frames: too short to model (a label needs at least {min_frames}), and no other \
                 clip's name starts with `{w}` to share a label with",
                clip.frames
            ))
        };
    }
    for fate in &mut fates {
        if let Fate::Own(l) | Fate::Grouped(l) = fate {
            if let Some(why) = thin.get(l.as_str()) {
                *fate = Fate::Excluded(format!("its label `{l}` {why}"));
            }
        }
    }
    let plan =
        LabelsPlan { text: labels_text(clips, &fates, min_frames), clips: clips.iter().cloned().zip(fates).collect() };
    let labels = plan.labels();
    if labels.len() < 2 {
        let list: Vec<String> = clips.iter().map(|c| format!("`{}` ({} frames)", c.name, c.frames)).collect();
        return Err(Error::Init(format!(
            "the source's clips make {} label(s) that can be modeled ({}); a pipeline needs two to bridge and \
             compare: write a labels file that splits the takes into labels (frame ranges) and give it with --labels",
            labels.len(),
            list.join(", ")
        )));
    }
    Ok(plan)
}

/// The labels file for `fates` (see [`plan_labels`]).
fn labels_text(clips: &[ClipInfo], fates: &[Fate], min_frames: i64) -> String {
    let mut t = String::from(
        "# Labels written by `reprise init`. Edit them: the paper groups frames by what the motion\n\
         # communicates, so that each label's model is homogeneous (`pattern` is a glob over clip\n\
         # names; several clips may share a label). Format: docs/inputs.md, \"Labels file\".\n",
    );
    let entry = |t: &mut String, clip: &ClipInfo, label: &str| {
        if crate::paths::is_glob(&clip.name) {
            let _ = writeln!(
                t,
                "[[range]]\nclip = {}\nstart = 0\nend = {}\nlabel = {}",
                quoted(&clip.name),
                clip.frames - 1,
                quoted(label)
            );
        } else {
            let _ = writeln!(t, "[[rule]]\npattern = {}\nlabel = {}", quoted(&clip.name), quoted(label));
        }
    };
    let own: fn(&Fate) -> Option<&str> = |f| if let Fate::Own(l) = f { Some(l) } else { None };
    let grouped: fn(&Fate) -> Option<&str> = |f| if let Fate::Grouped(l) = f { Some(l) } else { None };
    let sections = [
        (format!("One label per clip of at least {min_frames} frames."), own),
        (
            format!(
                "Clips shorter than {min_frames} frames, too short to model alone, share a label with the clips\n\
                 # whose names start with the same word."
            ),
            grouped,
        ),
    ];
    for (heading, pick) in sections {
        let members: Vec<(&ClipInfo, &str)> =
            clips.iter().zip(fates).filter_map(|(c, f)| Some((c, pick(f)?))).collect();
        if !members.is_empty() {
            let _ = writeln!(t, "\n# {heading}");
        }
        for (clip, label) in members {
            let _ = writeln!(t, "# {}: {} frames", clip.name, clip.frames);
            entry(&mut t, clip, label);
        }
    }
    if fates.iter().any(|f| matches!(f, Fate::Excluded(_))) {
        let _ = writeln!(
            t,
            "\n# Excluded: each reason says why. To keep a clip, give it the label of clips it moves like."
        );
        for (clip, fate) in clips.iter().zip(fates) {
            if let Fate::Excluded(why) = fate {
                let _ = writeln!(t, "[[exclude]]\nclip = {}\nreason = {}", quoted(&clip.name), quoted(why));
            }
        }
    }
    t
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
    let _ = writeln!(t, "wrote {}", relative(cwd, &dir.join("scripts/demo.toml")));
    let _ = writeln!(t, "next: reprise run --pipeline {shown}");
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clip(name: &str, frames: i64) -> ClipInfo {
        ClipInfo { name: name.into(), frames }
    }

    /// Long clips are their own labels, named after them (distinct even when two names slug
    /// alike); short clips share a label by the first word of their names when together
    /// long enough, else are excluded with the reason; a clip name with glob characters
    /// becomes a whole-clip range.
    #[test]
    fn labels_one_per_clip_short_ones_grouped_or_excluded() {
        let clips = [
            clip("Idle", 100),
            clip("Walk Cycle", 40),
            clip("walk-cycle", 30),
            clip("emote-yes", 17),
            clip("emote-no", 17),
            clip("Sit", 11),
            clip("[x]", 24),
            clip("idle-blink", 5),
        ];
        let plan = plan_labels(&clips, 24, &BTreeMap::new()).unwrap();
        assert_eq!(plan.labels(), ["idle", "walk_cycle", "walk_cycle_2", "emote", "x"]);
        let fate = |name: &str| plan.clips.iter().find(|(c, _)| c.name == name).unwrap().1.clone();
        assert_eq!(fate("emote-no"), Fate::Grouped("emote".into()));
        assert_eq!(fate("idle-blink"), Fate::Grouped("idle".into()), "joins the clip label of its word");
        assert!(matches!(fate("Sit"), Fate::Excluded(why) if why.contains("11 frames: too short")));
        let parsed: toml::Table = toml::from_str(&plan.text).unwrap();
        assert_eq!(parsed["rule"].as_array().unwrap().len(), 6);
        assert_eq!(parsed["range"][0]["clip"].as_str(), Some("[x]"));
        assert_eq!(parsed["range"][0]["end"].as_integer(), Some(23));
        assert_eq!(parsed["exclude"][0]["clip"].as_str(), Some("Sit"));
        assert!(plan.text.contains("share a label with the clips"), "{}", plan.text);

        // A label that cannot be modeled is excluded with its reason.
        let thin = BTreeMap::from([("idle".to_string(), "moves in 2 dimension(s)".to_string())]);
        let plan = plan_labels(&clips, 24, &thin).unwrap();
        assert!(!plan.labels().contains(&"idle"));
        let parsed: toml::Table = toml::from_str(&plan.text).unwrap();
        let reasons: Vec<&str> =
            parsed["exclude"].as_array().unwrap().iter().filter_map(|e| e["reason"].as_str()).collect();
        assert_eq!(reasons.iter().filter(|r| r.contains("its label `idle` moves in 2")).count(), 2, "{reasons:?}");
    }

    #[test]
    fn fewer_than_two_labels_is_an_error_naming_the_clips() {
        let e = plan_labels(&[clip("Take", 200), clip("Blink", 5)], 24, &BTreeMap::new()).unwrap_err().to_string();
        assert!(e.contains("make 1 label(s)") && e.contains("`Blink` (5 frames)"), "{e}");
        assert!(e.contains("--labels"), "{e}");
    }

    #[test]
    fn names_are_slugs() {
        assert_eq!(slug("character-male-a", '-'), "character-male-a");
        assert_eq!(slug("  Robot Expressive!", '-'), "robot-expressive");
        assert_eq!(slug("***", '-'), "");
    }

    fn segment(id: i64, label: &str, clip: &str, start: i64, end: i64) -> Segment {
        Segment { segment_id: id, label: label.into(), clip: clip.into(), start, end }
    }

    /// The script starts on the first label's longest segment and plays its clip.
    #[test]
    fn the_demo_script_names_real_frames() {
        let segs =
            [segment(0, "idle", "Idle", 0, 10), segment(1, "idle", "Idle2", 5, 60), segment(2, "wave", "Wave", 0, 30)];
        let text = script_text(&segs).unwrap();
        let parsed: toml::Table = toml::from_str(&text).unwrap();
        let script = &parsed["script"][0];
        assert_eq!(script["start"]["clip"].as_str(), Some("Idle2"));
        assert_eq!(script["start"]["frame"].as_integer(), Some(5));
        assert_eq!(script["command"][1]["clip"].as_str(), Some("Idle2"));
        assert!(text.contains("# to = \"wave\""), "{text}");
        assert!(script_text(&[]).is_err());
    }
}
