//! The Slurm executor: each batch of tasks (a stage, or the stale labels of a
//! partitioned stage) is one job array submitted with `sbatch`, polled with `squeue`.
//!
//! What it assumes: the pipeline directory, the artifacts and the stage binaries are at
//! the same absolute paths on every node (a shared filesystem), and `sbatch`, `squeue`
//! and `scancel` reach the cluster from where `reprise run` runs (`SLURM_CONF` or the
//! node's own configuration). What it checks before submitting: that `sbatch` runs, and
//! that every binary and the pipeline directory are absolute paths that exist here.
//!
//! A batch's files go to `<artifacts>/.slurm/<stage>-<pid>-<n>/`: `tasks.sh` (one `case`
//! per array index, each the stage's full command line), `<i>.log` (the task's output),
//! and `<i>.exit` (`<code> <start> <end>`, written by the script when the stage ends; a
//! task without one was cancelled, timed out or lost its node). Slurm accounting is not
//! needed. Submitted jobs are listed in `<artifacts>/.reprise.jobs` while they run, so
//! `reprise status` can show them, and a later run cancels any that a killed runner left.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::child::{stage_args, Interrupt, STATS_ENV};
use crate::error::{Error, Result};
use crate::executor::{Done, Executor, Task};
use crate::pipeline::Pipeline;

/// How often the executor looks for finished tasks.
const POLL: Duration = Duration::from_millis(250);

/// How many lines of a failed task's output the error shows.
const TAIL_LINES: usize = 30;

/// `sbatch` options given on the command line (`reprise run --slurm-…`).
#[derive(Debug, Clone, Default)]
pub struct SlurmOptions {
    /// `--partition` (Slurm's queue, not a label partition).
    pub partition: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--time` (a task's time limit, Slurm's format).
    pub time: Option<String>,
}

/// Submits to Slurm.
#[derive(Debug, Clone, Default)]
pub struct Slurm {
    /// The `sbatch` options.
    pub options: SlurmOptions,
}

/// One submitted job, as `<artifacts>/.reprise.jobs` lists it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JobRecord {
    /// The array job's id.
    pub job: String,
    /// The stage it runs.
    pub stage: String,
    /// How many tasks.
    pub tasks: usize,
    /// Its directory (scripts, logs, exit files).
    pub dir: String,
}

/// The file listing the jobs a run has in flight.
pub fn jobs_file(pipeline: &Pipeline) -> PathBuf {
    pipeline.artifacts.abs.join(".reprise.jobs")
}

/// The jobs `<artifacts>/.reprise.jobs` lists (none if it is absent or unreadable).
pub fn listed_jobs(pipeline: &Pipeline) -> Vec<JobRecord> {
    std::fs::read_to_string(jobs_file(pipeline))
        .map(|text| text.lines().filter_map(|l| serde_json::from_str(l).ok()).collect())
        .unwrap_or_default()
}

fn write_jobs(pipeline: &Pipeline, jobs: &[JobRecord]) -> Result<()> {
    let path = jobs_file(pipeline);
    if jobs.is_empty() {
        let _ = std::fs::remove_file(&path);
        return Ok(());
    }
    let text: String = jobs.iter().map(|j| serde_json::to_string(j).unwrap_or_default() + "\n").collect();
    let tmp = path.with_extension("jobs.tmp");
    std::fs::write(&tmp, text).map_err(|source| Error::Io { path: tmp.clone(), source })?;
    std::fs::rename(&tmp, &path).map_err(|source| Error::Io { path, source })
}

/// Of `jobs`, those Slurm still has pending or running, with their task states
/// (`None` when `squeue` cannot be asked).
pub fn in_flight(jobs: &[JobRecord]) -> Option<Vec<(JobRecord, String)>> {
    let mut out = Vec::new();
    for job in jobs {
        let states = squeue(&job.job).ok()?;
        if !states.is_empty() {
            out.push((job.clone(), summarise(&states)));
        }
    }
    Some(out)
}

/// Cancels the jobs a killed runner left (listed in the jobs file, still in the queue)
/// and waits until the queue holds none of them; returns what it cancelled. Where the
/// queue cannot be asked, the jobs stay listed and the run is refused.
pub fn cancel_leftovers(pipeline: &Pipeline) -> Result<Vec<JobRecord>> {
    const PATIENCE: Duration = Duration::from_secs(60);
    let listed = listed_jobs(pipeline);
    if listed.is_empty() {
        return Ok(Vec::new());
    }
    let unknown = |why: &str| Error::Slurm {
        stage: listed[0].stage.clone(),
        message: format!(
            "{} lists jobs of an earlier run, and {why}; cancel them (`scancel`) and remove the file",
            jobs_file(pipeline).display()
        ),
    };
    let live = in_flight(&listed).ok_or_else(|| unknown("`squeue` cannot be asked whether they still run"))?;
    for (job, _) in &live {
        scancel(&job.job, false);
    }
    let deadline = Instant::now() + PATIENCE;
    while !in_flight(&listed).ok_or_else(|| unknown("`squeue` failed"))?.is_empty() {
        if Instant::now() > deadline {
            return Err(unknown("they are still in the queue a minute after `scancel`"));
        }
        std::thread::sleep(POLL);
    }
    write_jobs(pipeline, &[])?;
    Ok(live.into_iter().map(|(j, _)| j).collect())
}

/// `12 running, 3 pending` from `squeue`'s task states.
fn summarise(states: &[String]) -> String {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for s in states {
        *counts.entry(s.to_lowercase()).or_default() += 1;
    }
    counts.iter().map(|(s, n)| format!("{n} {s}")).collect::<Vec<_>>().join(", ")
}

/// The states of `job`'s tasks still in the queue (empty once all ended).
fn squeue(job: &str) -> std::result::Result<Vec<String>, String> {
    let out = Command::new("squeue")
        .args(["-h", "-r", "-j", job, "-o", "%T"])
        .output()
        .map_err(|e| format!("cannot run `squeue`: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        // A job that left the queue long ago is "Invalid job id": nothing in flight.
        let err = String::from_utf8_lossy(&out.stderr);
        if err.contains("Invalid job id") {
            return Ok(Vec::new());
        }
        return Err(format!("`squeue -j {job}` failed: {}", err.trim()));
    }
    Ok(text.lines().map(|l| l.trim().to_string()).filter(|l| !l.is_empty()).collect())
}

fn scancel(job: &str, pending_only: bool) {
    let mut command = Command::new("scancel");
    if pending_only {
        command.arg("--state=PENDING");
    }
    let _ = command.arg(job).output();
}

/// `s` quoted for the shell.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The array script: task `i` runs `tasks[i]` in the pipeline directory and writes
/// `<dir>/<i>.exit` when it ends.
fn script(pipeline: &Pipeline, tasks: &[Task<'_>], dir: &Path) -> String {
    let mut s = String::from("#!/bin/bash\n");
    let _ = writeln!(s, "# Written by `reprise run --executor slurm`: {} task(s).", tasks.len());
    let _ = writeln!(s, "cd {} || exit 1", quote(&pipeline.dir.to_string_lossy()));
    let _ = writeln!(s, "export {}={}", reprise_artifact::provenance::PIPELINE_ENV, quote(&pipeline.name));
    s.push_str("start=$(date +%s.%N)\ncase \"$SLURM_ARRAY_TASK_ID\" in\n");
    for (i, task) in tasks.iter().enumerate() {
        let stats = dir.join(format!("{i}.stats.json"));
        let args: Vec<String> = stage_args(task.stage).iter().map(|a| quote(&a.to_string_lossy())).collect();
        let _ = writeln!(
            s,
            "{i}) {STATS_ENV}={} {} {} ;;",
            quote(&stats.to_string_lossy()),
            quote(&task.bin.path.to_string_lossy()),
            args.join(" ")
        );
    }
    s.push_str("*) echo \"reprise: no task $SLURM_ARRAY_TASK_ID in this array\" >&2; false ;;\nesac\n");
    s.push_str("code=$?\nend=$(date +%s.%N)\n");
    let _ = writeln!(s, "exit_file={}/\"$SLURM_ARRAY_TASK_ID\".exit", quote(&dir.to_string_lossy()));
    s.push_str("echo \"$code $start $end\" > \"$exit_file.tmp\" && mv \"$exit_file.tmp\" \"$exit_file\"\n");
    s.push_str("exit $code\n");
    s
}

/// The task's exit file: its code and seconds, once written.
fn read_exit(dir: &Path, i: usize) -> Option<(i32, f64)> {
    let text = std::fs::read_to_string(dir.join(format!("{i}.exit"))).ok()?;
    let mut parts = text.split_whitespace();
    let code = parts.next()?.parse().ok()?;
    let start: f64 = parts.next()?.parse().ok()?;
    let end: f64 = parts.next()?.parse().ok()?;
    Some((code, (end - start).max(0.0)))
}

/// The last [`TAIL_LINES`] lines of the task's output (read from its last 64 KiB).
fn tail(path: &Path) -> String {
    use std::io::{Read, Seek, SeekFrom};
    const MAX: u64 = 64 * 1024;
    let mut bytes = Vec::new();
    if let Ok(mut file) = std::fs::File::open(path) {
        let len = file.metadata().map_or(0, |m| m.len());
        let _ = file.seek(SeekFrom::Start(len.saturating_sub(MAX)));
        let _ = file.take(MAX).read_to_end(&mut bytes);
    }
    let text = String::from_utf8_lossy(&bytes);
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(TAIL_LINES)..].join("\n")
}

impl Slurm {
    /// What can be checked before submitting: `sbatch` runs, and the binaries and the
    /// pipeline directory are absolute paths that exist here.
    fn preflight(pipeline: &Pipeline, tasks: &[Task<'_>]) -> Result<()> {
        let fail = |message: String| Error::Slurm { stage: tasks[0].stage.name.clone(), message };
        let version = Command::new("sbatch").arg("--version").output();
        if !version.is_ok_and(|o| o.status.success()) {
            return Err(fail("`sbatch --version` does not run here: is Slurm installed and on PATH?".into()));
        }
        for task in tasks {
            let bin = &task.bin.path;
            if !bin.is_absolute() || !bin.is_file() {
                return Err(fail(format!("binary `{}` is not an absolute path to a file", bin.display())));
            }
        }
        if !pipeline.dir.is_absolute() {
            return Err(fail(format!("the pipeline directory `{}` is not absolute", pipeline.dir.display())));
        }
        Ok(())
    }

    /// Submits the array and returns its job id.
    fn submit(&self, name: &str, n: usize, dir: &Path, script: &Path) -> std::result::Result<String, String> {
        let mut command = Command::new("sbatch");
        command
            .arg("--parsable")
            .arg(format!("--array=0-{}", n - 1))
            .arg(format!("--job-name=reprise-{name}"))
            .arg(format!("--output={}/%a.log", dir.display().to_string().replace('\\', "\\\\").replace('%', "%%")))
            .arg("--export=ALL");
        for (flag, value) in [
            ("--partition", &self.options.partition),
            ("--account", &self.options.account),
            ("--time", &self.options.time),
        ] {
            if let Some(v) = value {
                command.arg(format!("{flag}={v}"));
            }
        }
        let out = command.arg(script).output().map_err(|e| format!("cannot run `sbatch`: {e}"))?;
        if !out.status.success() {
            return Err(format!("`sbatch` refused the job: {}", String::from_utf8_lossy(&out.stderr).trim()));
        }
        let id = String::from_utf8_lossy(&out.stdout).trim().split(';').next().unwrap_or_default().to_string();
        if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit()) {
            return Err(format!("`sbatch --parsable` printed no job id: {:?}", String::from_utf8_lossy(&out.stdout)));
        }
        Ok(id)
    }
}

impl Executor for Slurm {
    fn run(
        &self,
        pipeline: &Pipeline,
        tasks: &[Task<'_>],
        interrupt: &Interrupt,
        done: &mut dyn FnMut(usize, Result<Done>) -> Result<()>,
    ) -> Result<()> {
        if tasks.is_empty() {
            return Ok(());
        }
        Self::preflight(pipeline, tasks)?;
        // Arrays of at most MAX_ARRAY tasks (Slurm's default MaxArraySize is 1001), one
        // after the other.
        for (c, chunk) in tasks.chunks(MAX_ARRAY).enumerate() {
            let offset = c * MAX_ARRAY;
            self.run_array(pipeline, chunk, interrupt, &mut |i, result| done(offset + i, result))?;
        }
        Ok(())
    }
}

/// The most tasks in one array.
const MAX_ARRAY: usize = 1000;

/// How long the executor waits for exit files once the queue holds none of a job's tasks
/// (a shared filesystem may show a new file late).
const EXIT_FILE_GRACE: Duration = Duration::from_secs(60);

impl Slurm {
    /// Submits `tasks` as one array and waits for it.
    fn run_array(
        &self,
        pipeline: &Pipeline,
        tasks: &[Task<'_>],
        interrupt: &Interrupt,
        done: &mut dyn FnMut(usize, Result<Done>) -> Result<()>,
    ) -> Result<()> {
        // A partition's name is `stage[label]`; stage names hold no `[`.
        let stage = tasks[0].stage.name.split('[').next().unwrap_or_default().to_string();
        let fail = |message: String| Error::Slurm { stage: stage.clone(), message };
        let name = crate::paths::file_name(&stage);
        let dir = fresh_dir(&pipeline.artifacts.abs.join(".slurm"), &name)?;
        for task in tasks {
            for (_, path) in &task.stage.outputs {
                if let Some(parent) = path.abs.parent() {
                    std::fs::create_dir_all(parent)
                        .map_err(|source| Error::Io { path: parent.to_path_buf(), source })?;
                }
            }
        }
        let script_path = dir.join("tasks.sh");
        std::fs::write(&script_path, script(pipeline, tasks, &dir))
            .map_err(|source| Error::Io { path: script_path.clone(), source })?;
        let job = self.submit(&name, tasks.len(), &dir, &script_path).map_err(fail)?;
        let record =
            JobRecord { job: job.clone(), stage: stage.clone(), tasks: tasks.len(), dir: dir.display().to_string() };
        let mut listed = listed_jobs(pipeline);
        listed.push(record.clone());
        write_jobs(pipeline, &listed)?;

        let result = wait(&job, tasks, &dir, interrupt, done);
        if result.is_err() {
            scancel(&job, false);
        }
        let rest: Vec<JobRecord> = listed_jobs(pipeline).into_iter().filter(|j| *j != record).collect();
        if let Err(e) = write_jobs(pipeline, &rest) {
            return result.and(Err(e));
        }
        result
    }
}

/// A new directory `<parent>/<name>-<pid>-<n>` that no earlier run used (a container may
/// give every run the same pid).
fn fresh_dir(parent: &Path, name: &str) -> Result<PathBuf> {
    std::fs::create_dir_all(parent).map_err(|source| Error::Io { path: parent.to_path_buf(), source })?;
    loop {
        let dir = parent.join(format!("{name}-{}-{}", std::process::id(), unique()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(source) => return Err(Error::Io { path: dir, source }),
        }
    }
}

/// How task `i` of `job` ended, from its exit file: its stage's success, or the error
/// its stage's exit code means (a code above 128 is bash's report of a signal).
fn outcome(job: &str, task: &Task<'_>, dir: &Path, i: usize, code: i32, seconds: f64) -> Result<Done> {
    let id = format!("{job}_{i}");
    match code {
        0 => Ok(Done {
            seconds,
            peak_rss_mb: crate::child::read_peak(&dir.join(format!("{i}.stats.json"))),
            job: Some(id),
        }),
        129..=192 => Err(Error::StageKilled {
            stage: format!("{} (job {id})", task.stage.name),
            signal: code - 128,
            name: crate::child::signal_name(code - 128),
        }),
        _ => Err(Error::TaskFailed {
            stage: task.stage.name.clone(),
            code,
            job: id,
            output: tail(&dir.join(format!("{i}.log"))),
        }),
    }
}

/// Polls until every task of `job` ended, reporting each to `done` as its exit file
/// appears; after a failure the job's pending tasks are cancelled. Tasks still without an
/// exit file [`EXIT_FILE_GRACE`] after the queue emptied ended without running to their
/// end (cancelled, out of time, or their node failed).
fn wait(
    job: &str,
    tasks: &[Task<'_>],
    dir: &Path,
    interrupt: &Interrupt,
    done: &mut dyn FnMut(usize, Result<Done>) -> Result<()>,
) -> Result<()> {
    let mut reported = vec![false; tasks.len()];
    let mut first_error: Option<Error> = None;
    let mut squeue_failures = 0;
    let mut last_queue_check = Instant::now() - Duration::from_secs(1);
    let mut queue_empty_since: Option<Instant> = None;
    loop {
        if let Some(signal) = interrupt.received() {
            scancel(job, false);
            return Err(Error::Interrupted {
                stage: Some(format!("{} (Slurm job {job}, cancelled)", tasks[0].stage.name)),
                signal,
                name: crate::child::signal_name(signal),
            });
        }
        for (i, seen) in reported.iter_mut().enumerate() {
            if *seen {
                continue;
            }
            let Some((code, seconds)) = read_exit(dir, i) else { continue };
            *seen = true;
            let result = outcome(job, &tasks[i], dir, i, code, seconds);
            if result.is_err() {
                scancel(job, true);
            }
            if let Err(e) = done(i, result) {
                first_error.get_or_insert(e);
            }
        }
        if reported.iter().all(|&r| r) {
            return first_error.map_or(Ok(()), Err);
        }
        if let Some(since) = queue_empty_since {
            // After a failure the pending tasks were cancelled: they leave no exit file.
            if let Some(e) = first_error.take() {
                return Err(e);
            }
            if since.elapsed() >= EXIT_FILE_GRACE {
                let i = reported.iter().position(|r| !r).unwrap_or_default();
                let log = dir.join(format!("{i}.log"));
                return Err(Error::Slurm {
                    stage: tasks[i].stage.name.clone(),
                    message: format!(
                        "task {job}_{i} ended without an exit status (cancelled, out of time, or its node \
                         failed); its output ({}):\n{}",
                        log.display(),
                        tail(&log)
                    ),
                });
            }
        } else if last_queue_check.elapsed() >= Duration::from_secs(1) {
            last_queue_check = Instant::now();
            match squeue(job) {
                Ok(states) if states.is_empty() => queue_empty_since = Some(Instant::now()),
                Ok(_) => squeue_failures = 0,
                Err(message) => {
                    squeue_failures += 1;
                    if squeue_failures >= 10 {
                        return Err(Error::Slurm { stage: tasks[0].stage.name.clone(), message });
                    }
                }
            }
        }
        std::thread::sleep(POLL);
    }
}

/// A number distinct for each batch of this process.
fn unique() -> usize {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    NEXT.fetch_add(1, Ordering::SeqCst)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quoted word survives the shell, quotes and all.
    #[test]
    fn quoting_survives_the_shell() {
        for word in ["plain", "it's", "a b", "$HOME", "x'\"y", ""] {
            let out = Command::new("bash").arg("-c").arg(format!("printf %s {}", quote(word))).output().unwrap();
            assert_eq!(String::from_utf8_lossy(&out.stdout), word);
        }
    }

    /// Exit files give the code and the seconds; a missing or torn one is no answer.
    #[test]
    fn exit_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("0.exit"), "3 100.5 102.0\n").unwrap();
        std::fs::write(dir.path().join("1.exit"), "0 100.5").unwrap();
        assert_eq!(read_exit(dir.path(), 0), Some((3, 1.5)));
        assert_eq!(read_exit(dir.path(), 1), None);
        assert_eq!(read_exit(dir.path(), 2), None);
    }

    /// Task states are counted by kind.
    #[test]
    fn states_are_summarised() {
        let states: Vec<String> = ["RUNNING", "PENDING", "RUNNING"].iter().map(|s| s.to_string()).collect();
        assert_eq!(summarise(&states), "1 pending, 2 running");
    }
}
