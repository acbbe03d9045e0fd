//! The lock file `<artifacts>/reprise.lock`: what each stage's last *successful* run saw
//! and wrote. Pretty JSON with every map sorted, so it diffs cleanly; rewritten atomically
//! (temporary file in the same directory, then rename) after every successful stage, so a
//! later failure keeps earlier successes recorded.

use std::collections::BTreeMap;
use std::fs;
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The lock file format version this runner reads and writes.
pub const LOCK_VERSION: u32 = 1;

/// A file and the blake3 of its content.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileRecord {
    /// Path as declared in `pipeline.toml` (normalised), or the binary's resolved path.
    pub path: String,
    /// Hex blake3 of the content.
    pub blake3: String,
    /// For an input with a `label` column, each label's digest
    /// ([`crate::label_digest::label_digests`]), so `status` can say which labels changed.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub labels: BTreeMap<String, String>,
}

/// A stage binary: where it was, the blake3 of its bytes, and the code identity it
/// carried (absent in locks of runners before identities, and for binaries without one).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BinRecord {
    /// The binary's resolved path.
    pub path: String,
    /// Hex blake3 of its bytes.
    pub blake3: String,
    /// The identity it was keyed on, when keyed on its code.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub code_id: Option<String>,
}

impl BinRecord {
    /// What the cache key holds of the binary: `code:<id>`, or `bytes:<blake3>` without an
    /// identity.
    #[must_use]
    pub fn identity(&self) -> String {
        match &self.code_id {
            Some(id) => format!("code:{id}"),
            None => format!("bytes:{}", self.blake3),
        }
    }
}

/// One stage's last successful run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LockEntry {
    /// The cache key (see `crate::key`).
    pub key: String,
    /// The stage binary.
    pub bin: BinRecord,
    /// Canonical JSON of the parameters (keys sorted).
    pub params: BTreeMap<String, serde_json::Value>,
    /// Each input by name.
    pub inputs: BTreeMap<String, FileRecord>,
    /// Each output by name, hashed after the stage exited.
    pub outputs: BTreeMap<String, FileRecord>,
    /// When the stage finished, RFC 3339 UTC.
    pub finished_at: String,
    /// Wall-clock seconds the stage took.
    pub seconds: f64,
    /// The stage's peak resident memory (MB), when it reported it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_rss_mb: Option<f64>,
    /// For a stage run one label at a time (`crate::partitioned`), each label's last
    /// successful run. Recorded as each label finishes, so a failed or interrupted stage
    /// keeps the labels that succeeded (its `key` is then empty: the stage is not fresh).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub partitions: BTreeMap<String, PartitionRecord>,
    /// The scheduler's job that ran the stage (Slurm: `<array job>_<task>`), if not run
    /// locally; a partitioned stage's jobs are its labels'.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job: Option<String>,
}

/// One label's run of a partitioned stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartitionRecord {
    /// The partition's cache key (`crate::partitioned`).
    pub key: String,
    /// Each output of the partition run, hashed after it exited.
    pub outputs: BTreeMap<String, FileRecord>,
    /// Wall-clock seconds it took.
    pub seconds: f64,
    /// The scheduler's job that ran it (Slurm: `<array job>_<task>`), if not run locally.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job: Option<String>,
}

/// The whole lock file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LockFile {
    /// [`LOCK_VERSION`].
    pub version: u32,
    /// `[pipeline] name`.
    pub pipeline: String,
    /// Entries by stage name.
    pub stages: BTreeMap<String, LockEntry>,
}

impl LockFile {
    /// An empty lock for pipeline `name`.
    #[must_use]
    pub fn empty(name: &str) -> Self {
        Self { version: LOCK_VERSION, pipeline: name.into(), stages: BTreeMap::new() }
    }

    /// Reads the lock at `path`. A missing file is an empty lock. A lock that cannot be
    /// read or understood is also treated as empty (everything reruns), with a warning for
    /// the caller to print: it only ever costs time.
    #[must_use]
    pub fn load(path: &Path, name: &str) -> (Self, Option<String>) {
        let text = match fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (Self::empty(name), None),
            Err(e) => {
                return (
                    Self::empty(name),
                    Some(format!("cannot read `{}` ({e}); treating every stage as never run", path.display())),
                )
            }
        };
        match serde_json::from_str::<Self>(&text) {
            Ok(lock) if lock.version == LOCK_VERSION => (lock, None),
            Ok(lock) => (
                Self::empty(name),
                Some(format!(
                    "`{}` has lock format version {} (this runner knows {LOCK_VERSION}); treating every stage as never run",
                    path.display(),
                    lock.version
                )),
            ),
            Err(e) => (
                Self::empty(name),
                Some(format!("`{}` is not a valid lock file ({e}); treating every stage as never run", path.display())),
            ),
        }
    }

    /// Writes the lock to `path` atomically, creating its directory if needed.
    pub fn save(&self, path: &Path) -> Result<()> {
        let fail = |source| Error::LockWrite { path: path.to_path_buf(), source };
        let dir = path.parent().unwrap_or(Path::new("."));
        fs::create_dir_all(dir).map_err(fail)?;
        let mut text = serde_json::to_string_pretty(self).map_err(|e| fail(e.into()))?;
        text.push('\n');
        let file_name = path.file_name().map_or_else(|| "reprise.lock".into(), |n| n.to_string_lossy().into_owned());
        let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
        let write = || -> std::io::Result<()> {
            let mut file = fs::File::create(&tmp)?;
            file.write_all(text.as_bytes())?;
            file.sync_all()?;
            fs::rename(&tmp, path)
        };
        write().map_err(|e| {
            let _ = fs::remove_file(&tmp);
            fail(e)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(key: &str) -> LockEntry {
        LockEntry {
            key: key.into(),
            bin: BinRecord { path: "/bin/x".into(), blake3: "ab".into(), code_id: Some("ef".into()) },
            params: BTreeMap::from([("z".into(), serde_json::json!(1)), ("a".into(), serde_json::json!(["x"]))]),
            inputs: BTreeMap::new(),
            outputs: BTreeMap::from([(
                "o".into(),
                FileRecord { path: "out/o".into(), blake3: "cd".into(), labels: BTreeMap::new() },
            )]),
            finished_at: "2025-01-02T03:04:05Z".into(),
            seconds: 0.5,
            peak_rss_mb: Some(12.5),
            partitions: BTreeMap::new(),
            job: None,
        }
    }

    /// A lock written before code identities (no `code_id`) still reads.
    #[test]
    fn a_lock_without_code_identities_reads() {
        let mut e = serde_json::to_value(entry("k")).unwrap();
        e["bin"].as_object_mut().unwrap().remove("code_id");
        let back: LockEntry = serde_json::from_value(e).unwrap();
        assert_eq!(back.bin.code_id, None);
        assert_eq!(back.bin.identity(), "bytes:ab");
        assert_eq!(entry("k").bin.identity(), "code:ef");
    }

    #[test]
    fn round_trips_with_sorted_keys() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("new/dir/reprise.lock");
        let mut lock = LockFile::empty("p");
        lock.stages.insert("b".into(), entry("k2"));
        lock.stages.insert("a".into(), entry("k1"));
        lock.save(&path).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.find("\"a\": {").unwrap() < text.find("\"b\": {").unwrap());
        assert!(text.find("\"a\": [").unwrap() < text.find("\"z\": 1").unwrap());
        assert_eq!(LockFile::load(&path, "p"), (lock, None));
        let leftovers: Vec<_> = fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(leftovers.len(), 1, "no temporary file is left behind");
    }

    #[test]
    fn missing_is_empty_and_garbage_is_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("reprise.lock");
        assert_eq!(LockFile::load(&path, "p"), (LockFile::empty("p"), None));
        fs::write(&path, "{ not json").unwrap();
        let (lock, warning) = LockFile::load(&path, "p");
        assert!(lock.stages.is_empty());
        assert!(warning.unwrap().contains("is not a valid lock file"));
    }
}
