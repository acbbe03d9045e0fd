//! One stage run's bookkeeping, shared by whole and partitioned stages: the lock records of
//! what it read and wrote, hashed around the run, and the temporary files a stage that died
//! left behind.

use std::collections::BTreeMap;

use crate::cache;
use crate::error::{Error, Result};
use crate::hash::FileHasher;
use crate::lock::FileRecord;
use crate::pipeline::Stage;

/// Each input's blake3, `None` for a file that is missing.
pub(crate) type InputHashes = BTreeMap<String, Option<String>>;

/// `stage`'s inputs hashed now (after upstream stages of this run rewrote them), and
/// their lock records (with each label's digest for an input with a `label` column).
pub(crate) fn record_inputs(
    stage: &Stage,
    hasher: &mut FileHasher,
) -> Result<(InputHashes, BTreeMap<String, FileRecord>)> {
    let inputs = cache::input_hashes(stage, hasher)?;
    let mut records = BTreeMap::new();
    for (name, path) in &stage.inputs {
        let Some(blake3) = inputs[name].clone() else {
            return Err(Error::SourceMissing {
                stage: stage.name.clone(),
                input: name.clone(),
                path: path.rel.clone(),
            });
        };
        let labels = crate::label_digest::label_digests(&path.abs).unwrap_or_default();
        records.insert(name.clone(), FileRecord { path: path.rel.clone(), blake3, labels });
    }
    Ok((inputs, records))
}

/// The lock records of `stage`'s outputs, hashed now (after it ran); an output it did not
/// write is an error.
pub(crate) fn record_outputs(stage: &Stage, hasher: &mut FileHasher) -> Result<BTreeMap<String, FileRecord>> {
    let mut outputs = BTreeMap::new();
    for (name, path) in &stage.outputs {
        hasher.forget(&path.abs);
        let Some(blake3) = hasher.hash(&path.abs)? else {
            return Err(Error::OutputNotWritten {
                stage: stage.name.clone(),
                output: name.clone(),
                path: path.rel.clone(),
            });
        };
        outputs.insert(name.clone(), FileRecord { path: path.rel.clone(), blake3, labels: BTreeMap::new() });
    }
    Ok(outputs)
}

/// Removes the temporary files (`.<name>.<pid>.tmp`) that a stage that died left beside
/// its outputs. Only one run of a pipeline runs at a time and its stages die with it, so
/// any such file is stale.
pub(crate) fn remove_stale_temps(stage: &Stage) {
    for (_, path) in &stage.outputs {
        remove_stale_temps_of(&path.abs);
    }
}

/// Removes the temporary files (`.<name>.<pid>.tmp`) a killed writer of `path` left
/// beside it. Call it only while holding the pipeline's run lock: then no live writer
/// of `path` exists.
pub(crate) fn remove_stale_temps_of(path: &std::path::Path) {
    let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else { return };
    let prefix = format!(".{}.", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let file = file.to_string_lossy();
        let stale = file
            .strip_prefix(&prefix)
            .and_then(|rest| rest.strip_suffix(".tmp"))
            .is_some_and(|pid| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()));
        if stale {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression (CI, 2026-12-03): a runner killed with SIGKILL while saving its lock
    /// left `.reprise.lock.<pid>.tmp`; the next run removes it and nothing else.
    #[test]
    fn a_killed_writers_temporary_copy_is_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let lock = dir.path().join("reprise.lock");
        let names = [
            "reprise.lock",
            ".reprise.lock.2425.tmp",
            ".reprise.lock.x1.tmp",
            ".reprise.lock..tmp",
            ".other.lock.7.tmp",
        ];
        for name in names {
            std::fs::write(dir.path().join(name), "x").unwrap();
        }
        remove_stale_temps_of(&lock);
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [".other.lock.7.tmp", ".reprise.lock..tmp", ".reprise.lock.x1.tmp", "reprise.lock"]);
    }
}
