//! Where stage processes run: [`Local`] child processes (the default) or [`Slurm`] job
//! arrays.
//!
//! The runner decides what runs (the cache), hashes inputs and outputs, merges a
//! partitioned stage's labels and writes the lock; an executor only runs a batch of
//! processes — a whole stage, or the stale labels of a partitioned one — and reports each
//! one's end. So a stage is keyed, cached, merged and recorded the same way whichever
//! executor ran it, and another farm scheduler (Deadline, OpenCue, Tractor) is one more
//! implementation of [`Executor`]: submit a batch of command lines, say when each ended
//! and with what exit code, cancel on request.

use std::path::Path;
use std::time::Instant;

use crate::cache::ResolvedBin;
use crate::child::{self, Interrupt, Outcome};
use crate::error::{Error, Result};
use crate::pipeline::{Pipeline, Stage};

pub use crate::slurm::{Slurm, SlurmOptions};

/// One process to run: a stage (or one label of it) and its binary.
#[derive(Clone, Copy)]
pub struct Task<'a> {
    /// The stage, with the flags it is run with (a partition's outputs and `--partition`).
    pub stage: &'a Stage,
    /// Its binary.
    pub bin: &'a ResolvedBin,
}

/// How a task ended well.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Done {
    /// Wall-clock seconds it ran.
    pub seconds: f64,
    /// The peak resident memory (MB) it reported.
    pub peak_rss_mb: Option<f64>,
    /// The scheduler's id of the job that ran it (`<job>_<task>` for Slurm).
    pub job: Option<String>,
}

/// Runs batches of stage processes.
pub trait Executor {
    /// Runs `tasks` and calls `done(i, result)` on the runner's thread as task `i` ends.
    /// After a failure (or an error from `done`) no new task starts; the tasks already
    /// running end, and the first error is returned.
    fn run(
        &self,
        pipeline: &Pipeline,
        tasks: &[Task<'_>],
        interrupt: &Interrupt,
        done: &mut dyn FnMut(usize, Result<Done>) -> Result<()>,
    ) -> Result<()>;
}

/// Child processes of the runner, at most `jobs` at once.
pub struct Local {
    /// At most this many tasks at once (at least 1).
    pub jobs: usize,
}

impl Executor for Local {
    fn run(
        &self,
        pipeline: &Pipeline,
        tasks: &[Task<'_>],
        interrupt: &Interrupt,
        done: &mut dyn FnMut(usize, Result<Done>) -> Result<()>,
    ) -> Result<()> {
        use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
        let next = AtomicUsize::new(0);
        let failed = AtomicBool::new(false);
        let workers = self.jobs.clamp(1, tasks.len().max(1));
        let plain = workers > 1;
        let (tx, rx) = std::sync::mpsc::channel::<(usize, Result<Done>)>();
        let mut first_error = None;
        std::thread::scope(|scope| {
            for _ in 0..workers {
                let tx = tx.clone();
                let (next, failed) = (&next, &failed);
                scope.spawn(move || loop {
                    let k = next.fetch_add(1, Ordering::SeqCst);
                    if k >= tasks.len() || failed.load(Ordering::SeqCst) {
                        return;
                    }
                    let Task { stage, bin } = tasks[k];
                    let started = Instant::now();
                    let result = invoke_measured(pipeline, stage, &bin.path, interrupt, plain).map(|peak| Done {
                        seconds: started.elapsed().as_secs_f64(),
                        peak_rss_mb: peak,
                        job: None,
                    });
                    if result.is_err() {
                        failed.store(true, Ordering::SeqCst);
                    }
                    if tx.send((k, result)).is_err() {
                        return;
                    }
                });
            }
            drop(tx);
            for (k, result) in rx {
                if let Err(e) = done(k, result) {
                    failed.store(true, Ordering::SeqCst);
                    first_error.get_or_insert(e);
                }
            }
        });
        first_error.map_or(Ok(()), Err)
    }
}

/// Runs `stage` once as a child process (its outputs' directories created first) and
/// returns the peak memory (MB) it reported; a failure is an error naming the stage.
/// `plain_progress` asks it for plain progress lines (several stages run at once).
pub(crate) fn invoke_measured(
    pipeline: &Pipeline,
    stage: &Stage,
    bin: &Path,
    interrupt: &child::Interrupt,
    plain_progress: bool,
) -> Result<Option<f64>> {
    for (_, path) in &stage.outputs {
        if let Some(parent) = path.abs.parent() {
            std::fs::create_dir_all(parent).map_err(|source| Error::Io { path: parent.to_path_buf(), source })?;
        }
    }
    let stats = pipeline.artifacts.abs.join(format!(".{}.stats.json", crate::paths::file_name(&stage.name)));
    let _ = std::fs::create_dir_all(&pipeline.artifacts.abs);
    let _ = std::fs::remove_file(&stats);
    let call = child::Call { stats: Some(&stats), plain_progress, pipeline: &pipeline.name, ..Default::default() };
    let outcome = child::invoke(stage, bin, &pipeline.dir, call, interrupt)?;
    let peak_rss_mb = child::read_peak(&stats);
    let _ = std::fs::remove_file(&stats);
    match outcome {
        Outcome::Success => Ok(peak_rss_mb),
        Outcome::Failed(code) => Err(Error::StageFailed { stage: stage.name.clone(), code }),
        Outcome::Killed(signal) => {
            Err(Error::StageKilled { stage: stage.name.clone(), signal, name: child::signal_name(signal) })
        }
        Outcome::Interrupted(signal) => {
            Err(Error::Interrupted { stage: Some(stage.name.clone()), signal, name: child::signal_name(signal) })
        }
    }
}
