//! Partitioned stages: a stage declared `Partition::Label { by }`
//! ([`reprise_stagekit::wiring::Partition`]) runs once per label of its input `by`, each
//! run cached on its own, and the labels' rows are merged into the stage's outputs.
//!
//! A partition is the stage binary with `--partition <label>`, reading the stage's whole
//! inputs and writing its outputs under `<artifacts>/partitions/<stage>/<label>/`. Its
//! cache key ([`crate::key::cache_key`] of `<stage>[<label>]`) holds the binary's identity,
//! the stage's parameters, the partition's output paths and, per input, the label's digest
//! ([`crate::partition::label_digests`]) for an input with a `label` column, or the whole
//! file's blake3 for one without. So when one label's frames change, only that label's
//! key changes: the other labels are cached, and merged with the new one
//! ([`reprise_artifact::partition::merge`]) into outputs equal, row for row, to what one
//! run of the stage over all labels writes.
//!
//! Stale partitions run `jobs` at a time. Each label's success is written to the lock as
//! it happens (`LockEntry::partitions`), so a failure or an interrupt keeps the labels
//! that finished; the stage's own key is recorded only once every label ran and merged.
//! This is the unit a cluster executor schedules.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Instant, SystemTime};

use reprise_artifact::partition::{self as parts, Part};
use reprise_artifact::provenance::{InputRef, Provenance};

use crate::cache::{self, ResolvedBin};
use crate::error::{Error, Result};
use crate::exec;
use crate::hash::FileHasher;
use crate::key::cache_key;
use crate::lock::{FileRecord, LockEntry, LockFile, PartitionRecord};
use crate::params::{canonical_json, ParamValue, Scalar};
use crate::paths::ArtifactPath;
use crate::pipeline::{Pipeline, Stage};
use crate::run::{invoke_measured, record_inputs, record_outputs, remove_stale_temps};

/// One partitioned stage to run.
pub(crate) struct Job<'a> {
    /// The pipeline.
    pub pipeline: &'a Pipeline,
    /// The stage.
    pub stage: &'a Stage,
    /// The input whose labels are the partitions.
    pub by: &'a str,
    /// The stage's binary.
    pub bin: &'a ResolvedBin,
    /// Rerun every label (`--force`).
    pub forced: bool,
    /// At most this many partitions at once.
    pub jobs: usize,
    /// The runner's signal watch.
    pub interrupt: &'a exec::Interrupt,
}

/// One label's run: its stage (outputs under the partition directory, `--partition` set)
/// and its key.
struct Unit {
    label: String,
    stage: Stage,
    key: String,
}

/// A file or directory name for `name` (a label, or `stage[label]`): kept when it is made
/// of letters, digits, `_`, `-`, `.`, `[` and `]` (and does not start with `.`), else those
/// characters with the rest as `_`, plus 8 hex digits of its blake3 so that two names
/// never share one.
pub(crate) fn file_name(name: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-.[]".contains(c);
    if !name.is_empty() && !name.starts_with('.') && name.chars().all(plain) {
        return name.to_string();
    }
    let kept: String = name.chars().map(|c| if plain(c) { c } else { '_' }).collect();
    format!("{}-{}", kept.trim_start_matches('.'), &blake3::hash(name.as_bytes()).to_hex()[..8])
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
    let units: Vec<Unit> = order.iter().map(|(label, _)| unit(pipeline, stage, bin, label, &input_records)).collect();

    let old = lock.stages.get(&stage.name).map(|e| e.partitions.clone()).unwrap_or_default();
    let mut stale = Vec::new();
    for (i, u) in units.iter().enumerate() {
        if job.forced || !still_valid(old.get(&u.label), &u.key, &u.stage, hasher)? {
            stale.push(i);
        }
    }
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
            .filter_map(|u| old.get(&u.label).filter(|r| r.key == u.key).map(|r| (u.label.clone(), r.clone())))
            .collect(),
    };
    lock.stages.insert(stage.name.clone(), entry.clone());
    lock.save(lock_path)?;
    say(
        log,
        &format!(
            "{:>10} {}: {} of {} labels to run{}",
            "labels",
            stage.name,
            stale.len(),
            units.len(),
            list(stale.iter().map(|&i| units[i].label.as_str()))
        ),
    );

    let peak = run_units(job, &units, &stale, hasher, lock, lock_path, &mut entry, log)?;
    merge_outputs(stage, &units, &order, &hashes)?;
    entry.outputs = record_outputs(stage, hasher)?;
    entry.key = cache::current_key(stage, bin, &hashes).unwrap_or_default();
    entry.finished_at = crate::clock::rfc3339(SystemTime::now());
    entry.seconds = started.elapsed().as_secs_f64();
    entry.peak_rss_mb = peak;
    Ok(entry)
}

/// The partition of `label`: its stage and its key.
fn unit(
    pipeline: &Pipeline,
    stage: &Stage,
    bin: &ResolvedBin,
    label: &str,
    inputs: &BTreeMap<String, FileRecord>,
) -> Unit {
    let dir = format!("{}/partitions/{}/{}", pipeline.artifacts.rel, file_name(&stage.name), file_name(label));
    let mut part = stage.clone();
    part.name = format!("{}[{label}]", stage.name);
    part.outputs = stage
        .outputs
        .iter()
        .map(|(role, path)| {
            let file = Path::new(&path.rel).file_name().map_or_else(|| role.clone(), |f| f.to_string_lossy().into());
            (role.clone(), ArtifactPath::new(&pipeline.dir, &format!("{dir}/{file}")))
        })
        .collect();
    part.params
        .push((reprise_stagekit::wiring::PARTITION_FLAG.into(), ParamValue::Scalar(Scalar::Str(label.to_string()))));
    let digests: BTreeMap<String, String> = inputs
        .iter()
        .map(|(name, record)| {
            let digest = if record.labels.is_empty() {
                format!("file:{}", record.blake3)
            } else {
                record.labels.get(label).map_or_else(|| "label:absent".into(), |d| format!("label:{d}"))
            };
            (name.clone(), digest)
        })
        .collect();
    let outputs = part.outputs.iter().map(|(name, path)| (name.as_str(), path.rel.as_str()));
    let key = cache_key(&part.name, &bin.record().identity(), &part.params, &digests, outputs);
    Unit { label: label.to_string(), stage: part, key }
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

/// Runs the units `stale` (indices into `units`), `job.jobs` at a time, recording each
/// success in `entry` and the lock as it arrives. After a failure no new unit starts; the
/// first error is returned once the running ones end. Returns the largest peak memory.
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
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let workers = job.jobs.clamp(1, stale.len().max(1));
    let plain = workers > 1;
    let (tx, rx) = mpsc::channel::<(usize, Result<(f64, Option<f64>)>)>();
    let mut first_error = None;
    let mut peak: Option<f64> = None;
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let tx = tx.clone();
            let (next, failed) = (&next, &failed);
            scope.spawn(move || loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                if k >= stale.len() || failed.load(Ordering::SeqCst) {
                    return;
                }
                let u = &units[stale[k]];
                let result = invoke_measured(job.pipeline, &u.stage, job.bin, job.interrupt, plain);
                if result.is_err() {
                    failed.store(true, Ordering::SeqCst);
                }
                if tx.send((stale[k], result)).is_err() {
                    return;
                }
            });
        }
        drop(tx);
        for (i, result) in rx {
            let u = &units[i];
            let recorded = result.and_then(|(seconds, mb)| {
                let outputs = record_outputs(&u.stage, hasher)?;
                entry.partitions.insert(u.label.clone(), PartitionRecord { key: u.key.clone(), outputs, seconds });
                lock.stages.insert(job.stage.name.clone(), entry.clone());
                lock.save(lock_path)?;
                Ok((seconds, mb))
            });
            match recorded {
                Ok((seconds, mb)) => {
                    peak = match (peak, mb) {
                        (Some(a), Some(b)) => Some(a.max(b)),
                        (a, b) => a.or(b),
                    };
                    say(log, &format!("{:>10} {} in {seconds:.2} s", "ran", u.stage.name));
                }
                Err(e) => {
                    remove_stale_temps(&u.stage);
                    failed.store(true, Ordering::SeqCst);
                    first_error.get_or_insert(e);
                }
            }
        }
    });
    first_error.map_or(Ok(peak), Err)
}

/// Merges the labels' files into each of the stage's outputs, in the order of `by`, with
/// the current segment ids and, as provenance, the current input files.
fn merge_outputs(
    stage: &Stage,
    units: &[Unit],
    order: &[(String, Vec<i64>)],
    hashes: &BTreeMap<String, Option<String>>,
) -> Result<()> {
    let fail = |message: String| Error::Partition { stage: stage.name.clone(), message };
    let segments: BTreeMap<String, Vec<i64>> = order.iter().cloned().collect();
    for (role, out) in &stage.outputs {
        let files: Vec<&ArtifactPath> = units
            .iter()
            .map(|u| u.stage.outputs.iter().find(|(r, _)| r == role).map(|(_, p)| p))
            .collect::<Option<_>>()
            .ok_or_else(|| fail(format!("a partition has no output `{role}`")))?;
        let inputs = current_inputs(files[0], hashes).map_err(fail)?;
        let list: Vec<Part<'_>> =
            units.iter().zip(&files).map(|(u, p)| Part { path: &p.abs, label: &u.label }).collect();
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

fn say(log: &mut dyn Write, line: &str) {
    let _ = writeln!(log, "{line}");
    let _ = log.flush();
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plain names stay; others keep their plain characters and gain a hash, so two
    /// labels differing only in a replaced character get two directories.
    #[test]
    fn file_names_are_safe_and_distinct() {
        assert_eq!(file_name("head_shake"), "head_shake");
        assert_eq!(file_name("gplvm[Dance-2]"), "gplvm[Dance-2]");
        let (a, b) = (file_name("walk/run"), file_name("walk run"));
        assert!(a.starts_with("walk_run-") && b.starts_with("walk_run-") && a != b, "{a} {b}");
        assert!(!file_name("..").starts_with('.') && !file_name("").is_empty());
        assert!(!file_name("a/../../b").contains('/'));
    }

    /// Labels are listed, at most eight by name.
    #[test]
    fn lists_name_at_most_eight() {
        assert_eq!(list(["a", "b"].into_iter()), " (`a`, `b`)");
        assert_eq!(list(std::iter::empty()), "");
        let many: Vec<String> = (0..10).map(|i| i.to_string()).collect();
        assert!(list(many.iter().map(String::as_str)).ends_with(", and 2 more)"));
    }
}
