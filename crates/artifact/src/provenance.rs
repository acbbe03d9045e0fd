//! Provenance: who wrote an artifact, with which parameters, from which inputs. It
//! travels in the Parquet file's key-value metadata under `reprise.*` keys, so any
//! Parquet reader (pyarrow, polars, DuckDB) can see where a table came from.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{ArtifactError, Result};

/// Metadata key: the artifact kind (e.g. `frames`).
pub const KEY_KIND: &str = "reprise.schema";
/// Metadata key: the artifact kind's schema version.
pub const KEY_SCHEMA_VERSION: &str = "reprise.schema_version";
/// Metadata key: the producing stage's name.
pub const KEY_STAGE: &str = "reprise.stage";
/// Metadata key: the producing stage's version (its crate version).
pub const KEY_STAGE_VERSION: &str = "reprise.stage_version";
/// Metadata key: the stage's parameters as canonical JSON (keys sorted).
pub const KEY_PARAMS: &str = "reprise.params";
/// Metadata key: blake3 of the canonical parameter JSON.
pub const KEY_PARAMS_HASH: &str = "reprise.params_hash";
/// Metadata key: blake3 of the table's decoded content, checked on every read.
pub const KEY_CONTENT: &str = "reprise.content_blake3_columns";
/// Metadata key: JSON object `name -> {path, blake3}` of the stage's input files.
pub const KEY_INPUTS: &str = "reprise.inputs";
/// Metadata key: the pipeline (its `[pipeline] name`) whose run wrote the artifact; absent
/// for a stage run by hand. The runner knows its own outputs by it when its lock is lost,
/// and refuses to overwrite another pipeline's.
pub const KEY_PIPELINE: &str = "reprise.pipeline";
/// Environment variable: the pipeline a stage runs for (set by the runner).
pub const PIPELINE_ENV: &str = "REPRISE_PIPELINE";

/// The marker a non-Parquet output (a report, a glTF file) carries so the runner can tell
/// whose it is: `reprise:stage=<stage>;pipeline=<name>` (`pipeline` omitted when run by
/// hand).
pub fn output_marker(stage: &str, pipeline: Option<&str>) -> String {
    match pipeline {
        Some(p) => format!("reprise:stage={stage};pipeline={p}"),
        None => format!("reprise:stage={stage}"),
    }
}

/// The pipeline this process runs for ([`PIPELINE_ENV`]), if a runner started it.
pub fn pipeline_from_env() -> Option<String> {
    std::env::var(PIPELINE_ENV).ok().filter(|p| !p.is_empty())
}

/// One input file of a stage, identified by its content.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputRef {
    /// The path as the stage was given it.
    pub path: String,
    /// blake3 of the file's bytes, hex.
    pub blake3: String,
}

/// Who produced an artifact and from what.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Stage name, e.g. `ingest`.
    pub stage: String,
    /// Stage version, e.g. `0.1.0`.
    pub stage_version: String,
    /// Parameters as a JSON object; serialised canonically (sorted keys).
    pub params: serde_json::Value,
    /// Input files by role name.
    pub inputs: BTreeMap<String, InputRef>,
    /// The pipeline whose run wrote it ([`KEY_PIPELINE`]).
    #[serde(default)]
    pub pipeline: Option<String>,
}

impl Provenance {
    /// A provenance record with no inputs yet.
    pub fn new(stage: &str, stage_version: &str, params: serde_json::Value) -> Self {
        Self {
            stage: stage.into(),
            stage_version: stage_version.into(),
            params,
            inputs: BTreeMap::new(),
            pipeline: None,
        }
    }

    /// Records an input file by hashing its content now.
    pub fn with_input(mut self, name: &str, path: &Path) -> Result<Self> {
        let hash = hash_file(path)?;
        self.inputs.insert(name.into(), InputRef { path: path.display().to_string(), blake3: hash });
        Ok(self)
    }

    /// Canonical JSON of the parameters (`serde_json` maps are sorted by key).
    pub fn params_json(&self) -> String {
        canonical_json(&self.params)
    }

    /// The `reprise.*` key-value pairs (without kind and schema version).
    pub fn to_metadata(&self) -> Vec<(String, String)> {
        let params = self.params_json();
        let mut kv = vec![
            (KEY_STAGE.into(), self.stage.clone()),
            (KEY_STAGE_VERSION.into(), self.stage_version.clone()),
            (KEY_PARAMS_HASH.into(), blake3::hash(params.as_bytes()).to_hex().to_string()),
            (KEY_PARAMS.into(), params),
            (KEY_INPUTS.into(), serde_json::to_string(&self.inputs).expect("string map serialises")),
        ];
        kv.extend(self.pipeline.iter().map(|p| (KEY_PIPELINE.to_string(), p.clone())));
        kv
    }

    /// Reads provenance back from key-value metadata.
    pub fn from_metadata(path: &Path, meta: &BTreeMap<String, String>) -> Result<Self> {
        let get = |key: &str| {
            meta.get(key).ok_or_else(|| ArtifactError::Metadata {
                path: path.into(),
                key: key.into(),
                message: "missing".into(),
            })
        };
        let bad = |key: &str, e: serde_json::Error| ArtifactError::Metadata {
            path: path.into(),
            key: key.into(),
            message: e.to_string(),
        };
        Ok(Self {
            stage: get(KEY_STAGE)?.clone(),
            stage_version: get(KEY_STAGE_VERSION)?.clone(),
            params: serde_json::from_str(get(KEY_PARAMS)?).map_err(|e| bad(KEY_PARAMS, e))?,
            inputs: serde_json::from_str(get(KEY_INPUTS)?).map_err(|e| bad(KEY_INPUTS, e))?,
            pipeline: meta.get(KEY_PIPELINE).cloned(),
        })
    }
}

/// Refuses an input artifact made from other files than the ones this stage was given:
/// for every role that both `artifact`'s provenance and `given` (this stage's own
/// provenance, inputs hashed) record, the content must be the same. E.g. `scales` made
/// from the controls of a seed-8 rig, fed to a pca given the controls of seed 7. An
/// artifact without provenance (a user's table) is not checked.
pub fn check_made_from(artifact: &Path, given: &Provenance) -> Result<()> {
    let meta = crate::table::metadata_of(artifact)?;
    if !meta.contains_key(KEY_INPUTS) {
        return Ok(());
    }
    let made = Provenance::from_metadata(artifact, &meta)?;
    for (role, used) in &made.inputs {
        let Some(now) = given.inputs.get(role) else { continue };
        if now.blake3 != used.blake3 {
            return Err(ArtifactError::Invalid {
                path: artifact.into(),
                message: format!(
                    "was made by `{}` from {role} `{}`, but this stage was given {role} `{}`, whose content differs; \
                     the inputs come from different runs — rerun `{}` on the same {role}",
                    made.stage, used.path, now.path, made.stage
                ),
            });
        }
    }
    Ok(())
}

/// Refuses two artifacts that one run of a stage must have written together (e.g. the
/// motion graph's nodes and edges, or the GPLVM's models and latents) but that come from
/// different runs: the stage, its parameters and its input files recorded in each must be
/// equal, as must every metadata key in `also`. The error names both files and the stage
/// to rerun.
pub fn check_same_run(path: &Path, other: &Path, also: &[&str]) -> Result<()> {
    let (a, b) = (crate::table::metadata_of(path)?, crate::table::metadata_of(other)?);
    let keys = [KEY_STAGE, KEY_PARAMS, KEY_INPUTS];
    if let Some(key) = keys.iter().chain(also).find(|k| a.get(**k) != b.get(**k)) {
        let stage = a.get(KEY_STAGE).map_or("the producing stage", String::as_str);
        return Err(ArtifactError::Mismatch {
            path: path.into(),
            other: other.into(),
            message: format!(
                "they were written by different runs (their `{key}` differ); rerun `{stage}` to write both"
            ),
        });
    }
    Ok(())
}

/// Serialises a JSON value with object keys sorted, so equal parameters hash equally.
pub fn canonical_json(value: &serde_json::Value) -> String {
    // serde_json's default `Map` is a BTreeMap: keys come out sorted at every level.
    serde_json::to_string(value).expect("JSON values serialise")
}

/// blake3 of a file's bytes, hex.
pub fn hash_file(path: &Path) -> Result<String> {
    let mut hasher = blake3::Hasher::new();
    let file = crate::input::open_regular(&crate::table::current_location(path))?;
    hasher.update_reader(file).map_err(|e| ArtifactError::io(path, e))?;
    Ok(hasher.finalize().to_hex().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parameter JSON is canonical: key order in the source does not change the hash.
    #[test]
    fn params_hash_ignores_key_order() {
        let a: serde_json::Value = serde_json::from_str(r#"{"b":1,"a":{"y":2,"x":3}}"#).unwrap();
        let b: serde_json::Value = serde_json::from_str(r#"{"a":{"x":3,"y":2},"b":1}"#).unwrap();
        assert_eq!(canonical_json(&a), canonical_json(&b));
        assert_eq!(canonical_json(&a), r#"{"a":{"x":3,"y":2},"b":1}"#);
    }

    #[test]
    fn metadata_round_trip() {
        let p = Provenance::new("label", "0.1.0", serde_json::json!({"min_segment_length": 12}));
        let meta: BTreeMap<_, _> = p.to_metadata().into_iter().collect();
        let back = Provenance::from_metadata(Path::new("x.parquet"), &meta).unwrap();
        assert_eq!(back, p);
        let mut broken = meta.clone();
        broken.insert(KEY_PARAMS.into(), "{not json".into());
        let err = Provenance::from_metadata(Path::new("x.parquet"), &broken).unwrap_err();
        assert!(err.to_string().contains("reprise.params"), "{err}");
    }
}
