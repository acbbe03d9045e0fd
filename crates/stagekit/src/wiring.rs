//! What a stage reads and writes, declared by the stage in code, so that `pipeline.toml`
//! need only name the stages, their parameters and the user's own files: the runner gives
//! every output its default place in the pipeline's artifacts (or reports) directory and
//! wires every input to the one stage of the pipeline that writes the same artifact.
//!
//! An artifact is named by its file name (`pca_coords.parquet`): the kind and the role
//! together (`answers_reprise.parquet` and `answers_baseline.parquet` are one kind in two
//! roles). A role is the stage's flag (`--coords`), as in `inputs.coords = "…"`.

/// A stage's declaration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wiring {
    /// The stage's usual name in `pipeline.toml` (`[stage.gplvm]`): a stage table of this
    /// name without `bin` runs [`Wiring::bin`].
    pub stage: &'static str,
    /// The binary (`reprise-gplvm`).
    pub bin: &'static str,
    /// What it reads.
    pub inputs: &'static [Input],
    /// What it writes.
    pub outputs: &'static [Output],
    /// Parameters the runner fills in from the pipeline unless `pipeline.toml` sets them.
    pub derived: &'static [(&'static str, Derived)],
}

/// One input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Input {
    /// The flag's name with `_` (`labeled_frames`).
    pub role: &'static str,
    /// The artifact it reads (`labeled_frames.parquet`); for a source, what it is.
    pub artifact: &'static str,
    /// Whether it must be wired, and from where.
    pub need: Need,
}

/// How an input is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Need {
    /// Written by another stage of the pipeline; an error if none does.
    Required,
    /// Wired when another stage writes it, else left out.
    Optional,
    /// The user's own file (a character, a labels file, scripts): given in
    /// `pipeline.toml`, never wired; an error if missing.
    Source,
    /// A user's file that may be left out (one of several alternatives).
    OptionalSource,
}

/// One output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Output {
    /// The flag's name with `_` (`models`).
    pub role: &'static str,
    /// The file it writes by default (`gplvm_models.parquet`).
    pub artifact: &'static str,
    /// Which directory holds it.
    pub place: Place,
}

/// Where an output goes by default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// `<artifacts>/` (the pipeline's `artifacts`, default `artifacts/<name>`).
    Artifacts,
    /// The pipeline's reports directory (`[pipeline] reports`, default `reports/<name>`).
    Reports,
}

/// A parameter the pipeline determines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Derived {
    /// `[pipeline] name`.
    PipelineName,
    /// The path of the pipeline's lock file.
    LockFile,
}

/// `(role, artifact)` inputs written by other stages.
pub const fn required(role: &'static str, artifact: &'static str) -> Input {
    Input { role, artifact, need: Need::Required }
}

/// An input wired when some stage writes it.
pub const fn optional(role: &'static str, artifact: &'static str) -> Input {
    Input { role, artifact, need: Need::Optional }
}

/// A user's file.
pub const fn source(role: &'static str, what: &'static str) -> Input {
    Input { role, artifact: what, need: Need::Source }
}

/// A user's file that may be left out.
pub const fn optional_source(role: &'static str, what: &'static str) -> Input {
    Input { role, artifact: what, need: Need::OptionalSource }
}

/// An output in the artifacts directory.
pub const fn artifact(role: &'static str, file: &'static str) -> Output {
    Output { role, artifact: file, place: Place::Artifacts }
}

/// An output in the reports directory.
pub const fn report(role: &'static str, file: &'static str) -> Output {
    Output { role, artifact: file, place: Place::Reports }
}
