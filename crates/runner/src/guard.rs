//! What a stage may not overwrite. A stage replaces its outputs wholesale, so an output
//! path that names a user's file destroys it. Two checks, both before any stage (or its
//! `--check`) runs:
//!
//! - [`check_declared`] (part of parsing, so `status` and `dag` see it too): no output may
//!   be the pipeline file, the lock file or the run lock, or one of its own stage's inputs.
//! - [`check_existing`] (before a run): an output that already exists must have been
//!   written by this pipeline — recorded as an output in the lock file, or a reprise
//!   Parquet artifact whose provenance names the same stage — unless the stage lists it
//!   in `allow_overwrite`. When the lock file could not be read, files inside the
//!   artifacts directory are taken as the pipeline's own (so a damaged lock costs a rerun,
//!   never a refusal). A directory in the output's place, or a file where a parent
//!   directory should be, is refused with its own message.

use std::collections::BTreeSet;
use std::path::Path;

use crate::error::{Error, Result};
use crate::lock::LockFile;
use crate::pipeline::{Pipeline, Stage};

/// The declared-path rules; see the module docs.
pub fn check_declared(pipeline: &Pipeline) -> Result<()> {
    let lock = pipeline.lock_path();
    let running = pipeline.artifacts.abs.join(".reprise.running");
    for stage in &pipeline.stages {
        for (output, path) in &stage.outputs {
            let what = if path.abs == pipeline.path {
                "the pipeline file itself"
            } else if path.abs == lock || path.abs == running {
                "the runner's own lock file"
            } else if path.abs == pipeline.artifacts.abs {
                "the artifacts directory"
            } else if stage.inputs.iter().any(|(_, input)| input.abs == path.abs) {
                "also an input of the same stage"
            } else {
                continue;
            };
            return Err(Error::OutputForbidden {
                file: pipeline.file.clone(),
                stage: stage.name.clone(),
                output: output.clone(),
                path: path.rel.clone(),
                what,
            });
        }
    }
    Ok(())
}

/// The on-disk rules for the stages about to run; see the module docs. `lock_readable`
/// is false when the lock file existed but could not be understood.
pub fn check_existing(pipeline: &Pipeline, stages: &[&Stage], lock: &LockFile, lock_readable: bool) -> Result<()> {
    let recorded: BTreeSet<&str> =
        lock.stages.values().flat_map(|entry| entry.outputs.values().map(|r| r.path.as_str())).collect();
    for stage in stages {
        for (output, path) in &stage.outputs {
            let unwritable = |why: String| Error::OutputUnwritable {
                stage: stage.name.clone(),
                output: output.clone(),
                path: path.rel.clone(),
                why,
            };
            if let Some(parent) = path.abs.ancestors().skip(1).find(|a| a.exists()) {
                if !parent.is_dir() {
                    return Err(unwritable(format!("`{}` is a file, not a directory", parent.display())));
                }
            }
            let Ok(meta) = std::fs::metadata(&path.abs) else { continue };
            if meta.is_dir() {
                return Err(unwritable("a directory is in its place".into()));
            }
            if same_file(&path.abs, &pipeline.path) {
                return Err(Error::OutputForbidden {
                    file: pipeline.file.clone(),
                    stage: stage.name.clone(),
                    output: output.clone(),
                    path: path.rel.clone(),
                    what: "the pipeline file itself (through a link)",
                });
            }
            let ours = recorded.contains(path.rel.as_str())
                || stage.allow_overwrite.contains(output)
                || artifact_of(&path.abs, &stage.name)
                || (!lock_readable && path.abs.starts_with(&pipeline.artifacts.abs));
            if !ours {
                return Err(Error::OutputNotOurs {
                    file: pipeline.file.clone(),
                    stage: stage.name.clone(),
                    output: output.clone(),
                    path: path.rel.clone(),
                    lock: pipeline.lock_path().display().to_string(),
                });
            }
        }
    }
    Ok(())
}

/// Whether `path` is a Parquet file whose `reprise.stage` metadata is `stage`.
fn artifact_of(path: &Path, stage: &str) -> bool {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let Ok(file) = std::fs::File::open(path) else { return false };
    let Ok(reader) = SerializedFileReader::new(file) else { return false };
    let metadata = reader.metadata().file_metadata().key_value_metadata().cloned().unwrap_or_default();
    metadata.iter().any(|kv| kv.key == "reprise.stage" && kv.value.as_deref() == Some(stage))
}

#[cfg(unix)]
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(dir: &Path, outputs: &str) -> Result<Pipeline> {
        let text = format!(
            "[pipeline]\nname = \"t\"\nartifacts = \"art\"\n[stage.a]\nbin = \"a\"\ninputs.src = \"src.txt\"\n{outputs}\n"
        );
        Pipeline::parse(&text, "pipeline.toml", dir)
    }

    fn err(dir: &Path, outputs: &str) -> String {
        parse(dir, outputs).unwrap_err().to_string()
    }

    fn existing(dir: &Path, outputs: &str, lock: &LockFile, readable: bool) -> Result<()> {
        let p = parse(dir, outputs)?;
        check_existing(&p, &[&p.stages[0]], lock, readable)
    }

    #[test]
    fn declared_paths_that_are_never_outputs() {
        let dir = Path::new("/p");
        assert!(err(dir, "outputs.o = \"./pipeline.toml\"")
            .contains("output `o` is `pipeline.toml`, the pipeline file itself"));
        assert!(err(dir, "outputs.o = \"art/reprise.lock\"").contains("the runner's own lock file"));
        assert!(err(dir, "outputs.o = \"src.txt\"").contains("also an input of the same stage"));
        assert!(err(dir, "outputs.o = \"art\"").contains("the artifacts directory"));
        assert!(parse(dir, "outputs.o = \"art/o.parquet\"").is_ok());
    }

    #[test]
    fn existing_files_the_pipeline_did_not_write() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        let empty = LockFile::empty("t");
        let e = existing(d, "outputs.o = \"notes.txt\"", &empty, true).unwrap_err().to_string();
        assert!(e.contains("output `o` is `notes.txt`, an existing file that no stage of this pipeline wrote"), "{e}");
        assert!(e.contains("allow_overwrite = [\"o\"]"), "{e}");
        existing(d, "outputs.o = \"notes.txt\"\nallow_overwrite = [\"o\"]", &empty, true).unwrap();
        // Recorded in the lock: the pipeline's own.
        let mut lock = LockFile::empty("t");
        let p = parse(d, "outputs.o = \"notes.txt\"").unwrap();
        let record =
            crate::lock::FileRecord { path: "notes.txt".into(), blake3: "x".into(), labels: Default::default() };
        lock.stages.insert(
            "a".into(),
            crate::lock::LockEntry {
                key: String::new(),
                bin: crate::lock::BinRecord { path: "/bin/a".into(), blake3: "x".into(), code_id: None },
                params: std::collections::BTreeMap::new(),
                inputs: std::collections::BTreeMap::new(),
                outputs: std::collections::BTreeMap::from([("o".into(), record)]),
                finished_at: String::new(),
                seconds: 0.0,
                peak_rss_mb: None,
                partitions: std::collections::BTreeMap::new(),
                job: None,
            },
        );
        check_existing(&p, &[&p.stages[0]], &lock, true).unwrap();
        // An unreadable lock: files in the artifacts directory are trusted, others not.
        std::fs::create_dir_all(d.join("art")).unwrap();
        std::fs::write(d.join("art/o.txt"), "old").unwrap();
        existing(d, "outputs.o = \"art/o.txt\"", &empty, false).unwrap();
        assert!(existing(d, "outputs.o = \"art/o.txt\"", &empty, true).is_err());
        assert!(existing(d, "outputs.o = \"notes.txt\"", &empty, false).is_err());
        assert!(parse(d, "outputs.o = \"x\"\nallow_overwrite = [\"p\"]")
            .unwrap_err()
            .to_string()
            .contains("`allow_overwrite` names `p`, which is not an output"));
    }

    #[test]
    fn directories_in_the_way() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("file"), "x").unwrap();
        std::fs::create_dir_all(d.join("adir")).unwrap();
        let empty = LockFile::empty("t");
        let e = existing(d, "outputs.o = \"file/sub/o.parquet\"", &empty, true).unwrap_err().to_string();
        assert!(e.contains("is a file, not a directory"), "{e}");
        let e = existing(d, "outputs.o = \"adir\"", &empty, true).unwrap_err().to_string();
        assert!(e.contains("a directory is in its place"), "{e}");
        existing(d, "outputs.o = \"new/dir/o.parquet\"", &empty, true).unwrap();
    }
}
