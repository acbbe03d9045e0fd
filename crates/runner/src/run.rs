//! `reprise run`: decide which stages are stale, check their flags, then run them in order,
//! recording each success in the lock file as soon as it happens.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::time::{Instant, SystemTime};

use crate::cache::{self, Assessment, ResolvedBin};
use crate::child::{self, Outcome};
use crate::cli::{ExecutorKind, RunArgs};
use crate::dag::Dag;
use crate::error::{Error, Result};
use crate::executor::{Done, Executor, Local, Slurm, SlurmOptions, Task};
use crate::hash::FileHasher;
use crate::locate::BinDirs;
use crate::lock::{LockEntry, LockFile};
use crate::params::canonical_json;
use crate::partitioned;
use crate::pipeline::{Pipeline, Stage};
use crate::record::{record_inputs, record_outputs, remove_stale_temps, remove_stale_temps_of};
use crate::say;
use reprise_stagekit::wiring::Partition;

/// Runs the pipeline; progress goes to `log` (the runner's stderr).
pub fn run(args: &RunArgs, dirs: &BinDirs, log: &mut dyn Write) -> Result<()> {
    let started = Instant::now();
    let (pipeline, dag) = crate::load(&args.pipeline.pipeline, dirs.known)?;
    let selected = match &args.to {
        Some(to) => dag.with_ancestors(pipeline.index_of(to)?),
        None => (0..pipeline.stages.len()).collect(),
    };
    let mut forced = BTreeSet::new();
    for name in &args.force {
        let i = pipeline.index_of(name)?;
        if !selected.contains(&i) {
            let to = args.to.clone().unwrap_or_default();
            return Err(Error::ForcedNotSelected { stage: name.clone(), to });
        }
        forced.insert(i);
    }

    let lock_path = pipeline.lock_path();
    let _running = hold_run_lock(&pipeline)?;
    // A runner killed while saving the lock leaves its temporary copy behind.
    remove_stale_temps_of(&lock_path);
    let (mut lock, warning) = LockFile::load(&lock_path, &pipeline.name);
    let lock_readable = warning.is_none();
    if lock.pipeline != pipeline.name {
        if !args.adopt_artifacts {
            return Err(Error::ArtifactsOwned {
                file: pipeline.file.clone(),
                dir: pipeline.artifacts.rel.clone(),
                owner: lock.pipeline.clone(),
                pipeline: pipeline.name.clone(),
                lock: lock_path.display().to_string(),
            });
        }
        say(log, &format!("reprise: adopting `{}` from pipeline `{}`", pipeline.artifacts.rel, lock.pipeline));
        lock = LockFile::empty(&pipeline.name);
    }
    if let Some(warning) = warning {
        say(log, &format!("reprise: warning: {warning}"));
    }

    let mut hasher = FileHasher::new();
    let ctx = cache::Inputs { pipeline: &pipeline, dag: &dag, lock: &lock, forced: &forced, dirs };
    let plan = cache::assess(&ctx, &mut hasher)?;
    let order: Vec<usize> = dag.order().iter().copied().filter(|i| selected.contains(i)).collect();
    let to_run: Vec<usize> = order.iter().copied().filter(|&i| !plan[i].is_fresh()).collect();
    let stages_to_run: Vec<&Stage> = to_run.iter().map(|&i| &pipeline.stages[i]).collect();
    crate::guard::check_existing(&pipeline, &stages_to_run, &lock, lock_readable, args.adopt_artifacts)?;
    lock.pipeline.clone_from(&pipeline.name);
    lock.stages.retain(|name, _| pipeline.stage(name).is_some());

    // Jobs a killed runner left would write outputs under this run: cancel them first.
    for job in crate::slurm::cancel_leftovers(&pipeline)? {
        say(log, &format!("reprise: cancelled Slurm job {} ({}), left running by an earlier run", job.job, job.stage));
    }
    if to_run.is_empty() {
        let scope = args.to.as_ref().map_or_else(String::new, |to| format!(" up to `{to}`"));
        let seconds = started.elapsed().as_secs_f64();
        let line = match order.len() {
            1 => format!("reprise: the 1 stage{scope} is up to date ({seconds:.2} s)"),
            n => format!("reprise: all {n} stages{scope} are up to date ({seconds:.2} s)"),
        };
        say(log, &line);
        return Ok(());
    }

    let bins = preflight(&pipeline, &dag, &plan, &to_run)?;
    let executor = executor(args);
    let interrupt = child::Interrupt::watch();
    say(log, &format!("{:>10} {} of {} stages", "checking", to_run.len(), order.len()));
    check(&pipeline, &bins, &to_run, &interrupt)?;

    let (mut ran, mut cached) = (0, 0);
    for &i in &order {
        let stage = &pipeline.stages[i];
        let Some(bin) = bins.get(&i) else {
            say(log, &format!("{:>10} {}", "cached", stage.name));
            cached += 1;
            continue;
        };
        if let Some(signal) = interrupt.received() {
            return Err(Error::Interrupted { stage: None, signal, name: child::signal_name(signal) });
        }
        let reasons: Vec<String> = plan[i].reasons.iter().map(ToString::to_string).collect();
        say(log, &format!("{:>10} {} ({})", "running", stage.name, reasons.join("; ")));
        remove_stale_temps(stage);
        let partition = crate::wire::find(dirs.known, &stage.bin).map(|w| w.partition);
        let result = match partition {
            Some(p @ (Partition::Label { by } | Partition::LabelPair { by })) => {
                let job = partitioned::Job {
                    pipeline: &pipeline,
                    stage,
                    by,
                    pairs: matches!(p, Partition::LabelPair { .. }),
                    bin,
                    forced: forced.contains(&i),
                    executor: executor.as_ref(),
                    interrupt: &interrupt,
                };
                partitioned::run(&job, &mut hasher, &mut lock, &lock_path, log)
            }
            _ => run_stage(&pipeline, stage, bin, &mut hasher, &interrupt, executor.as_ref()),
        };
        match result {
            Ok(entry) => {
                let peak = entry.peak_rss_mb.map(|mb| format!(", peak memory {mb:.0} MB")).unwrap_or_default();
                say(log, &format!("{:>10} {} in {:.2} s{peak}", "ran", stage.name, entry.seconds));
                lock.stages.insert(stage.name.clone(), entry);
                lock.save(&lock_path)?;
                ran += 1;
            }
            Err(e) => {
                remove_stale_temps(stage);
                // A partitioned stage's entry keeps the labels that finished (not fresh).
                let keep = lock.stages.get(&stage.name).is_some_and(|e| e.key.is_empty() && !e.partitions.is_empty());
                if !keep && lock.stages.remove(&stage.name).is_some() {
                    lock.save(&lock_path)?;
                }
                return Err(e);
            }
        }
    }
    say(log, &format!("{:>10} {ran} ran, {cached} cached in {:.2} s", "finished", started.elapsed().as_secs_f64()));
    Ok(())
}

/// The executor `args` ask for.
fn executor(args: &RunArgs) -> Box<dyn Executor> {
    match args.executor {
        ExecutorKind::Local => Box::new(Local {
            jobs: args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from)),
        }),
        ExecutorKind::Slurm => Box::new(Slurm {
            options: SlurmOptions {
                partition: args.slurm_partition.clone(),
                account: args.slurm_account.clone(),
                time: args.slurm_time.clone(),
            },
        }),
    }
}

/// Everything that can be known wrong before any child starts: a missing binary, a
/// missing source input. Returns the binary of each stage to run.
fn preflight(
    pipeline: &Pipeline,
    dag: &Dag,
    plan: &[Assessment],
    to_run: &[usize],
) -> Result<BTreeMap<usize, ResolvedBin>> {
    let mut bins = BTreeMap::new();
    for &i in to_run {
        let stage = &pipeline.stages[i];
        let bin = plan[i].bin.clone().map_err(|searched| Error::StageBinaryMissing {
            stage: stage.name.clone(),
            bin: stage.bin.declared().into(),
            searched,
        })?;
        let produced = dag.produced_inputs(i);
        for (name, path) in &stage.inputs {
            if !produced.contains(name.as_str()) && !path.abs.exists() {
                return Err(Error::SourceMissing {
                    stage: stage.name.clone(),
                    input: name.clone(),
                    path: path.rel.clone(),
                });
            }
        }
        bins.insert(i, bin);
    }
    Ok(bins)
}

/// Invokes every stage to run with `--check`; all are tried so every problem shows at once.
fn check(
    pipeline: &Pipeline,
    bins: &BTreeMap<usize, ResolvedBin>,
    to_run: &[usize],
    interrupt: &child::Interrupt,
) -> Result<()> {
    let mut failures = Vec::new();
    let mut code = None;
    for &i in to_run {
        let stage = &pipeline.stages[i];
        let (why, exit) = match child::invoke(
            stage,
            &bins[&i].path,
            &pipeline.dir,
            child::Call { check: true, ..Default::default() },
            interrupt,
        )? {
            Outcome::Success => continue,
            Outcome::Interrupted(signal) => {
                return Err(Error::Interrupted {
                    stage: Some(stage.name.clone()),
                    signal,
                    name: child::signal_name(signal),
                })
            }
            Outcome::Failed(c) => (format!("exit code {c}"), c),
            Outcome::Killed(s) => {
                (format!("killed by signal {s} ({})", child::signal_name(s)), reprise_stagekit::exit::STAGE_CRASHED)
            }
        };
        failures.push((stage.name.clone(), why));
        code.get_or_insert(exit);
    }
    match code {
        None => Ok(()),
        Some(code) => Err(Error::CheckFailed { failures, code }),
    }
}

/// Runs one stage and returns its lock entry; nothing is recorded on failure.
fn run_stage(
    pipeline: &Pipeline,
    stage: &Stage,
    bin: &ResolvedBin,
    hasher: &mut FileHasher,
    interrupt: &child::Interrupt,
    executor: &dyn Executor,
) -> Result<LockEntry> {
    let (inputs, input_records) = record_inputs(stage, hasher)?;
    let mut ran = Done::default();
    executor.run(pipeline, &[Task { stage, bin }], interrupt, &mut |_, result| {
        ran = result?;
        Ok(())
    })?;
    let outputs = record_outputs(stage, hasher)?;
    let key = cache::current_key(stage, bin, &inputs).unwrap_or_default();
    Ok(LockEntry {
        key,
        bin: bin.record(),
        params: canonical_json(&stage.params),
        inputs: input_records,
        outputs,
        finished_at: crate::clock::rfc3339(SystemTime::now()),
        seconds: ran.seconds,
        peak_rss_mb: ran.peak_rss_mb,
        partitions: BTreeMap::new(),
        job: ran.job,
    })
}

/// Takes an exclusive advisory lock on `<artifacts>/.reprise.running` for the length of
/// the run, so two `reprise run`s of one pipeline cannot interleave stages or overwrite
/// each other's lock file. Released when the returned file is dropped (or the process ends).
fn hold_run_lock(pipeline: &Pipeline) -> Result<std::fs::File> {
    let dir = &pipeline.artifacts.abs;
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
    let path = dir.join(".reprise.running");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|source| Error::Io { path: path.clone(), source })?;
    // A lock seen held is asked again for a moment: a child another thread of this process
    // is starting holds a copy of every descriptor between its fork and its exec, so a run
    // that just ended can look alive for a few microseconds (when `main_with_args` is
    // called from several threads, as the tests do).
    let deadline = Instant::now() + std::time::Duration::from_millis(500);
    loop {
        match file.try_lock() {
            Ok(()) => return Ok(file),
            Err(std::fs::TryLockError::WouldBlock) if Instant::now() < deadline => {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            Err(std::fs::TryLockError::WouldBlock) => return Err(Error::AlreadyRunning { path }),
            Err(std::fs::TryLockError::Error(source)) => return Err(Error::Io { path, source }),
        }
    }
}
