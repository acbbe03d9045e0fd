//! What a stage may not overwrite. A stage replaces its outputs wholesale, so an output
//! path that names a user's file destroys it. Two checks, both before any stage (or its
//! `--check`) runs:
//!
//! - [`check_declared`] (part of parsing, so `status` and `dag` see it too): no output may
//!   be the pipeline file, the lock file or the run lock, or one of its own stage's inputs.
//! - [`check_existing`] (before a run): an output that already exists must have been
//!   written by this pipeline — recorded as an output in the lock file, or saying so
//!   itself ([`writer_of`]: a Parquet artifact's provenance, a report's or glTF file's
//!   marker, naming the same stage and this pipeline, or no pipeline when a stage was run
//!   by hand) — unless the stage lists it in `allow_overwrite`. Another pipeline's output
//!   is refused, naming that pipeline. So a lost or damaged lock costs a rerun, never a
//!   refusal; when the lock could not be read, files without provenance inside the
//!   artifacts directory are taken as the pipeline's own too. A directory in the output's
//!   place, or a file where a parent directory should be, is refused with its own message.

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
/// is false when the lock file existed but could not be understood; `adopt` takes
/// another pipeline's outputs as this one's (`reprise run --adopt-artifacts`).
pub fn check_existing(
    pipeline: &Pipeline,
    stages: &[&Stage],
    lock: &LockFile,
    lock_readable: bool,
    adopt: bool,
) -> Result<()> {
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
            let writer = writer_of(&path.abs);
            // A stage's files name it by its kind (`export-gltf`, from its binary
            // `reprise-export-gltf`), which the pipeline may call otherwise (`export`).
            let bin = stage.bin.declared().rsplit('/').next().unwrap_or_default();
            let kind = bin.strip_prefix("reprise-").unwrap_or(bin);
            let this_stage = |by: &str| by == stage.name || by == kind;
            let ours = recorded.contains(path.rel.as_str())
                || stage.allow_overwrite.contains(output)
                || match &writer {
                    // Written by this stage: of this pipeline, by hand (no pipeline), or of
                    // a pipeline whose directory this one adopts.
                    Some((by, p)) if this_stage(by) => p.as_deref().is_none_or(|p| p == pipeline.name) || adopt,
                    Some(_) => false,
                    None => !lock_readable && path.abs.starts_with(&pipeline.artifacts.abs),
                };
            if !ours {
                let whose = match &writer {
                    Some((by, Some(p))) if p != &pipeline.name => format!("stage `{by}` of pipeline `{p}` wrote it"),
                    Some((by, _)) if !this_stage(by) => format!("stage `{by}` wrote it"),
                    _ => format!(
                        "it is not recorded in `{}` and carries no reprise provenance",
                        pipeline.lock_path().display()
                    ),
                };
                return Err(Error::OutputNotOurs {
                    file: pipeline.file.clone(),
                    stage: stage.name.clone(),
                    output: output.clone(),
                    path: path.rel.clone(),
                    whose,
                });
            }
        }
    }
    Ok(())
}

/// The most bytes read at each end of a file looking for its [`output_marker`].
const MARKER_WINDOW: u64 = 64 << 10;

/// Who wrote `path`, as the file itself says: (stage, pipeline) from a Parquet
/// artifact's provenance, or from the [`output_marker`] a report or glTF file carries (in
/// its first or last 64 KiB, or a GLB's JSON chunk). `None`: no reprise stage did.
///
/// [`output_marker`]: reprise_artifact::provenance::output_marker
pub fn writer_of(path: &Path) -> Option<(String, Option<String>)> {
    use reprise_artifact::provenance::{KEY_PIPELINE, KEY_STAGE};
    // Only a regular file says anything (opening a FIFO would block).
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    if let Some(meta) = parquet_metadata(path) {
        let get = |key: &str| meta.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone());
        return get(KEY_STAGE).map(|stage| (stage, get(KEY_PIPELINE)));
    }
    let text = marker_text(path)?;
    let at = text.find("reprise:stage=")? + "reprise:stage=".len();
    let word =
        |s: &str| s.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-').collect::<String>();
    let stage = word(&text[at..]);
    let rest = &text[at + stage.len()..];
    let pipeline = rest.strip_prefix(";pipeline=").map(word);
    (!stage.is_empty()).then_some((stage, pipeline))
}

/// A Parquet file's key-value metadata, if `path` is one.
fn parquet_metadata(path: &Path) -> Option<Vec<(String, String)>> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let file = std::fs::File::open(path).ok()?;
    let reader = SerializedFileReader::new(file).ok()?;
    let kv = reader.metadata().file_metadata().key_value_metadata().cloned().unwrap_or_default();
    Some(kv.into_iter().filter_map(|kv| Some((kv.key, kv.value?))).collect())
}

/// Where a marker may be: the first and last [`MARKER_WINDOW`] bytes, and a GLB's JSON
/// chunk (at most 64 MiB), as text.
fn marker_text(path: &Path) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let len = file.metadata().ok().filter(std::fs::Metadata::is_file)?.len();
    let mut head = Vec::new();
    (&mut file).take(MARKER_WINDOW).read_to_end(&mut head).ok()?;
    let mut tail = Vec::new();
    if len > MARKER_WINDOW {
        file.seek(SeekFrom::Start(len - MARKER_WINDOW)).ok()?;
        (&mut file).take(MARKER_WINDOW).read_to_end(&mut tail).ok()?;
    }
    let mut json = Vec::new();
    if head.starts_with(b"glTF") && head.len() >= 20 {
        let chunk = u64::from(u32::from_le_bytes(head[12..16].try_into().ok()?)).min(64 << 20);
        file.seek(SeekFrom::Start(20)).ok()?;
        (&mut file).take(chunk).read_to_end(&mut json).ok()?;
    }
    Some([head, tail, json].iter().map(|b| String::from_utf8_lossy(b).into_owned()).collect::<Vec<_>>().join("\n"))
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
        check_existing(&p, &[&p.stages[0]], lock, readable, false)
    }

    /// A file says who wrote it: a report's marker at its end, a page's in its head, a
    /// GLB's in its JSON chunk, a Parquet artifact's provenance; a user's file says nothing.
    /// A marker of this stage and pipeline (or of no pipeline: run by hand) is this
    /// pipeline's own with no lock at all; another pipeline's is refused, naming it, unless
    /// adopted.
    #[test]
    fn outputs_are_known_by_what_they_say() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let marker = reprise_artifact::provenance::output_marker("a", Some("t"));
        let long = "x".repeat(200_000);
        std::fs::write(d.join("report.md"), format!("# t\n{long}\n<!-- {marker} -->\n")).unwrap();
        std::fs::write(d.join("page.html"), format!("<head><meta name='generator' content='{marker}'>{long}")).unwrap();
        let json = format!("{{\"accessors\":[\"{long}\"],\"asset\":{{\"extras\":{{\"reprise\":\"{marker}\"}}}}}}");
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(((20 + json.len()) as u32).to_le_bytes());
        glb.extend((json.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(json.as_bytes());
        std::fs::write(d.join("c.glb"), &glb).unwrap();
        std::fs::write(d.join("notes.txt"), "reprise is nice").unwrap();
        for f in ["report.md", "page.html", "c.glb"] {
            assert_eq!(writer_of(&d.join(f)), Some(("a".into(), Some("t".into()))), "{f}");
        }
        assert_eq!(writer_of(&d.join("notes.txt")), None);
        let by_hand = reprise_artifact::provenance::output_marker("a", None);
        std::fs::write(d.join("hand.md"), format!("<!-- {by_hand} -->")).unwrap();
        assert_eq!(writer_of(&d.join("hand.md")), Some(("a".into(), None)));

        let empty = LockFile::empty("t");
        for f in ["report.md", "page.html", "c.glb", "hand.md"] {
            existing(d, &format!("outputs.o = \"{f}\""), &empty, true).unwrap();
        }
        let other = reprise_artifact::provenance::output_marker("a", Some("u"));
        std::fs::write(d.join("theirs.md"), format!("<!-- {other} -->")).unwrap();
        let e = existing(d, "outputs.o = \"theirs.md\"", &empty, true).unwrap_err().to_string();
        assert!(e.contains("(stage `a` of pipeline `u` wrote it)"), "{e}");
        let p = parse(d, "outputs.o = \"theirs.md\"").unwrap();
        check_existing(&p, &[&p.stages[0]], &empty, true, true).unwrap();
        std::fs::write(
            d.join("b.md"),
            format!("<!-- {} -->", reprise_artifact::provenance::output_marker("b", Some("t"))),
        )
        .unwrap();
        let e = existing(d, "outputs.o = \"b.md\"", &empty, true).unwrap_err().to_string();
        assert!(e.contains("(stage `b` wrote it)"), "{e}");
        // A stage the pipeline calls `export`, of kind `export-gltf` (its binary's name).
        let marker = reprise_artifact::provenance::output_marker("export-gltf", Some("t"));
        std::fs::write(d.join("c2.glb"), format!("<!-- {marker} -->")).unwrap();
        let text = "[pipeline]\nname = \"t\"\nartifacts = \"art\"\n[stage.export]\nbin = \"reprise-export-gltf\"\n\
                    inputs.src = \"src.txt\"\noutputs.glb = \"c2.glb\"\n";
        let p = Pipeline::parse(text, "pipeline.toml", d).unwrap();
        check_existing(&p, &[&p.stages[0]], &empty, true, false).unwrap();
        // A FIFO in an output's place says nothing (and is not opened: that would block).
        #[cfg(unix)]
        {
            assert!(std::process::Command::new("mkfifo").arg(d.join("fifo")).status().unwrap().success());
            assert_eq!(writer_of(&d.join("fifo")), None);
            assert!(existing(d, "outputs.o = \"fifo\"", &empty, true).is_err());
        }
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
        check_existing(&p, &[&p.stages[0]], &lock, true, false).unwrap();
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
