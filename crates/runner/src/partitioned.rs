//! Partitioned stages: a stage declared `Partition::Label { by }`
//! ([`reprise_stagekit::wiring::Partition`]) runs once per label of its input `by`, each
//! run cached on its own, and the labels' rows are merged into the stage's outputs.
//!
//! A partition is the stage binary with `--partition <label>` (a pair adds
//! `--partition-to <to>`), reading the stage's whole inputs and writing its outputs under
//! `<artifacts>/partitions/<stage>/<label>/` (a pair's under `…/<from>/<to>/`). Its
//! cache key ([`crate::key::cache_key`] of `<stage>[<label>]`) holds the binary's identity,
//! the stage's parameters, the partition's output paths and, per input, the label's digest
//! ([`crate::label_digest::label_digests`]) for an input with a `label` column, or the whole
//! file's blake3 for one without (a pair: both labels' digests). So when one label's frames
//! change, only that label's keys change (for pairs, the 2·(L−1) pairs holding it): the
//! others are cached, and merged with the new ones
//! ([`reprise_artifact::partition::merge`]) into outputs equal, row for row, to what one
//! run of the stage over all labels writes.
//!
//! Stale partitions run on the run's executor (`--jobs` at a time locally, one Slurm
//! array for all of them). Each label's success is written to the lock as
//! it happens (`LockEntry::partitions`), so a failure or an interrupt keeps the labels
//! that finished; the stage's own key is recorded only once every label ran and merged.
//! This is the unit a cluster executor schedules.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::time::{Instant, SystemTime};

use reprise_artifact::partition::{self as parts, Part};
use reprise_artifact::provenance::{InputRef, Provenance};

use crate::cache::{self, ResolvedBin};
use crate::child;
use crate::error::{Error, Result};
use crate::executor::{Executor, Task};
use crate::hash::FileHasher;
use crate::key::cache_key;
use crate::lock::{FileRecord, LockEntry, LockFile, PartitionRecord};
use crate::params::{canonical_json, ParamValue, Scalar};
use crate::paths::{file_name, ArtifactPath};
use crate::pipeline::{Pipeline, Stage};
use crate::record::{record_inputs, record_outputs, remove_stale_temps};
use crate::say;

/// One partitioned stage to run.
pub(crate) struct Job<'a> {
    /// The pipeline.
    pub pipeline: &'a Pipeline,
    /// The stage.
    pub stage: &'a Stage,
    /// The input whose labels are the partitions.
    pub by: &'a str,
    /// One partition per ordered pair of labels, not per label.
    pub pairs: bool,
    /// The stage's binary.
    pub bin: &'a ResolvedBin,
    /// Rerun every label (`--force`).
    pub forced: bool,
    /// Where the labels run.
    pub executor: &'a dyn Executor,
    /// The runner's signal watch.
    pub interrupt: &'a child::Interrupt,
}

/// One partition's run: its stage (outputs under the partition directory, `--partition`
/// set) and its key.
struct Unit {
    /// Its name in the lock and the log: the label, or `from → to`.
    name: String,
    /// Its label, or a pair's first.
    label: String,
    /// A pair's second label.
    to: Option<String>,
    stage: Stage,
    key: String,
}

/// Runs the stale partitions of `job`, merges every label into the stage's outputs, and
/// returns the stage's lock entry. `lock` is updated (and saved to `lock_path`) as each
/// label finishes.
pub(crate) fn run(
    job: &Job<'_>,
    hasher: &mut FileHasher,
    lock: &mut LockFile,
    lock_path: &Path,
    log: &mut dyn Write,
) -> Result<LockEntry> {
    let Job { pipeline, stage, by, bin, .. } = *job;
    let started = Instant::now();
    let (hashes, input_records) = record_inputs(stage, hasher)?;
    let by_path = &stage
        .inputs
        .iter()
        .find(|(name, _)| name == by)
        .ok_or_else(|| Error::Partition {
            stage: stage.name.clone(),
            message: format!("it is run one label at a time by its input `{by}`, which it is not given"),
        })?
        .1;
    let order = parts::labels_in_order(&by_path.abs)
        .map_err(|e| Error::Partition { stage: stage.name.clone(), message: e.to_string() })?;
    let labels: Vec<&str> = order.iter().map(|l| l.label.as_str()).collect();
    let which: Vec<(&str, Option<&str>)> = if job.pairs {
        labels.iter().flat_map(|&a| labels.iter().filter(move |&&b| b != a).map(move |&b| (a, Some(b)))).collect()
    } else {
        labels.iter().map(|&a| (a, None)).collect()
    };
    let units: Vec<Unit> = which.into_iter().map(|(a, b)| unit(pipeline, stage, bin, a, b, &input_records)).collect();

    let old = lock.stages.get(&stage.name).map(|e| e.partitions.clone()).unwrap_or_default();
    let mut stale = Vec::new();
    for (i, u) in units.iter().enumerate() {
        if job.forced || !still_valid(old.get(&u.name), &u.key, &u.stage, hasher)? {
            stale.push(i);
        }
    }
    // Longest first, so that the last to finish is not a long one started late: by the
    // seconds it took last time, else by its (first) label's rows.
    let rows: BTreeMap<&str, usize> = order.iter().map(|l| (l.label.as_str(), l.rows)).collect();
    let cost = |u: &Unit| (old.get(&u.name).map_or(0.0, |r| r.seconds), rows.get(u.label.as_str()).copied());
    stale.sort_by(|&a, &b| {
        let ((sa, ra), (sb, rb)) = (cost(&units[a]), cost(&units[b]));
        sb.total_cmp(&sa).then(rb.cmp(&ra)).then(a.cmp(&b))
    });
    // Until every label has run and merged, the stage is not fresh: its key stays empty,
    // and the labels still valid are kept.
    let mut entry = LockEntry {
        key: String::new(),
        bin: bin.record(),
        params: canonical_json(&stage.params),
        inputs: input_records,
        outputs: BTreeMap::new(),
        finished_at: crate::clock::rfc3339(SystemTime::now()),
        seconds: 0.0,
        peak_rss_mb: None,
        partitions: units
            .iter()
            .filter_map(|u| old.get(&u.name).filter(|r| r.key == u.key).map(|r| (u.name.clone(), r.clone())))
            .collect(),
        job: None,
    };
    lock.stages.insert(stage.name.clone(), entry.clone());
    lock.save(lock_path)?;
    say(
        log,
        &format!(
            "{:>10} {}: {} of {} {} to run{}",
            "labels",
            stage.name,
            stale.len(),
            units.len(),
            if job.pairs { "label pairs" } else { "labels" },
            list(stale.iter().map(|&i| units[i].name.as_str()))
        ),
    );

    let peak = run_units(job, &units, &stale, hasher, lock, lock_path, &mut entry, log)?;
    merge_outputs(stage, &units, &order, &hashes)?;
    let stage_dir = pipeline.artifacts.abs.join("partitions").join(file_name(&stage.name));
    let keep: Vec<(String, Option<String>)> =
        units.iter().map(|u| (file_name(&u.label), u.to.as_deref().map(file_name))).collect();
    match prune(&stage_dir, &keep) {
        Ok(gone) if !gone.is_empty() => {
            say(
                log,
                &format!("{:>10} {}: removed the partitions of labels gone: {}", "labels", stage.name, gone.join(", ")),
            );
        }
        Ok(_) => {}
        Err(e) => say(log, &format!("{:>10} {}: could not remove old partitions: {e}", "labels", stage.name)),
    }
    entry.outputs = record_outputs(stage, hasher)?;
    entry.key = cache::current_key(stage, bin, &hashes).unwrap_or_default();
    entry.finished_at = crate::clock::rfc3339(SystemTime::now());
    entry.seconds = started.elapsed().as_secs_f64();
    entry.peak_rss_mb = peak;
    Ok(entry)
}

/// The partition of `label` (or of the pair `label → to`): its stage and its key.
fn unit(
    pipeline: &Pipeline,
    stage: &Stage,
    bin: &ResolvedBin,
    label: &str,
    to: Option<&str>,
    inputs: &BTreeMap<String, FileRecord>,
) -> Unit {
    let name = unit_name(label, to);
    let mut dir = format!("{}/partitions/{}/{}", pipeline.artifacts.rel, file_name(&stage.name), file_name(label));
    if let Some(to) = to {
        dir = format!("{dir}/{}", file_name(to));
    }
    let mut part = stage.clone();
    part.name = format!("{}[{name}]", stage.name);
    part.outputs = partition_files(&stage.outputs)
        .into_iter()
        .map(|(role, file)| (role, ArtifactPath::new(&pipeline.dir, &format!("{dir}/{file}"))))
        .collect();
    part.params
        .push((reprise_stagekit::wiring::PARTITION_FLAG.into(), ParamValue::Scalar(Scalar::Str(label.to_string()))));
    if let Some(to) = to {
        let value = ParamValue::Scalar(Scalar::Str(to.to_string()));
        part.params.push((reprise_stagekit::wiring::PARTITION_TO_FLAG.into(), value));
    }
    let digests: BTreeMap<String, String> = inputs
        .iter()
        .map(|(name, record)| {
            let digest = if record.labels.is_empty() {
                format!("file:{}", record.blake3)
            } else {
                let digest = |l: &str| record.labels.get(l).map_or("absent", String::as_str).to_string();
                match to {
                    None => format!("label:{}", digest(label)),
                    Some(to) => format!("pair:{}:{}", digest(label), digest(to)),
                }
            };
            (name.clone(), digest)
        })
        .collect();
    let outputs = part.outputs.iter().map(|(name, path)| (name.as_str(), path.rel.as_str()));
    let key = cache_key(&part.name, &bin.record().identity(), &part.params, &digests, outputs);
    Unit { name, label: label.to_string(), to: to.map(str::to_string), stage: part, key }
}

/// Removes the partition directories under `stage_dir` (`<artifacts>/partitions/<stage>`)
/// of labels (or pairs) no longer in `keep` (directory names: `(label, to)`), so that a
/// renamed or removed label leaves nothing behind; returns what it removed. Only
/// directories are touched.
fn prune(stage_dir: &Path, keep: &[(String, Option<String>)]) -> std::io::Result<Vec<String>> {
    let mut gone = Vec::new();
    let dirs = |dir: &Path| -> std::io::Result<Vec<String>> {
        let mut names = Vec::new();
        for entry in std::fs::read_dir(dir)? {
            let entry = entry?;
            if entry.file_type()?.is_dir() {
                names.push(entry.file_name().to_string_lossy().into_owned());
            }
        }
        names.sort();
        Ok(names)
    };
    if !stage_dir.is_dir() {
        return Ok(gone);
    }
    for label in dirs(stage_dir)? {
        let mine: Vec<&Option<String>> = keep.iter().filter(|(l, _)| *l == label).map(|(_, to)| to).collect();
        if mine.is_empty() {
            std::fs::remove_dir_all(stage_dir.join(&label))?;
            gone.push(label);
            continue;
        }
        if mine.iter().all(|to| to.is_none()) {
            continue;
        }
        for to in dirs(&stage_dir.join(&label))? {
            if !mine.iter().any(|t| t.as_deref() == Some(to.as_str())) {
                std::fs::remove_dir_all(stage_dir.join(&label).join(&to))?;
                gone.push(format!("{label} → {to}"));
            }
        }
    }
    Ok(gone)
}

/// A partition's name in the lock and the log: the label, or `from → to` for a pair. A
/// label that itself contains the arrow is quoted, so that no two pairs share a name.
fn unit_name(label: &str, to: Option<&str>) -> String {
    let Some(to) = to else { return label.to_string() };
    if label.contains('→') || to.contains('→') {
        format!("{label:?} → {to:?}")
    } else {
        format!("{label} → {to}")
    }
}

/// The file name of each output (by role) inside a partition's directory: the stage
/// output's own file name, or, if two outputs share one (`a/x.parquet` and
/// `b/x.parquet`), `role.name` for every output, so that no partition output overwrites
/// another (roles are distinct).
fn partition_files(outputs: &[(String, ArtifactPath)]) -> Vec<(String, String)> {
    let named: Vec<(String, String)> = outputs
        .iter()
        .map(|(role, path)| {
            let file = Path::new(&path.rel).file_name().map_or_else(|| role.clone(), |f| f.to_string_lossy().into());
            (role.clone(), file)
        })
        .collect();
    let distinct: std::collections::BTreeSet<&str> = named.iter().map(|(_, f)| f.as_str()).collect();
    if distinct.len() == named.len() {
        return named;
    }
    named
        .into_iter()
        .map(|(role, file)| {
            let prefixed = format!("{role}.{file}");
            (role, prefixed)
        })
        .collect()
}

/// Whether a label's recorded run has this key and its outputs are still as written.
fn still_valid(record: Option<&PartitionRecord>, key: &str, part: &Stage, hasher: &mut FileHasher) -> Result<bool> {
    let Some(record) = record.filter(|r| r.key == key) else { return Ok(false) };
    for (name, path) in &part.outputs {
        let Some(recorded) = record.outputs.get(name) else { return Ok(false) };
        if hasher.hash(&path.abs)?.as_deref() != Some(recorded.blake3.as_str()) {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Runs the units `stale` (indices into `units`) on the job's executor, recording each
/// success in `entry` and the lock as it arrives. Returns the largest peak memory and the
/// jobs that ran them (for a scheduler).
#[allow(clippy::too_many_arguments)]
fn run_units(
    job: &Job<'_>,
    units: &[Unit],
    stale: &[usize],
    hasher: &mut FileHasher,
    lock: &mut LockFile,
    lock_path: &Path,
    entry: &mut LockEntry,
    log: &mut dyn Write,
) -> Result<Option<f64>> {
    for &i in stale {
        remove_stale_temps(&units[i].stage);
    }
    let tasks: Vec<Task<'_>> = stale.iter().map(|&i| Task { stage: &units[i].stage, bin: job.bin }).collect();
    let mut peak: Option<f64> = None;
    let result = job.executor.run(job.pipeline, &tasks, job.interrupt, &mut |k, result| {
        let u = &units[stale[k]];
        let recorded = result.and_then(|done| {
            let outputs = record_outputs(&u.stage, hasher)?;
            let record = PartitionRecord { key: u.key.clone(), outputs, seconds: done.seconds, job: done.job.clone() };
            entry.partitions.insert(u.name.clone(), record);
            lock.stages.insert(job.stage.name.clone(), entry.clone());
            lock.save(lock_path)?;
            Ok(done)
        });
        match recorded {
            Ok(done) => {
                peak = match (peak, done.peak_rss_mb) {
                    (Some(a), Some(b)) => Some(a.max(b)),
                    (a, b) => a.or(b),
                };
                let at = done.job.map(|j| format!(" (Slurm {j})")).unwrap_or_default();
                say(log, &format!("{:>10} {} in {:.2} s{at}", "ran", u.stage.name, done.seconds));
                Ok(())
            }
            Err(e) => {
                remove_stale_temps(&u.stage);
                Err(e)
            }
        }
    });
    result.map(|()| peak)
}

/// Merges the labels' files into each of the stage's outputs, in the order of `by`, with
/// the current segment ids and, as provenance, the current input files.
fn merge_outputs(
    stage: &Stage,
    units: &[Unit],
    order: &[parts::LabelRows],
    hashes: &BTreeMap<String, Option<String>>,
) -> Result<()> {
    let fail = |message: String| Error::Partition { stage: stage.name.clone(), message };
    let segments: BTreeMap<String, Vec<i64>> = order.iter().map(|l| (l.label.clone(), l.segments.clone())).collect();
    for (role, out) in &stage.outputs {
        let files: Vec<&ArtifactPath> = units
            .iter()
            .map(|u| u.stage.outputs.iter().find(|(r, _)| r == role).map(|(_, p)| p))
            .collect::<Option<_>>()
            .ok_or_else(|| fail(format!("a partition has no output `{role}`")))?;
        let inputs = current_inputs(files[0], hashes).map_err(fail)?;
        let list: Vec<Part<'_>> = units
            .iter()
            .zip(&files)
            .map(|(u, p)| Part { path: &p.abs, label: &u.label, to: u.to.as_deref() })
            .collect();
        parts::merge(&list, &out.abs, &inputs, &segments).map_err(|e| fail(e.to_string()))?;
    }
    Ok(())
}

/// The input record a partition's file carries, with each input's current content hash
/// (its other labels may have changed since the partition ran).
fn current_inputs(
    part: &ArtifactPath,
    hashes: &BTreeMap<String, Option<String>>,
) -> std::result::Result<BTreeMap<String, InputRef>, String> {
    let meta = reprise_artifact::table::metadata_of(&part.abs).map_err(|e| e.to_string())?;
    let mut inputs = Provenance::from_metadata(&part.abs, &meta).map_err(|e| e.to_string())?.inputs;
    for (role, input) in &mut inputs {
        input.blake3 = hashes
            .get(role)
            .cloned()
            .flatten()
            .ok_or_else(|| format!("{}: records input `{role}`, which the stage is not given", part.rel))?;
    }
    Ok(inputs)
}

/// ` (a, b, c)`, or nothing for no labels; at most 8 named.
fn list<'a>(labels: impl Iterator<Item = &'a str>) -> String {
    let labels: Vec<&str> = labels.collect();
    if labels.is_empty() {
        return String::new();
    }
    let shown: Vec<String> = labels.iter().take(8).map(|l| format!("`{l}`")).collect();
    let more = if labels.len() > 8 { format!(", and {} more", labels.len() - 8) } else { String::new() };
    format!(" ({}{more})", shown.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pair names are unambiguous even for labels containing the arrow.
    #[test]
    fn pair_names_are_distinct() {
        assert_eq!(unit_name("a", None), "a");
        assert_eq!(unit_name("a", Some("b")), "a → b");
        let (one, two) = (unit_name("a → b", Some("c")), unit_name("a", Some("b → c")));
        assert_ne!(one, two);
        assert_eq!(one, "\"a → b\" → \"c\"");
    }

    /// Outputs keep their file names unless two share one; then every one is prefixed by
    /// its role and all are distinct.
    #[test]
    fn partition_files_never_collide() {
        let out = |role: &str, rel: &str| (role.to_string(), ArtifactPath::new(Path::new("/p"), rel));
        let plain = [out("latents", "artifacts/latents.parquet"), out("models", "artifacts/models.parquet")];
        let files: Vec<String> = partition_files(&plain).into_iter().map(|(_, f)| f).collect();
        assert_eq!(files, ["latents.parquet", "models.parquet"]);
        let clash = [out("latents", "a/x.parquet"), out("models", "b/x.parquet"), out("trace", "c/t.parquet")];
        let files: Vec<(String, String)> = partition_files(&clash);
        assert_eq!(
            files.iter().map(|(_, f)| f.as_str()).collect::<Vec<_>>(),
            ["latents.x.parquet", "models.x.parquet", "trace.t.parquet"]
        );
        assert_eq!(files[1].0, "models");
    }

    /// Labels are listed, at most eight by name.
    #[test]
    fn lists_name_at_most_eight() {
        assert_eq!(list(["a", "b"].into_iter()), " (`a`, `b`)");
        assert_eq!(list(std::iter::empty()), "");
        let many: Vec<String> = (0..10).map(|i| i.to_string()).collect();
        assert!(list(many.iter().map(String::as_str)).ends_with(", and 2 more)"));
    }

    /// Directories of labels and pairs no longer present go; current ones, and files,
    /// stay.
    #[test]
    fn prune_removes_only_gone_partitions() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        for d in ["a", "old", "p/q", "p/gone", "p/r"] {
            std::fs::create_dir_all(dir.join(d)).unwrap();
        }
        std::fs::write(dir.join("note.txt"), "").unwrap();
        let keep = [
            ("a".to_string(), None),
            ("p".to_string(), Some("q".to_string())),
            ("p".to_string(), Some("r".to_string())),
        ];
        let gone = super::prune(dir, &keep).unwrap();
        assert_eq!(gone, ["old", "p → gone"]);
        assert!(dir.join("a").is_dir() && dir.join("p/q").is_dir() && dir.join("p/r").is_dir());
        assert!(!dir.join("old").exists() && !dir.join("p/gone").exists() && dir.join("note.txt").exists());
        assert_eq!(super::prune(&dir.join("missing"), &keep).unwrap(), Vec::<String>::new());
    }
}
