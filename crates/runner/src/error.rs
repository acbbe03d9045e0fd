//! The runner's one error type. Every variant carries the context a user needs to act on
//! it (file, stage, input/output name, path); [`Error::code`] maps it to the exit code
//! from [`reprise_stagekit::exit`]. Errors are printed once, by `lib.rs`, as
//! `reprise: error: …`.

use std::io;
use std::path::PathBuf;

use reprise_stagekit::exit;

/// The runner's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can stop a `reprise` command.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The runner received a signal and stopped (its running stage first).
    #[error("interrupted by {name}{}; nothing after the last completed stage was recorded", stage.as_ref().map(|s| format!(" while stage `{s}` ran (it was stopped)")).unwrap_or_default())]
    Interrupted { stage: Option<String>, signal: i32, name: &'static str },

    /// An output names a file no stage may write (the pipeline file, the lock file, one of
    /// the stage's own inputs); `what` says which.
    #[error("{file}: stage `{stage}`: output `{output}` is `{path}`, {what}; choose another path")]
    OutputForbidden { file: String, stage: String, output: String, path: String, what: &'static str },

    /// An output names an existing file that this pipeline did not write.
    #[error(
        "{file}: stage `{stage}`: output `{output}` is `{path}`, an existing file that no stage of this pipeline wrote \
         ({whose}); refusing to overwrite it: choose another path, move the file away, \
         or add `allow_overwrite = [\"{output}\"]` to `[stage.{stage}]`"
    )]
    OutputNotOurs { file: String, stage: String, output: String, path: String, whose: String },

    /// The artifacts directory holds another pipeline's lock.
    #[error(
        "{file}: the artifacts directory `{dir}` belongs to pipeline `{owner}` (its lock `{lock}` says so); running \
         `{pipeline}` there would replace `{owner}`'s artifacts and lock. Give `{pipeline}` its own directory \
         (`artifacts = \"…\"` under `[pipeline]`), or pass --adopt-artifacts to take this one over"
    )]
    ArtifactsOwned { file: String, dir: String, owner: String, pipeline: String, lock: String },

    /// An output cannot be a file: a directory is in the way, or a parent is a file.
    #[error("stage `{stage}`: output `{output}` is `{path}`, but {why}")]
    OutputUnwritable { stage: String, output: String, path: String, why: String },

    /// Another `reprise run` holds this pipeline's run lock.
    #[error("another `reprise run` is running this pipeline (it holds `{}`); wait for it to finish", path.display())]
    AlreadyRunning { path: std::path::PathBuf },

    /// One or more stages rejected their flags when invoked with `--check`.
    #[error("{}", check_failures(failures))]
    CheckFailed { failures: Vec<(String, String)>, code: i32 },

    /// A stage names itself (or a stage that names it) as a dependency.
    #[error("{file}: dependency cycle: {cycle}")]
    Cycle { file: String, cycle: String },

    /// Two stages write the same output path.
    #[error("{file}: output `{path}` is produced by both stage `{first}` and stage `{second}`")]
    DuplicateOutput { file: String, path: String, first: String, second: String },

    /// Two of a stage's inputs, outputs or parameters would be passed as the same flag.
    #[error("{file}: stage `{stage}`: {first} and {second} would both be passed as `--{flag}`")]
    FlagClash { file: String, stage: String, first: String, second: String, flag: String },

    /// A `--force` names a stage that `--to` did not select.
    #[error("stage `{stage}` is forced but `--to {to}` does not select it (it is not `{to}` or one of its ancestors)")]
    ForcedNotSelected { stage: String, to: String },

    /// An input and a parameter of the same stage share a name.
    #[error("{file}: stage `{stage}`: `{name}` is both an input and a parameter")]
    InputParamClash { file: String, stage: String, name: String },

    /// `inspect` was asked for a column the file does not have.
    #[error("`{}` has no column `{column}` (columns: {available})", path.display())]
    InspectColumn { path: PathBuf, column: String, available: String },

    /// `reprise init` cannot make a working pipeline from what it was given; says why.
    #[error("init: {0}")]
    Init(String),

    /// `reprise serve` cannot start the server for this pipeline; says why.
    #[error("serve: {0}")]
    Serve(String),

    /// `reprise replay` cannot measure this recording on this pipeline; says why.
    #[error("replay: {0}")]
    Replay(String),

    /// The server stopped with an error (it said which).
    #[error("serve: reprise-serve exited with code {code}")]
    ServeExited {
        /// Its exit code.
        code: i32,
    },

    /// A stage `reprise init` ran on the source to check it failed; `output` is what it said.
    #[error("init: checking the source, stage `{stage}` failed ({what}):\n{output}")]
    InitProbe { stage: String, what: String, output: String, code: i32 },

    /// `reprise init` would replace a file.
    #[error("init: `{}` exists; refusing to overwrite it (give --force to replace it)", path.display())]
    InitExists { path: PathBuf },

    /// An input's glob names no file, or cannot be read.
    #[error("{file}: stage `{stage}`: input `{input}`: glob `{pattern}`: {why}")]
    InputGlob { file: String, stage: String, input: String, pattern: String, why: String },

    /// `inspect` could not decode a Parquet file's rows.
    #[error("cannot read rows of `{}`: {message}", path.display())]
    InspectRows { path: PathBuf, message: String },

    /// A name (stage, input, output, parameter) is not `[a-z0-9_-]+`.
    #[error("{file}: {what} name `{name}` is invalid: use only lowercase letters, digits, `_` and `-`")]
    InvalidName { file: String, what: String, name: String },

    /// A value in `pipeline.toml` has the wrong type or is out of place.
    #[error("{file}: {context}: {message}")]
    InvalidValue { file: String, context: String, message: String },

    /// Reading a file's content for hashing failed (other than it not existing).
    #[error("cannot read `{}`: {source}", path.display())]
    Io { path: PathBuf, source: io::Error },

    /// Writing the lock file failed.
    #[error("cannot write lock file `{}`: {source}", path.display())]
    LockWrite { path: PathBuf, source: io::Error },

    /// A parameter value is a table, or an array holding tables or arrays.
    #[error(
        "{file}: stage `{stage}`: parameter `{param}` is {found}; parameters must be scalars or arrays of scalars"
    )]
    NestedParam { file: String, stage: String, param: String, found: &'static str },

    /// The pipeline declares no stages.
    #[error("{file}: no stages: add a `[stage.<name>]` table")]
    NoStages { file: String },

    /// The file given to `inspect` is not Parquet.
    #[error("`{}` is not a Parquet file: {message}", path.display())]
    NotParquet { path: PathBuf, message: String },

    /// A stage exited 0 without writing one of its declared outputs.
    #[error("stage `{stage}` exited 0 but did not write output `{output}` ({path})")]
    OutputNotWritten { stage: String, output: String, path: String },

    /// `pipeline.toml` (or another named file) could not be read.
    #[error("cannot read `{}`: {source}", path.display())]
    PipelineRead { path: PathBuf, source: io::Error },

    /// `pipeline.toml` is not valid TOML.
    #[error("{file}: {message}")]
    PipelineSyntax { file: String, message: String },

    /// An input that no stage produces does not exist.
    #[error("stage `{stage}`: input `{input}` not found: {path} (no stage produces it)")]
    SourceMissing { stage: String, input: String, path: String },

    /// The operating system refused to start a stage binary.
    #[error("stage `{stage}`: cannot start `{}`: {source}", bin.display())]
    Spawn { stage: String, bin: PathBuf, source: io::Error },

    /// A stage binary is nowhere to be found.
    #[error("stage `{stage}`: binary `{bin}` not found (looked in {searched}); build the stages with `cargo build --release`, or set REPRISE_BIN_DIR")]
    StageBinaryMissing { stage: String, bin: String, searched: String },

    /// The Slurm executor could not submit, follow or finish a job.
    #[error("stage `{stage}`: Slurm: {message}")]
    Slurm { stage: String, message: String },

    /// A task run by a scheduler exited non-zero; `output` is the end of its log.
    #[error("stage `{stage}` failed (exit code {code}) in job {job}; the end of its output:\n{output}")]
    TaskFailed { stage: String, code: i32, job: String, output: String },

    /// A partitioned stage's labels could not be found or merged.
    #[error("stage `{stage}`: {message}")]
    Partition { stage: String, message: String },

    /// A stage exited with a non-zero code.
    #[error("stage `{stage}` failed (exit code {code})")]
    StageFailed { stage: String, code: i32 },

    /// A stage was killed by a signal.
    #[error("stage `{stage}` crashed: killed by signal {signal} ({name})")]
    StageKilled { stage: String, signal: i32, name: &'static str },

    /// `after` names a stage that does not exist.
    #[error("{file}: stage `{stage}`: `after` names unknown stage `{after}`")]
    UnknownAfter { file: String, stage: String, after: String },

    /// A declared input that wiring cannot find (see [`crate::wire`]).
    #[error("{file}: stage `{stage}`: input `{input}` is not given and cannot be wired: {why}")]
    Unwired { file: String, stage: String, input: String, why: String },

    /// A stage table without `bin` whose name is no known stage.
    #[error("{file}: stage `{stage}` has no `bin`, and no known stage is called `{stage}` (known: {known})")]
    NoBin { file: String, stage: String, known: String },

    /// A key `pipeline.toml` does not know.
    #[error("{file}: {context}: unknown key `{key}`{}", hint(suggestion.as_deref(), expected))]
    UnknownKey {
        file: String,
        context: String,
        key: String,
        suggestion: Option<String>,
        expected: &'static [&'static str],
    },

    /// `--to`/`--force` names a stage the pipeline does not have.
    #[error("{file}: no stage named `{stage}` (stages: {known})")]
    UnknownStage { file: String, stage: String, known: String },
}

impl Error {
    /// The process exit code for this error (see `reprise_stagekit::exit`).
    #[must_use]
    pub fn code(&self) -> i32 {
        match self {
            Self::Cycle { .. }
            | Self::DuplicateOutput { .. }
            | Self::FlagClash { .. }
            | Self::ForcedNotSelected { .. }
            | Self::InvalidName { .. }
            | Self::InvalidValue { .. }
            | Self::InputParamClash { .. }
            | Self::InputGlob { .. }
            | Self::Init(_)
            | Self::Serve(_)
            | Self::Replay(_)
            | Self::InitExists { .. }
            | Self::InspectColumn { .. }
            | Self::NestedParam { .. }
            | Self::NoStages { .. }
            | Self::OutputForbidden { .. }
            | Self::OutputNotOurs { .. }
            | Self::ArtifactsOwned { .. }
            | Self::OutputUnwritable { .. }
            | Self::PipelineRead { .. }
            | Self::PipelineSyntax { .. }
            | Self::UnknownAfter { .. }
            | Self::Unwired { .. }
            | Self::NoBin { .. }
            | Self::UnknownKey { .. }
            | Self::UnknownStage { .. } => exit::CONFIG,
            Self::Io { source, .. } | Self::LockWrite { source, .. } if exit::is_environment(source) => {
                exit::ENVIRONMENT
            }
            Self::Io { .. }
            | Self::InspectRows { .. }
            | Self::NotParquet { .. }
            | Self::Partition { .. }
            | Self::SourceMissing { .. } => exit::INPUT,
            Self::AlreadyRunning { .. } | Self::LockWrite { .. } | Self::OutputNotWritten { .. } => exit::FAILURE,
            Self::Spawn { .. } | Self::StageBinaryMissing { .. } | Self::StageKilled { .. } => exit::STAGE_CRASHED,
            Self::CheckFailed { code, .. }
            | Self::StageFailed { code, .. }
            | Self::TaskFailed { code, .. }
            | Self::InitProbe { code, .. }
            | Self::ServeExited { code } => *code,
            Self::Slurm { .. } => exit::ENVIRONMENT,
            Self::Interrupted { signal, .. } => exit::INTERRUPTED_BASE + signal,
        }
    }
}

fn hint(suggestion: Option<&str>, expected: &[&str]) -> String {
    match suggestion {
        Some(s) => format!(" (did you mean `{s}`?)"),
        None if expected.is_empty() => String::new(),
        None => {
            let list: Vec<String> = expected.iter().map(|k| format!("`{k}`")).collect();
            format!(" (expected one of {})", list.join(", "))
        }
    }
}

fn check_failures(failures: &[(String, String)]) -> String {
    failures
        .iter()
        .map(|(stage, why)| format!("stage `{stage}`: parameter check failed ({why}); see its message above"))
        .collect::<Vec<_>>()
        .join("\nreprise: error: ")
}
