//! `pipeline.toml`: its serde shape (unknown keys refused everywhere), the validated
//! [`Pipeline`] it becomes, and every rule checked on the way — names, duplicate outputs,
//! unknown `after` stages, nested parameters, flags that would collide. Dependency cycles
//! are found by [`crate::dag`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::params::{ParamValue, Params};
use crate::paths::ArtifactPath;
use reprise_stagekit::wiring::Wiring;

const TOP_KEYS: &[&str] = &["pipeline", "stage"];
const HEADER_KEYS: &[&str] = &["name", "artifacts", "reports", "stage_identity"];
const STAGE_KEYS: &[&str] = &["bin", "inputs", "outputs", "after", "params", "allow_overwrite"];
/// Flags the runner itself passes, or that every clap binary owns.
const RESERVED: &[&str] = &["check", "help", "version"];

/// `[pipeline]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct HeaderDef {
    name: String,
    artifacts: Option<String>,
    reports: Option<String>,
    stage_identity: Option<StageIdentity>,
}

/// `[pipeline] stage_identity`: what of a stage's binary its cache key holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StageIdentity {
    /// The code identity compiled into it (the source of every crate it links, the
    /// locked dependency versions, the compiler; see `reprise_codeid`), so a rebuild of
    /// unchanged code keeps the cache. A binary without one is keyed on its bytes.
    #[default]
    Code,
    /// Its bytes (strict: any rebuild that changes a byte reruns the stage).
    Binary,
}

/// `[stage.<name>]`, before validation.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StageDef {
    bin: Option<String>,
    #[serde(default)]
    inputs: toml::Table,
    #[serde(default)]
    outputs: toml::Table,
    #[serde(default)]
    after: Vec<String>,
    #[serde(default)]
    params: toml::Table,
    #[serde(default)]
    allow_overwrite: Vec<String>,
}

/// How a stage names its executable.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BinSpec {
    /// A bare name, looked up in `$REPRISE_BIN_DIR`, next to the runner, then on `PATH`.
    Name(String),
    /// A value containing `/`: a path relative to the pipeline file.
    Path(ArtifactPath),
}

impl BinSpec {
    /// The binary as written in `pipeline.toml`.
    #[must_use]
    pub fn declared(&self) -> &str {
        match self {
            Self::Name(name) => name,
            Self::Path(path) => &path.rel,
        }
    }
}

/// One validated stage.
#[derive(Debug, Clone)]
pub struct Stage {
    /// `<name>` of `[stage.<name>]`.
    pub name: String,
    /// The executable.
    pub bin: BinSpec,
    /// Inputs in declaration order. An input given as a list of files or a glob
    /// (`inputs.bvh = ["a.bvh", "b.bvh"]`, `inputs.bvh = "takes/*.bvh"`) is one entry per
    /// file, named `bvh[0]`, `bvh[1]`, … (see [`input_role`]), so the cache key, the lock
    /// and `status` see every file.
    pub inputs: Vec<(String, ArtifactPath)>,
    /// Outputs in declaration order.
    pub outputs: Vec<(String, ArtifactPath)>,
    /// Extra dependencies by stage name.
    pub after: Vec<String>,
    /// Parameters in declaration order.
    pub params: Params,
    /// Outputs (by name) that may replace an existing file this pipeline did not write
    /// (see [`crate::guard`]).
    pub allow_overwrite: Vec<String>,
}

/// A validated `pipeline.toml`.
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// The pipeline file as the user named it (for messages).
    pub file: String,
    /// The absolute directory of the pipeline file: stages run here and paths resolve here.
    pub dir: PathBuf,
    /// The pipeline file's absolute path (no output may name it).
    pub path: PathBuf,
    /// `[pipeline] name`.
    pub name: String,
    /// The artifacts directory, which holds the lock file.
    pub artifacts: ArtifactPath,
    /// Stages in declaration order.
    pub stages: Vec<Stage>,
    /// `[pipeline] stage_identity`.
    pub stage_identity: StageIdentity,
}

impl Pipeline {
    /// Reads and validates the pipeline file at `path`, with no stage declarations (every
    /// input and output given in the file).
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_wired(path, &[])
    }

    /// Reads and validates the pipeline file at `path`, filling in what the stages declared
    /// in `known` leave out ([`crate::wire`]).
    pub fn load_wired(path: &Path, known: &[Wiring]) -> Result<Self> {
        let text = reprise_artifact::input::read_text(path, reprise_artifact::input::MAX_TEXT_BYTES)
            .map_err(|e| Error::PipelineRead { path: path.to_path_buf(), source: e.into_io() })?;
        let abs =
            std::path::absolute(path).map_err(|source| Error::PipelineRead { path: path.to_path_buf(), source })?;
        let dir = crate::paths::normalize(abs.parent().unwrap_or(Path::new("/")));
        Self::parse_wired(&text, &path.display().to_string(), &dir, known)
    }

    /// Validates pipeline text; `file` names it in messages, `dir` is its absolute directory.
    pub fn parse(text: &str, file: &str, dir: &Path) -> Result<Self> {
        Self::parse_wired(text, file, dir, &[])
    }

    /// As [`Pipeline::parse`], wiring the stages declared in `known`.
    pub fn parse_wired(text: &str, file: &str, dir: &Path, known: &[Wiring]) -> Result<Self> {
        let ctx = Ctx { file };
        let top: toml::Table = toml::from_str(text)
            .map_err(|e| Error::PipelineSyntax { file: file.into(), message: e.to_string().trim_end().to_string() })?;
        ctx.known_keys("top level", &top, TOP_KEYS)?;

        let header = top.get("pipeline").ok_or_else(|| ctx.invalid("top level", "missing `[pipeline]` table"))?;
        let header_table = header.as_table().ok_or_else(|| ctx.invalid("`pipeline`", "must be a table"))?;
        ctx.known_keys("[pipeline]", header_table, HEADER_KEYS)?;
        let header: HeaderDef = header.clone().try_into().map_err(|e| ctx.invalid("[pipeline]", e))?;
        ctx.name("pipeline", &header.name)?;
        let artifacts = header.artifacts.unwrap_or_else(|| format!("artifacts/{}", header.name));

        let stage_tables = match top.get("stage") {
            None => return Err(Error::NoStages { file: file.into() }),
            Some(toml::Value::Table(t)) if t.is_empty() => return Err(Error::NoStages { file: file.into() }),
            Some(toml::Value::Table(t)) => t,
            Some(_) => return Err(ctx.invalid("`stage`", "must be a table of `[stage.<name>]` tables")),
        };
        let mut stages =
            stage_tables.iter().map(|(name, value)| ctx.stage(dir, name, value, known)).collect::<Result<Vec<_>>>()?;
        let wirings: Vec<Option<&Wiring>> = stages.iter().map(|s| crate::wire::find(known, &s.bin)).collect();
        let places = crate::wire::Places {
            dir,
            artifacts: &artifacts,
            reports: &header.reports.clone().unwrap_or_else(|| format!("reports/{}", header.name)),
            name: &header.name,
            lock: crate::paths::normalize(Path::new(&format!("{artifacts}/reprise.lock")))
                .to_string_lossy()
                .replace('\\', "/"),
        };
        crate::wire::outputs(&mut stages, &wirings, &places);
        crate::wire::inputs(&mut stages, &wirings, file)?;
        for stage in &stages {
            ctx.check_flags(stage)?;
        }

        let pipeline = Self {
            file: file.into(),
            dir: dir.to_path_buf(),
            path: crate::paths::normalize(&dir.join(Path::new(file).file_name().unwrap_or_default())),
            name: header.name,
            artifacts: ArtifactPath::new(dir, &artifacts),
            stages,
            stage_identity: header.stage_identity.unwrap_or_default(),
        };
        pipeline.check_cross_stage()?;
        Ok(pipeline)
    }

    /// The stage called `name`.
    #[must_use]
    pub fn stage(&self, name: &str) -> Option<&Stage> {
        self.stages.iter().find(|s| s.name == name)
    }

    /// The stage index of `name`, or an error listing the known stages.
    pub fn index_of(&self, name: &str) -> Result<usize> {
        self.stages.iter().position(|s| s.name == name).ok_or_else(|| Error::UnknownStage {
            file: self.file.clone(),
            stage: name.into(),
            known: self.stages.iter().map(|s| format!("`{}`", s.name)).collect::<Vec<_>>().join(", "),
        })
    }

    /// `<artifacts>/reprise.lock`.
    #[must_use]
    pub fn lock_path(&self) -> PathBuf {
        self.artifacts.abs.join("reprise.lock")
    }

    fn check_cross_stage(&self) -> Result<()> {
        crate::guard::check_declared(self)?;
        let mut producers: HashMap<&Path, &str> = HashMap::new();
        for stage in &self.stages {
            for (_, path) in &stage.outputs {
                if let Some(first) = producers.insert(&path.abs, &stage.name) {
                    return Err(Error::DuplicateOutput {
                        file: self.file.clone(),
                        path: path.rel.clone(),
                        first: first.into(),
                        second: stage.name.clone(),
                    });
                }
            }
        }
        for stage in &self.stages {
            if let Some(after) = stage.after.iter().find(|a| self.stage(a).is_none()) {
                return Err(Error::UnknownAfter {
                    file: self.file.clone(),
                    stage: stage.name.clone(),
                    after: after.clone(),
                });
            }
        }
        Ok(())
    }
}

/// Validation context: the file name every message starts with.
struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn invalid(&self, context: &str, message: impl ToString) -> Error {
        Error::InvalidValue {
            file: self.file.into(),
            context: context.into(),
            message: message.to_string().trim_end().to_string(),
        }
    }

    fn known_keys(&self, context: &str, table: &toml::Table, expected: &'static [&'static str]) -> Result<()> {
        match table.keys().find(|k| !expected.contains(&k.as_str())) {
            None => Ok(()),
            Some(key) => Err(Error::UnknownKey {
                file: self.file.into(),
                context: context.into(),
                key: key.clone(),
                suggestion: closest(key, expected).map(str::to_string),
                expected,
            }),
        }
    }

    fn name(&self, what: &str, name: &str) -> Result<()> {
        if valid_name(name) {
            Ok(())
        } else {
            Err(Error::InvalidName { file: self.file.into(), what: what.into(), name: name.into() })
        }
    }

    fn stage(&self, dir: &Path, name: &str, value: &toml::Value, known: &[Wiring]) -> Result<Stage> {
        self.name("stage", name)?;
        let context = format!("stage `{name}`");
        let table = value.as_table().ok_or_else(|| self.invalid(&context, "must be a table"))?;
        self.known_keys(&context, table, STAGE_KEYS)?;
        let def: StageDef = value.clone().try_into().map_err(|e| self.invalid(&context, e))?;

        let declared = match def.bin {
            Some(bin) => bin,
            None => known.iter().find(|w| w.stage == name).map(|w| w.bin.to_string()).ok_or_else(|| Error::NoBin {
                file: self.file.into(),
                stage: name.into(),
                known: known.iter().map(|w| format!("`{}`", w.stage)).collect::<Vec<_>>().join(", "),
            })?,
        };
        let bin = if declared.contains('/') {
            BinSpec::Path(ArtifactPath::new(dir, &declared))
        } else if declared.is_empty() {
            return Err(self.invalid(&context, "`bin` is empty"));
        } else {
            BinSpec::Name(declared)
        };
        let inputs = self.input_paths(dir, name, &def.inputs)?;
        let outputs = self.paths(dir, name, "output", &def.outputs)?;
        let mut params = Params::new();
        for (param, value) in &def.params {
            self.name(&format!("stage `{name}`: parameter"), param)?;
            let value = ParamValue::from_toml(value).map_err(|why| Error::NestedParam {
                file: self.file.into(),
                stage: name.into(),
                param: param.clone(),
                found: why.describe(),
            })?;
            params.push((param.clone(), value));
        }
        let declared_outputs = crate::wire::find(known, &bin).map_or(&[][..], |w| w.outputs);
        if let Some(unknown) = def
            .allow_overwrite
            .iter()
            .find(|o| !outputs.iter().any(|(n, _)| n == *o) && !declared_outputs.iter().any(|d| d.role == o.as_str()))
        {
            return Err(self.invalid(&context, format!("`allow_overwrite` names `{unknown}`, which is not an output")));
        }
        let stage = Stage {
            name: name.into(),
            bin,
            inputs,
            outputs,
            after: def.after,
            params,
            allow_overwrite: def.allow_overwrite,
        };
        Ok(stage)
    }

    fn paths(&self, dir: &Path, stage: &str, what: &str, table: &toml::Table) -> Result<Vec<(String, ArtifactPath)>> {
        table
            .iter()
            .map(|(name, value)| {
                self.name(&format!("stage `{stage}`: {what}"), name)?;
                match value {
                    toml::Value::String(path) if !path.is_empty() => Ok((name.clone(), ArtifactPath::new(dir, path))),
                    other => Err(self.invalid(
                        &format!("stage `{stage}`"),
                        format!("{what} `{name}` must be a non-empty path string, found {}", other.type_str()),
                    )),
                }
            })
            .collect()
    }

    /// A stage's inputs: each a path, a glob (one entry per matching file, sorted) or a
    /// list of paths and globs (one entry per file, in order).
    fn input_paths(&self, dir: &Path, stage: &str, table: &toml::Table) -> Result<Vec<(String, ArtifactPath)>> {
        let mut out = Vec::new();
        for (name, value) in table {
            self.name(&format!("stage `{stage}`: input"), name)?;
            let bad = |found: &str| {
                self.invalid(
                    &format!("stage `{stage}`"),
                    format!("input `{name}` must be a non-empty path string or a list of them, found {found}"),
                )
            };
            let (declared, listed): (Vec<&str>, bool) = match value {
                toml::Value::String(path) if !path.is_empty() => (vec![path.as_str()], false),
                toml::Value::Array(items) if !items.is_empty() => {
                    let paths = items.iter().map(|v| match v {
                        toml::Value::String(p) if !p.is_empty() => Ok(p.as_str()),
                        other => Err(bad(&format!("a list holding {}", describe(other)))),
                    });
                    (paths.collect::<Result<_>>()?, true)
                }
                other => return Err(bad(&describe(other))),
            };
            let mut files = Vec::new();
            let mut globbed = false;
            for path in declared {
                if crate::paths::is_glob(path) {
                    globbed = true;
                    let matched = crate::paths::expand_glob(dir, path).map_err(|why| Error::InputGlob {
                        file: self.file.into(),
                        stage: stage.into(),
                        input: name.clone(),
                        pattern: path.into(),
                        why,
                    })?;
                    files.extend(matched.iter().map(|m| ArtifactPath::new(dir, m)));
                } else {
                    files.push(ArtifactPath::new(dir, path));
                }
            }
            if listed || globbed {
                out.extend(files.into_iter().enumerate().map(|(i, path)| (format!("{name}[{i}]"), path)));
            } else {
                out.extend(files.into_iter().map(|path| (name.clone(), path)));
            }
        }
        Ok(out)
    }

    /// Every input, output and parameter becomes a `--flag`; no two may share one, and none
    /// may take a flag the runner or clap owns. The files of one input (a list or a glob)
    /// share its flag.
    fn check_flags(&self, stage: &Stage) -> Result<()> {
        let mut roles: Vec<&str> = stage.inputs.iter().map(|(n, _)| input_role(n)).collect();
        roles.dedup();
        let roles: Vec<String> = roles.into_iter().map(str::to_string).collect();
        let inputs = roles.iter().map(|n| ("input", n));
        let outputs = stage.outputs.iter().map(|(n, _)| ("output", n));
        let params = stage.params.iter().map(|(n, _)| ("parameter", n));
        let mut seen: HashMap<String, (&str, &String)> = HashMap::new();
        for (kind, name) in inputs.chain(outputs).chain(params) {
            let flag = name.replace('_', "-");
            if RESERVED.contains(&flag.as_str()) {
                return Err(self.invalid(
                    &format!("stage `{}`", stage.name),
                    format!("{kind} name `{name}` is reserved (the runner passes `--{flag}` itself)"),
                ));
            }
            if let Some((first_kind, first)) = seen.insert(flag.clone(), (kind, name)) {
                if first == name && first_kind == "input" && kind == "parameter" {
                    return Err(Error::InputParamClash {
                        file: self.file.into(),
                        stage: stage.name.clone(),
                        name: name.clone(),
                    });
                }
                return Err(Error::FlagClash {
                    file: self.file.into(),
                    stage: stage.name.clone(),
                    first: format!("{first_kind} `{first}`"),
                    second: format!("{kind} `{name}`"),
                    flag,
                });
            }
        }
        Ok(())
    }
}

/// The input (the stage's flag) an entry of [`Stage::inputs`] belongs to: `bvh` for
/// `bvh[2]`, the name itself otherwise.
#[must_use]
pub fn input_role(name: &str) -> &str {
    name.split_once('[').map_or(name, |(role, _)| role)
}

/// A TOML value's type, for messages (`integer`, `table`, …; `empty string`, `empty list`).
fn describe(value: &toml::Value) -> String {
    match value {
        toml::Value::String(s) if s.is_empty() => "an empty string".into(),
        toml::Value::Array(a) if a.is_empty() => "an empty list".into(),
        other => other.type_str().into(),
    }
}

/// `[a-z0-9_-]+`.
#[must_use]
pub fn valid_name(name: &str) -> bool {
    !name.is_empty() && name.bytes().all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-')
}

/// The expected key nearest to a misspelt one, if it is near enough to be a typo.
fn closest<'a>(key: &str, expected: &[&'a str]) -> Option<&'a str> {
    expected
        .iter()
        .map(|candidate| (edit_distance(key, candidate), *candidate))
        .filter(|(d, candidate)| *d <= 2.max(candidate.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, candidate)| candidate)
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diagonal + usize::from(ca != *cb)).min(row[j] + 1).min(row[j + 1] + 1);
            diagonal = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    const DIR: &str = "/p";

    fn parse(text: &str) -> Result<Pipeline> {
        Pipeline::parse(text, "pipeline.toml", Path::new(DIR))
    }

    fn err(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    const EXAMPLE: &str = r#"
        [pipeline]
        name = "dragon-face"

        [stage.ingest]
        bin = "reprise-ingest"
        inputs = {}
        outputs.frames = "artifacts/dragon-face/frames.parquet"
        outputs.controls = "artifacts/dragon-face/controls.parquet"
        after = []
        [stage.ingest.params]
        source = "dragon-face"
        seed = 7

        [stage.label]
        bin = "./bin/label.sh"
        inputs.frames = "artifacts/dragon-face/frames.parquet"
        inputs.labels = "datasets/dragon-face/labels.toml"
        outputs.segments = "artifacts/dragon-face/segments.parquet"
        [stage.label.params]
        min_segment_length = 12
        mask = ["eye_*"]
    "#;

    #[test]
    fn parses_the_documented_example() {
        let p = parse(EXAMPLE).unwrap();
        assert_eq!(p.name, "dragon-face");
        assert_eq!(p.artifacts.rel, "artifacts/dragon-face");
        assert_eq!(p.lock_path(), PathBuf::from("/p/artifacts/dragon-face/reprise.lock"));
        let names: Vec<_> = p.stages.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["ingest", "label"]);
        let ingest = &p.stages[0];
        assert_eq!(ingest.bin, BinSpec::Name("reprise-ingest".into()));
        let outputs: Vec<_> = ingest.outputs.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(outputs, ["frames", "controls"], "declaration order is kept");
        let label = &p.stages[1];
        assert_eq!(label.bin.declared(), "bin/label.sh");
        assert!(matches!(&label.bin, BinSpec::Path(path) if path.abs == Path::new("/p/bin/label.sh")));
        assert_eq!(label.params[1].1.plain(), "eye_*");
    }

    #[test]
    fn explicit_artifacts_directory() {
        let p = parse("[pipeline]\nname = \"x\"\nartifacts = \"out/./x\"\n[stage.a]\nbin = \"a\"\n").unwrap();
        assert_eq!(p.artifacts.rel, "out/x");
    }

    #[test]
    fn unknown_stage_key_names_file_stage_and_key() {
        let text = EXAMPLE.replace("outputs.segments", "ouputs.segments");
        assert_eq!(err(&text), "pipeline.toml: stage `label`: unknown key `ouputs` (did you mean `outputs`?)");
    }

    #[test]
    fn unknown_keys_elsewhere() {
        assert!(err("[pipeline]\nname = \"x\"\nnmae = 1\n[stage.a]\nbin = \"a\"\n")
            .starts_with("pipeline.toml: [pipeline]: unknown key `nmae` (did you mean `name`?)"));
        assert!(err("[pipeline]\nname = \"x\"\n[stages.a]\nbin = \"a\"\n")
            .contains("top level: unknown key `stages` (did you mean `stage`?)"));
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nzzzzzzz = 1\n").contains(
            "unknown key `zzzzzzz` (expected one of `bin`, `inputs`, `outputs`, `after`, `params`, `allow_overwrite`)"
        ));
    }

    #[test]
    fn missing_pieces() {
        assert!(err("[stage.a]\nbin = \"a\"\n").contains("missing `[pipeline]` table"));
        assert!(err("[pipeline]\n[stage.a]\nbin = \"a\"\n").contains("missing field `name`"));
        assert!(err("[pipeline]\nname = \"x\"\n").contains("no stages"));
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\ninputs = {}\n").contains("stage `a` has no `bin`"));
    }

    #[test]
    fn syntax_errors_carry_the_file_name() {
        assert!(err("[pipeline\n").starts_with("pipeline.toml: TOML parse error at line 1"));
    }

    #[test]
    fn wrong_types() {
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\ninputs.f = 3\n")
            .contains("stage `a`: input `f` must be a non-empty path string or a list of them, found integer"));
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nafter = \"b\"\n")
            .contains("stage `a`: invalid type"));
    }

    #[test]
    fn names_are_checked() {
        assert!(
            err("[pipeline]\nname = \"x\"\n[stage.Ingest]\nbin = \"a\"\n").contains("stage name `Ingest` is invalid")
        );
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\noutputs.\"a b\" = \"x\"\n")
            .contains("stage `a`: output name `a b` is invalid"));
        assert!(err("[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nparams.minLen = 1\n")
            .contains("stage `a`: parameter name `minLen` is invalid"));
        assert!(err("[pipeline]\nname = \"x y\"\n[stage.a]\nbin = \"a\"\n").contains("pipeline name `x y` is invalid"));
    }

    #[test]
    fn duplicate_output() {
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\noutputs.o = \"out/o.parquet\"\n\
                    [stage.b]\nbin = \"b\"\noutputs.p = \"./out/o.parquet\"\n";
        assert_eq!(err(text), "pipeline.toml: output `out/o.parquet` is produced by both stage `a` and stage `b`");
    }

    #[test]
    fn unknown_after_stage() {
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nafter = [\"ghost\"]\n";
        assert_eq!(err(text), "pipeline.toml: stage `a`: `after` names unknown stage `ghost`");
    }

    #[test]
    fn nested_params() {
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\n[stage.a.params.fit]\niters = 3\n";
        assert_eq!(
            err(text),
            "pipeline.toml: stage `a`: parameter `fit` is a table; parameters must be scalars or arrays of scalars"
        );
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nparams.grid = [[1, 2], [3]]\n";
        assert!(err(text).contains("parameter `grid` is an array of arrays"));
    }

    #[test]
    fn input_named_like_a_param() {
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\ninputs.seed = \"s.txt\"\nparams.seed = 1\n";
        assert_eq!(err(text), "pipeline.toml: stage `a`: `seed` is both an input and a parameter");
    }

    #[test]
    fn flags_that_collide_or_are_reserved() {
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\noutputs.min_len = \"o\"\nparams.min-len = 1\n";
        assert!(err(text).contains("output `min_len` and parameter `min-len` would both be passed as `--min-len`"));
        let text = "[pipeline]\nname = \"x\"\n[stage.a]\nbin = \"a\"\nparams.check = true\n";
        assert!(err(text).contains("parameter name `check` is reserved"));
    }
}
