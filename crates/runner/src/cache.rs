//! Freshness: is a stage's last successful run (its lock entry) still valid, and if not,
//! every reason why. A stage is fresh when its entry's key equals the current key and every
//! output still exists with the recorded content. Staleness flows downstream: a stage whose
//! dependency is stale or forced is stale too, predicted before anything reruns.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::PathBuf;

use crate::dag::Dag;
use crate::error::Result;
use crate::hash::FileHasher;
use crate::key::cache_key;
use crate::locate::{locate, BinDirs};
use crate::lock::{BinRecord, LockEntry, LockFile};
use crate::params::canonical_json;
use crate::pipeline::{Pipeline, Stage, StageIdentity};

/// Why a stage must run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reason {
    /// `--force` named it.
    Forced,
    /// A stage it depends on will rerun.
    Upstream { stage: String },
    /// No successful run is recorded.
    NeverRun,
    /// The binary cannot be found.
    BinaryMissing { bin: String },
    /// The binary's code identity differs from the recorded one.
    CodeChanged { bin: String },
    /// The binary's content differs from the recorded one (binaries without a code
    /// identity, or `stage_identity = "binary"`).
    BinaryChanged { bin: String },
    /// A parameter's value differs (values as JSON).
    ParamChanged { name: String, old: String, new: String },
    /// A parameter not in the recorded run.
    ParamAdded { name: String, value: String },
    /// A recorded parameter that is gone.
    ParamRemoved { name: String, old: String },
    /// A source input does not exist.
    InputMissing { name: String, path: String },
    /// An input's content differs from the recorded one.
    InputChanged { name: String, path: String },
    /// An input's content differs, and both runs know its label partitions: which changed.
    InputLabelsChanged { name: String, path: String, delta: crate::label_digest::Delta },
    /// An input declared now that the recorded run did not have, or now at another path.
    InputAdded { name: String, path: String },
    /// A recorded input that is no longer declared.
    InputRemoved { name: String },
    /// An output does not exist.
    OutputMissing { name: String, path: String },
    /// An output's content differs from what the stage wrote.
    OutputModified { name: String, path: String },
    /// An output declared now that the recorded run did not write, or now at another path.
    OutputAdded { name: String, path: String },
    /// A recorded output that is no longer declared.
    OutputRemoved { name: String },
    /// The key differs for no reason above (a lock written by another runner version).
    KeyChanged,
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Forced => write!(f, "forced with --force"),
            Self::Upstream { stage } => write!(f, "upstream stage `{stage}` is stale (will rerun)"),
            Self::NeverRun => write!(f, "never run"),
            Self::BinaryMissing { bin } => write!(f, "stage binary `{bin}` not found"),
            Self::CodeChanged { bin } => write!(f, "the code of stage binary `{bin}` changed"),
            Self::BinaryChanged { bin } => write!(f, "stage binary `{bin}` changed"),
            Self::ParamChanged { name, old, new } => write!(f, "parameter `{name}` changed: {old} -> {new}"),
            Self::ParamAdded { name, value } => write!(f, "parameter `{name}` added: {value}"),
            Self::ParamRemoved { name, old } => write!(f, "parameter `{name}` removed (was {old})"),
            Self::InputMissing { name, path } => write!(f, "input `{name}` missing ({path})"),
            Self::InputChanged { name, path } => write!(f, "input `{name}` changed ({path})"),
            Self::InputLabelsChanged { name, path, delta } => write!(f, "input `{name}` changed ({path}): {delta}"),
            Self::InputAdded { name, path } => write!(f, "input `{name}` added ({path})"),
            Self::InputRemoved { name } => write!(f, "input `{name}` removed"),
            Self::OutputMissing { name, path } => write!(f, "output `{name}` missing ({path})"),
            Self::OutputModified { name, path } => write!(f, "output `{name}` modified since it was written ({path})"),
            Self::OutputAdded { name, path } => write!(f, "output `{name}` added ({path})"),
            Self::OutputRemoved { name } => write!(f, "output `{name}` removed"),
            Self::KeyChanged => write!(f, "cache key changed (lock written by another version of reprise)"),
        }
    }
}

/// A stage binary found and hashed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResolvedBin {
    /// Where it is.
    pub path: PathBuf,
    /// blake3 of its content.
    pub blake3: String,
    /// The code identity it carries, if the stage is keyed on code and it has one.
    pub code_id: Option<String>,
}

impl ResolvedBin {
    /// Its record in the lock.
    #[must_use]
    pub fn record(&self) -> BinRecord {
        BinRecord { path: self.path.display().to_string(), blake3: self.blake3.clone(), code_id: self.code_id.clone() }
    }
}

/// The verdict on one stage.
#[derive(Debug, Clone)]
pub struct Assessment {
    /// The binary, or where it was looked for.
    pub bin: Result<ResolvedBin, String>,
    /// Empty when fresh.
    pub reasons: Vec<Reason>,
}

impl Assessment {
    /// No reason to run.
    #[must_use]
    pub fn is_fresh(&self) -> bool {
        self.reasons.is_empty()
    }
}

/// What `assess` needs besides the pipeline.
pub struct Inputs<'a> {
    /// The parsed pipeline.
    pub pipeline: &'a Pipeline,
    /// Its graph.
    pub dag: &'a Dag,
    /// The lock as read.
    pub lock: &'a LockFile,
    /// Stages named by `--force`.
    pub forced: &'a BTreeSet<usize>,
    /// Where bare binary names are looked up.
    pub dirs: &'a BinDirs,
}

/// Assesses every stage, in run order, so that upstream staleness is known before each
/// downstream stage. The result is indexed like `pipeline.stages`.
pub fn assess(ctx: &Inputs<'_>, hasher: &mut FileHasher) -> Result<Vec<Assessment>> {
    let stages = &ctx.pipeline.stages;
    let mut out: Vec<Option<Assessment>> = vec![None; stages.len()];
    let bins = stages.iter().filter_map(|s| locate(&s.bin, ctx.dirs).ok());
    let files = stages.iter().flat_map(|s| s.inputs.iter().chain(&s.outputs)).map(|(_, p)| p.abs.clone());
    hasher.prefetch(bins.chain(files));
    for &i in ctx.dag.order() {
        let stage = &stages[i];
        let mut reasons = Vec::new();
        if ctx.forced.contains(&i) {
            reasons.push(Reason::Forced);
        }
        for dep in ctx.dag.deps(i) {
            if out[dep].as_ref().is_some_and(|a| !a.is_fresh()) {
                reasons.push(Reason::Upstream { stage: stages[dep].name.clone() });
            }
        }
        let bin = resolve_bin(stage, ctx.dirs, ctx.pipeline.stage_identity, hasher)?;
        // A missing input some stage writes is explained by that stage being stale.
        let explained = if reasons.iter().any(|r| matches!(r, Reason::Upstream { .. })) {
            ctx.dag.produced_inputs(i)
        } else {
            BTreeSet::new()
        };
        reasons.extend(own_reasons(stage, &bin, ctx.lock.stages.get(&stage.name), &explained, hasher)?);
        out[i] = Some(Assessment { bin, reasons });
    }
    Ok(out
        .into_iter()
        .map(|a| a.unwrap_or(Assessment { bin: Err(String::new()), reasons: vec![Reason::NeverRun] }))
        .collect())
}

/// Finds and hashes a stage's binary, and reads its code identity when the stage is keyed
/// on code; a missing binary is reported, not an error.
pub fn resolve_bin(
    stage: &Stage,
    dirs: &BinDirs,
    identity: StageIdentity,
    hasher: &mut FileHasher,
) -> Result<Result<ResolvedBin, String>> {
    match locate(&stage.bin, dirs) {
        Err(searched) => Ok(Err(searched)),
        Ok(path) => match hasher.hash(&path)? {
            Some(blake3) => {
                let code_id = match identity {
                    StageIdentity::Code => hasher.code_id(&path)?,
                    StageIdentity::Binary => None,
                };
                Ok(Ok(ResolvedBin { path, blake3, code_id }))
            }
            None => Ok(Err(format!("`{}`", path.display()))),
        },
    }
}

/// The blake3 of each input, by name; `None` for those that do not exist.
pub fn input_hashes(stage: &Stage, hasher: &mut FileHasher) -> Result<BTreeMap<String, Option<String>>> {
    stage.inputs.iter().map(|(name, path)| Ok((name.clone(), hasher.hash(&path.abs)?))).collect()
}

/// The current cache key, if the binary and every input exist.
pub fn current_key(stage: &Stage, bin: &ResolvedBin, inputs: &BTreeMap<String, Option<String>>) -> Option<String> {
    let hashes: Option<BTreeMap<String, String>> =
        inputs.iter().map(|(name, hash)| hash.clone().map(|h| (name.clone(), h))).collect();
    let outputs = stage.outputs.iter().map(|(name, path)| (name.as_str(), path.rel.as_str()));
    Some(cache_key(&stage.name, &bin.record().identity(), &stage.params, &hashes?, outputs))
}

/// The reasons that come from the stage itself and its lock entry (not from upstream).
/// `explained` names inputs whose absence is explained by a stale upstream stage.
fn own_reasons(
    stage: &Stage,
    bin: &Result<ResolvedBin, String>,
    entry: Option<&LockEntry>,
    explained: &BTreeSet<&str>,
    hasher: &mut FileHasher,
) -> Result<Vec<Reason>> {
    let mut reasons = Vec::new();
    let inputs = input_hashes(stage, hasher)?;
    let missing: Vec<Reason> = stage
        .inputs
        .iter()
        .filter(|(name, _)| inputs[name].is_none() && !explained.contains(name.as_str()))
        .map(|(name, path)| Reason::InputMissing { name: name.clone(), path: path.rel.clone() })
        .collect();

    let Some(entry) = entry else {
        reasons.push(Reason::NeverRun);
        if bin.is_err() {
            reasons.push(Reason::BinaryMissing { bin: stage.bin.declared().into() });
        }
        reasons.extend(missing);
        return Ok(reasons);
    };

    match bin {
        Err(_) => reasons.push(Reason::BinaryMissing { bin: stage.bin.declared().into() }),
        Ok(bin) if bin.record().identity() != entry.bin.identity() => {
            let bin_name = stage.bin.declared().into();
            reasons.push(match (&bin.code_id, &entry.bin.code_id) {
                (Some(_), Some(_)) => Reason::CodeChanged { bin: bin_name },
                _ => Reason::BinaryChanged { bin: bin_name },
            })
        }
        Ok(_) => {}
    }
    param_reasons(stage, entry, &mut reasons);

    reasons.extend(missing);
    for (name, path) in &stage.inputs {
        match (entry.inputs.get(name), &inputs[name]) {
            (_, None) => {} // reported above, or explained upstream
            (Some(old), Some(now)) if old.path == path.rel => {
                if &old.blake3 != now {
                    let labels =
                        (!old.labels.is_empty()).then(|| crate::label_digest::label_digests(&path.abs)).flatten();
                    reasons.push(match labels {
                        Some(new) => Reason::InputLabelsChanged {
                            name: name.clone(),
                            path: path.rel.clone(),
                            delta: crate::label_digest::Delta::between(&old.labels, &new),
                        },
                        None => Reason::InputChanged { name: name.clone(), path: path.rel.clone() },
                    });
                }
            }
            (_, Some(_)) => reasons.push(Reason::InputAdded { name: name.clone(), path: path.rel.clone() }),
        }
    }
    for name in entry.inputs.keys().filter(|n| !stage.inputs.iter().any(|(m, _)| m == *n)) {
        reasons.push(Reason::InputRemoved { name: name.clone() });
    }

    for (name, path) in &stage.outputs {
        match entry.outputs.get(name) {
            Some(old) if old.path == path.rel => match hasher.hash(&path.abs)? {
                None => reasons.push(Reason::OutputMissing { name: name.clone(), path: path.rel.clone() }),
                Some(now) if now != old.blake3 => {
                    reasons.push(Reason::OutputModified { name: name.clone(), path: path.rel.clone() });
                }
                Some(_) => {}
            },
            // Not recorded by the last run (a new output, or a run that stopped before
            // recording it): "added" only if the file is there, else it is missing.
            _ => reasons.push(match hasher.hash(&path.abs)? {
                None => Reason::OutputMissing { name: name.clone(), path: path.rel.clone() },
                Some(_) => Reason::OutputAdded { name: name.clone(), path: path.rel.clone() },
            }),
        }
    }
    for name in entry.outputs.keys().filter(|n| !stage.outputs.iter().any(|(m, _)| m == *n)) {
        reasons.push(Reason::OutputRemoved { name: name.clone() });
    }

    // With every ingredient unchanged the key matches, unless the lock was written by a
    // runner that computed keys differently. (No key without a binary or with a missing
    // input: both are reported above or upstream.)
    if reasons.is_empty() {
        let key = bin.as_ref().ok().and_then(|bin| current_key(stage, bin, &inputs));
        if key.is_some_and(|key| key != entry.key) {
            reasons.push(Reason::KeyChanged);
        }
    }
    Ok(reasons)
}

fn param_reasons(stage: &Stage, entry: &LockEntry, reasons: &mut Vec<Reason>) {
    let now = canonical_json(&stage.params);
    // Report in declaration order, then removed ones in sorted order.
    for (name, _) in &stage.params {
        let value = now[name].to_string();
        match entry.params.get(name) {
            None => reasons.push(Reason::ParamAdded { name: name.clone(), value }),
            Some(old) if *old != now[name] => {
                reasons.push(Reason::ParamChanged { name: name.clone(), old: old.to_string(), new: value });
            }
            Some(_) => {}
        }
    }
    for (name, old) in entry.params.iter().filter(|(n, _)| !now.contains_key(*n)) {
        reasons.push(Reason::ParamRemoved { name: name.clone(), old: old.to_string() });
    }
}

#[cfg(test)]
mod tests {
    use std::fs;
    use std::path::Path;

    use super::*;
    use crate::lock::FileRecord;

    /// A two-stage pipeline in a tempdir whose "binaries" are `/bin/sh`-free plain files
    /// found through a `BinDirs` pointing at the tempdir.
    struct Fixture {
        dir: tempfile::TempDir,
    }

    impl Fixture {
        fn new() -> Self {
            let dir = tempfile::tempdir().unwrap();
            fs::create_dir_all(dir.path().join("bin")).unwrap();
            for bin in ["make", "use"] {
                let path = dir.path().join("bin").join(bin);
                fs::write(&path, format!("binary {bin}")).unwrap();
                #[cfg(unix)]
                {
                    use std::os::unix::fs::PermissionsExt;
                    fs::set_permissions(&path, fs::Permissions::from_mode(0o755)).unwrap();
                }
            }
            fs::write(dir.path().join("src.txt"), "source").unwrap();
            Self { dir }
        }

        fn path(&self, rel: &str) -> std::path::PathBuf {
            self.dir.path().join(rel)
        }

        fn pipeline(&self, use_params: &str) -> (Pipeline, Dag) {
            let text = format!(
                "[pipeline]\nname = \"t\"\n\
                 [stage.make]\nbin = \"make\"\ninputs.src = \"src.txt\"\noutputs.mid = \"mid.txt\"\nparams.n = 1\n\
                 [stage.use]\nbin = \"use\"\ninputs.mid = \"mid.txt\"\noutputs.out = \"out.txt\"\n{use_params}"
            );
            let p = Pipeline::parse(&text, "pipeline.toml", self.dir.path()).unwrap();
            let d = Dag::build(&p).unwrap();
            (p, d)
        }

        fn dirs(&self) -> BinDirs {
            BinDirs { env_dir: Some(self.path("bin")), ..BinDirs::default() }
        }

        /// Writes the outputs and a lock recording the pipeline as it is now.
        fn run_all(&self, p: &Pipeline) -> LockFile {
            fs::write(self.path("mid.txt"), "mid").unwrap();
            fs::write(self.path("out.txt"), "out").unwrap();
            let mut hasher = FileHasher::new();
            let mut lock = LockFile::empty("t");
            for stage in &p.stages {
                let bin = resolve_bin(stage, &self.dirs(), p.stage_identity, &mut hasher).unwrap().unwrap();
                let inputs = input_hashes(stage, &mut hasher).unwrap();
                let record = |path: &crate::paths::ArtifactPath, h: &mut FileHasher| FileRecord {
                    path: path.rel.clone(),
                    blake3: h.hash(&path.abs).unwrap().unwrap(),
                    labels: BTreeMap::new(),
                };
                let entry = LockEntry {
                    key: current_key(stage, &bin, &inputs).unwrap(),
                    bin: bin.record(),
                    params: canonical_json(&stage.params),
                    inputs: stage.inputs.iter().map(|(n, path)| (n.clone(), record(path, &mut hasher))).collect(),
                    outputs: stage.outputs.iter().map(|(n, path)| (n.clone(), record(path, &mut hasher))).collect(),
                    finished_at: String::new(),
                    seconds: 0.0,
                    peak_rss_mb: None,
                    partitions: BTreeMap::new(),
                    job: None,
                };
                lock.stages.insert(stage.name.clone(), entry);
            }
            lock
        }

        fn reasons(&self, p: &Pipeline, d: &Dag, lock: &LockFile, forced: &[usize]) -> Vec<Vec<String>> {
            let forced = forced.iter().copied().collect();
            let dirs = self.dirs();
            let ctx = Inputs { pipeline: p, dag: d, lock, forced: &forced, dirs: &dirs };
            assess(&ctx, &mut FileHasher::new())
                .unwrap()
                .iter()
                .map(|a| a.reasons.iter().map(ToString::to_string).collect())
                .collect()
        }
    }

    const UPSTREAM: &str = "upstream stage `make` is stale (will rerun)";

    #[test]
    fn never_run() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let r = f.reasons(&p, &d, &LockFile::empty("t"), &[]);
        assert_eq!(r, [vec!["never run"], vec![UPSTREAM, "never run"]]);
    }

    #[test]
    fn fresh_after_a_recorded_run() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let lock = f.run_all(&p);
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [Vec::<String>::new(), vec![]]);
    }

    #[test]
    fn changed_param_is_named_and_flows_downstream() {
        let f = Fixture::new();
        let (p, _) = f.pipeline("params.k = 12\n");
        let lock = f.run_all(&p);
        let (p2, d2) = f.pipeline("params.k = 24\nparams.extra = \"x\"\n");
        assert_eq!(
            f.reasons(&p2, &d2, &lock, &[]),
            [vec![], vec!["parameter `k` changed: 12 -> 24", "parameter `extra` added: \"x\""]]
        );
        let (p3, d3) = f.pipeline("");
        assert_eq!(f.reasons(&p3, &d3, &lock, &[]), [vec![], vec!["parameter `k` removed (was 12)"]]);
    }

    #[test]
    fn changed_source_input_makes_both_stale() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let lock = f.run_all(&p);
        fs::write(f.path("src.txt"), "edited").unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec!["input `src` changed (src.txt)"], vec![UPSTREAM]]);
        fs::remove_file(f.path("src.txt")).unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec!["input `src` missing (src.txt)"], vec![UPSTREAM]]);
    }

    #[test]
    fn deleted_and_modified_outputs() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let lock = f.run_all(&p);
        fs::write(f.path("out.txt"), "tampered").unwrap();
        assert_eq!(
            f.reasons(&p, &d, &lock, &[]),
            [vec![], vec!["output `out` modified since it was written (out.txt)"]]
        );
        fs::remove_file(f.path("mid.txt")).unwrap();
        // `use`'s input is gone too, but that is explained by its producer being stale.
        assert_eq!(
            f.reasons(&p, &d, &lock, &[]),
            [
                vec!["output `mid` missing (mid.txt)"],
                vec![UPSTREAM, "output `out` modified since it was written (out.txt)"]
            ]
        );
    }

    /// An output the last run did not record (a run that stopped before recording it) is
    /// "missing" when its file is gone and "added" only when the file is there.
    #[test]
    fn unrecorded_outputs_are_missing_unless_present() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let mut lock = f.run_all(&p);
        let make = lock.stages.values_mut().find(|e| e.outputs.contains_key("mid")).unwrap();
        make.outputs.remove("mid");
        assert_eq!(f.reasons(&p, &d, &lock, &[])[0], ["output `mid` added (mid.txt)"]);
        fs::remove_file(f.path("mid.txt")).unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[])[0], ["output `mid` missing (mid.txt)"]);
    }

    #[test]
    fn changed_binary_and_forced_stage() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let lock = f.run_all(&p);
        assert_eq!(f.reasons(&p, &d, &lock, &[0]), [vec!["forced with --force"], vec![UPSTREAM]]);
        fs::write(f.path("bin/use"), "rebuilt").unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec![], vec!["stage binary `use` changed"]]);
        fs::remove_file(f.path("bin/use")).unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec![], vec!["stage binary `use` not found"]]);
    }

    /// A rebuild that keeps the code identity keeps the cache; a new identity reruns,
    /// named as a code change; a binary that loses its identity is compared by bytes; and
    /// under `stage_identity = "binary"` the bytes decide.
    #[test]
    fn a_binary_is_keyed_on_its_code_identity() {
        let f = Fixture::new();
        let id = |c: &str| format!("reprise-code-id={};", c.repeat(64));
        fs::write(f.path("bin/use"), format!("build 1 {}", id("a"))).unwrap();
        let (p, d) = f.pipeline("");
        let lock = f.run_all(&p);
        assert_eq!(lock.stages["use"].bin.code_id.as_deref(), Some("a".repeat(64).as_str()));
        assert!(lock.stages["make"].bin.code_id.is_none(), "no identity in `make`");
        fs::write(f.path("bin/use"), format!("build 2, other bytes {}", id("a"))).unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [Vec::<String>::new(), vec![]], "same code: fresh");
        fs::write(f.path("bin/use"), format!("build 3 {}", id("b"))).unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec![], vec!["the code of stage binary `use` changed"]]);
        fs::write(f.path("bin/use"), "build 4, no identity").unwrap();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec![], vec!["stage binary `use` changed"]]);

        fs::write(f.path("bin/use"), format!("build 1 {}", id("a"))).unwrap();
        let text = |mode: &str| {
            format!(
                "[pipeline]\nname = \"t\"\nstage_identity = \"{mode}\"\n\
                 [stage.make]\nbin = \"make\"\ninputs.src = \"src.txt\"\noutputs.mid = \"mid.txt\"\nparams.n = 1\n\
                 [stage.use]\nbin = \"use\"\ninputs.mid = \"mid.txt\"\noutputs.out = \"out.txt\"\n"
            )
        };
        let strict = Pipeline::parse(&text("binary"), "pipeline.toml", f.dir.path()).unwrap();
        let sd = Dag::build(&strict).unwrap();
        let lock = f.run_all(&strict);
        assert!(lock.stages["use"].bin.code_id.is_none(), "strict: keyed on bytes");
        fs::write(f.path("bin/use"), format!("build 2, other bytes {}", id("a"))).unwrap();
        assert_eq!(f.reasons(&strict, &sd, &lock, &[]), [vec![], vec!["stage binary `use` changed"]]);
        let bad = Pipeline::parse(&text("bytes"), "pipeline.toml", f.dir.path()).unwrap_err().to_string();
        assert!(bad.contains("stage_identity") || bad.contains("unknown variant"), "{bad}");
    }

    #[test]
    fn stale_key_without_visible_change() {
        let f = Fixture::new();
        let (p, d) = f.pipeline("");
        let mut lock = f.run_all(&p);
        lock.stages.get_mut("make").unwrap().key = "old".into();
        assert_eq!(f.reasons(&p, &d, &lock, &[]), [vec![Reason::KeyChanged.to_string()], vec![UPSTREAM.into()]]);
        assert!(Path::new(&f.path("mid.txt")).exists());
    }
}
