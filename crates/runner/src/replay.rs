//! `reprise replay RECORDING`: measures a live session with the transition benchmark's
//! metrics. It runs `reprise-replay` on the recording — every system replayed on the
//! session's commands, written as the benchmark's requests, answers and curves — then the
//! pipeline's own `evaluate` stage on those files in place of the benchmark's, its other
//! inputs and its parameters unchanged.
//!
//! Where it writes: the replay's artifacts under `<artifacts>/replay-<stem>/` and the report
//! under `<evaluate's report directory>/replay-<stem>/` (`reports/<name>/replay-<stem>/`),
//! `<stem>` the recording's file name without `.json`. An existing file there is replaced
//! only if `reprise-replay` or `evaluate` wrote it ([`crate::guard::writer_of`]); anything
//! else is refused before either runs. Both write each file to a temporary file and rename
//! it. Nothing is cached: a replay reruns every time.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use reprise_stagekit::wiring::Wiring;

use crate::cli::ReplayArgs;
use crate::locate::{locate, BinDirs};
use crate::params::{ParamValue, Scalar};
use crate::paths::ArtifactPath;
use crate::pipeline::{BinSpec, Pipeline, Stage};
use crate::{Error, Result};

/// The role of the replay's input naming the recording.
pub const RECORDING: &str = "recording";

/// The stage that measures the benchmark: it reads the requests and writes the metrics.
fn measures(stage: &Stage) -> bool {
    stage.inputs.iter().any(|(r, _)| r == "requests") && stage.outputs.iter().any(|(r, _)| r == "metrics")
}

/// The files of the pipeline's benchmark, which a replay's replace: every output of a stage
/// (other than evaluate) that writes or reads the requests — `transitions` and
/// `motion-match`, the ablation's answers included.
fn benchmark_files<'p>(pipeline: &'p Pipeline, evaluate: &Stage) -> HashSet<&'p Path> {
    let asks = |s: &Stage| s.outputs.iter().chain(&s.inputs).any(|(r, _)| r == "requests") && s.name != evaluate.name;
    pipeline.stages.iter().filter(|s| asks(s)).flat_map(|s| s.outputs.iter().map(|(_, p)| p.abs.as_path())).collect()
}

/// `dir/<file name of path>`, declared relative to the pipeline's directory.
fn beside(pipeline: &Pipeline, dir: &Path, file: &str) -> ArtifactPath {
    ArtifactPath::new(&pipeline.dir, &crate::paths::relative(&pipeline.dir, &dir.join(file)))
}

/// The two stages a replay runs, as the runner invokes stages: `reprise-replay` on the
/// recording and the world's files, then the pipeline's `evaluate` on its outputs.
#[derive(Debug)]
pub struct Plan {
    /// The pipeline.
    pub pipeline: Pipeline,
    /// `reprise-replay`.
    pub replay: Stage,
    /// The pipeline's evaluate stage, reading the replay's files.
    pub evaluate: Stage,
}

/// Plans the replay of `args.recording` on the pipeline at `args.pipeline`, whose
/// `reprise-replay` reads and writes what `wiring` declares.
///
/// # Errors
/// [`Error::Replay`] when the pipeline has no stage measuring the benchmark, an input the
/// replay or evaluate reads is not made yet (`reprise run` first), or an output would
/// replace a file neither wrote.
pub fn plan(args: &ReplayArgs, dirs: &BinDirs, wiring: &Wiring) -> Result<Plan> {
    let (pipeline, _) = crate::load(&args.pipeline.pipeline, dirs.known)?;
    let fail = |why: String| Error::Replay(why);
    let evaluate = pipeline.stages.iter().find(|s| measures(s)).ok_or_else(|| {
        fail(format!(
            "no stage of {} reads `requests` and writes `metrics`; replay needs the transition benchmark's \
             `evaluate` stage",
            pipeline.file
        ))
    })?;
    let recording =
        std::path::absolute(&args.recording).map_err(|e| fail(format!("{}: {e}", args.recording.display())))?;
    let stem = recording
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty())
        .ok_or_else(|| fail(format!("{}: a recording is a file `<name>.json`", args.recording.display())))?;
    let name = format!("replay-{stem}");
    let replaced = benchmark_files(&pipeline, evaluate);
    let kept: Vec<(String, ArtifactPath)> =
        evaluate.inputs.iter().filter(|(_, p)| !replaced.contains(p.abs.as_path())).cloned().collect();
    if let Some((_, p)) = kept.iter().find(|(_, p)| !p.abs.is_file()) {
        return Err(fail(format!("{} is not made yet: run `reprise run` first", p.rel)));
    }
    // The replay reads the world's files among evaluate's own inputs, and the recording.
    let mut inputs = vec![(RECORDING.to_string(), ArtifactPath::new(&pipeline.dir, &recording.to_string_lossy()))];
    for input in wiring.inputs.iter().filter(|i| i.role != RECORDING) {
        let found = kept.iter().find(|(r, _)| r == input.role).ok_or_else(|| {
            fail(format!(
                "stage `{}` of {} reads no `{}`, which the replay needs",
                evaluate.name, pipeline.file, input.role
            ))
        })?;
        inputs.push(found.clone());
    }
    let artifacts = pipeline.artifacts.abs.join(&name);
    let outputs: Vec<(String, ArtifactPath)> =
        wiring.outputs.iter().map(|o| (o.role.to_string(), beside(&pipeline, &artifacts, o.artifact))).collect();
    let hold = ParamValue::Scalar(Scalar::Float(args.hold));
    let replay = Stage {
        name: wiring.stage.to_string(),
        bin: BinSpec::Name(wiring.bin.to_string()),
        inputs,
        outputs: outputs.clone(),
        after: vec![],
        params: vec![("hold".into(), hold)],
        allow_overwrite: vec![],
    };
    let report = |p: &ArtifactPath| {
        let dir = p.abs.parent().unwrap_or(&pipeline.dir).join(&name);
        beside(&pipeline, &dir, &p.abs.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default())
    };
    let mut params = evaluate.params.clone();
    for (key, value) in &mut params {
        if key == "name" {
            *value = ParamValue::Scalar(Scalar::Str(format!("{} (replay of {stem})", pipeline.name)));
        }
    }
    let evaluate = Stage {
        inputs: kept.into_iter().chain(outputs).collect(),
        outputs: evaluate.outputs.iter().map(|(r, p)| (r.clone(), report(p))).collect(),
        params,
        ..evaluate.clone()
    };
    for (stage, writer) in [(&replay, wiring.stage), (&evaluate, "evaluate")] {
        for (_, p) in stage.outputs.iter().filter(|(_, p)| p.abs.exists()) {
            let by = crate::guard::writer_of(&p.abs).map(|(by, _)| by);
            if by.as_deref() != Some(writer) {
                return Err(fail(format!(
                    "{} exists and `reprise replay` did not write it; refusing to overwrite it: move it away",
                    p.rel
                )));
            }
        }
    }
    Ok(Plan { pipeline, replay, evaluate })
}

/// Runs the replay, then evaluate; says where the report is on `log`.
///
/// # Errors
/// As [`plan`]; [`Error::Replay`] when a binary is not found; [`Error::StageFailed`] (and
/// the stage's own message, naming the file, on stderr) when either fails.
pub fn replay(args: &ReplayArgs, dirs: &BinDirs, wiring: &Wiring, log: &mut dyn std::io::Write) -> Result<()> {
    let plan = plan(args, dirs, wiring)?;
    let interrupt = crate::child::Interrupt::watch();
    for stage in [&plan.replay, &plan.evaluate] {
        let bin: PathBuf = locate(&stage.bin, dirs)
            .map_err(|looked| Error::Replay(format!("cannot find `{}` (looked in {looked})", stage.bin.declared())))?;
        crate::say(log, &format!("replay: running {}", stage.name));
        crate::executor::invoke_measured(&plan.pipeline, stage, &bin, &interrupt, false)?;
    }
    if let Some((_, p)) = plan.evaluate.outputs.iter().find(|(r, _)| r == "html") {
        crate::say(log, &format!("replay: report {}", p.rel));
    }
    Ok(())
}
