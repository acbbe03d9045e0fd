//! Running a stage as a child process:
//! `<bin> --<input> <path>… --<output> <path>… --<param> <value>… [--check]`.
//!
//! Names have `_` replaced by `-`; the files of an input given as a list or a glob are
//! passed one flag each (`--bvh a.bvh --bvh b.bvh`). Paths are passed as declared (normalised); the child runs
//! in the pipeline file's directory, so they resolve against it. A value that starts with
//! `-` is passed as `--name=value` so the stage's parser cannot take it for a flag. The
//! child inherits stdout and stderr (its progress bars and messages show directly) and
//! gets an empty stdin.
//!
//! Lifetime: the child runs in its own process group and is told the runner's pid
//! (`REPRISE_RUNNER_PID`), so it dies with the runner (see `reprise_stagekit::lifetime`).
//! When the runner receives SIGINT, SIGTERM or SIGHUP while a stage runs, it sends SIGTERM
//! to the stage's whole process group, then SIGKILL after [`GRACE`], and reports
//! [`Outcome::Interrupted`].

use std::ffi::OsString;
use std::io;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::error::{Error, Result};
use crate::pipeline::Stage;

/// How a child process ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Exit code 0.
    Success,
    /// A non-zero exit code.
    Failed(i32),
    /// Killed by this signal.
    Killed(i32),
    /// The runner received this signal and stopped the stage.
    Interrupted(i32),
}

/// How long a stage has to exit after SIGTERM before its group gets SIGKILL.
pub const GRACE: Duration = Duration::from_secs(2);

/// Signals that stop a run: recorded by a signal handler, polled while a stage runs.
#[derive(Debug, Clone, Default)]
pub struct Interrupt {
    signal: Arc<AtomicUsize>,
}

impl Interrupt {
    /// Records SIGINT, SIGTERM and SIGHUP from now on (unix; the handler only stores the
    /// signal number). The handlers are installed once per process and stay; each call
    /// starts from "nothing received".
    #[must_use]
    pub fn watch() -> Self {
        static PROCESS: std::sync::OnceLock<Interrupt> = std::sync::OnceLock::new();
        let this = PROCESS.get_or_init(|| {
            let this = Self::default();
            #[cfg(unix)]
            for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM, signal_hook::consts::SIGHUP] {
                let _ = signal_hook::flag::register_usize(signal, this.signal.clone(), signal.unsigned_abs() as usize);
            }
            this
        });
        this.signal.store(0, Ordering::SeqCst);
        this.clone()
    }

    /// The signal received, if any.
    #[must_use]
    pub fn received(&self) -> Option<i32> {
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            s => i32::try_from(s).ok(),
        }
    }
}

/// The stage's command-line arguments (without the program and without `--check`).
#[must_use]
pub fn stage_args(stage: &Stage) -> Vec<OsString> {
    let mut args = Vec::new();
    let mut push = |name: &str, value: String| {
        let flag = format!("--{}", name.replace('_', "-"));
        if value.starts_with('-') {
            args.push(OsString::from(format!("{flag}={value}")));
        } else {
            args.push(flag.into());
            args.push(value.into());
        }
    };
    for (name, path) in &stage.inputs {
        push(crate::pipeline::input_role(name), path.rel.clone());
    }
    for (name, path) in &stage.outputs {
        push(name, path.rel.clone());
    }
    for (name, value) in &stage.params {
        push(name, value.plain());
    }
    args
}

/// Environment variable naming the file where a stage writes its resource statistics
/// (`reprise_stagekit::STATS_ENV`).
pub const STATS_ENV: &str = "REPRISE_STATS_FILE";

/// The peak resident memory (MB) a stage wrote to its statistics file, if it did.
pub fn read_peak(stats: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(stats).ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    value.get("peak_rss_bytes")?.as_f64().map(|bytes| bytes / 1_048_576.0)
}

/// How a stage is invoked besides its flags.
#[derive(Debug, Clone, Copy, Default)]
pub struct Call<'a> {
    /// Append `--check` (validate the flags only).
    pub check: bool,
    /// Ask the stage to write its statistics (peak memory) to this file.
    pub stats: Option<&'a Path>,
    /// Send the stage's stdout and stderr to this file instead of the runner's.
    pub log: Option<&'a Path>,
    /// Ask the stage for plain progress lines even on a terminal (several stages share it).
    pub plain_progress: bool,
    /// The pipeline the stage runs for (recorded in what it writes; empty: none).
    pub pipeline: &'a str,
}

/// Runs the stage binary `bin` in `dir` as `call` says and waits for it. A signal
/// recorded by `interrupt` stops the stage (see the module docs).
pub fn invoke(stage: &Stage, bin: &Path, dir: &Path, call: Call<'_>, interrupt: &Interrupt) -> Result<Outcome> {
    let Call { check, stats, log, plain_progress, pipeline } = call;
    let mut command = Command::new(bin);
    command.args(stage_args(stage)).current_dir(dir).stdin(Stdio::null());
    if let Some(log) = log {
        let file = std::fs::File::create(log).map_err(|source| Error::Io { path: log.to_path_buf(), source })?;
        let copy = file.try_clone().map_err(|source| Error::Io { path: log.to_path_buf(), source })?;
        command.stdout(file).stderr(copy);
    }
    command.env(reprise_stagekit::lifetime::RUNNER_PID_ENV, std::process::id().to_string());
    if !pipeline.is_empty() {
        command.env(reprise_artifact::provenance::PIPELINE_ENV, pipeline);
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        command.process_group(0);
    }
    if let Some(path) = stats {
        command.env(STATS_ENV, path);
    }
    if check {
        command.arg("--check");
    }
    if plain_progress {
        command.env(reprise_stagekit::progress::PLAIN_ENV, "1");
    }
    let spawn_error = |source| Error::Spawn { stage: stage.name.clone(), bin: bin.to_path_buf(), source };
    let mut child = spawn(&mut command).map_err(spawn_error)?;
    match wait(&mut child, interrupt).map_err(spawn_error)? {
        Ok(status) => Ok(outcome(status)),
        Err(signal) => Ok(Outcome::Interrupted(signal)),
    }
}

/// Spawns, retrying briefly on `ETXTBSY`: on Linux, executing a file that another thread
/// of this process has just written can fail while a concurrently forked child still holds
/// the write descriptor.
fn spawn(command: &mut Command) -> io::Result<Child> {
    const ETXTBSY: i32 = 26;
    let mut attempts = 0;
    loop {
        match command.spawn() {
            Ok(child) => return Ok(child),
            Err(e) if cfg!(target_os = "linux") && e.raw_os_error() == Some(ETXTBSY) && attempts < 50 => {
                attempts += 1;
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => return Err(e),
        }
    }
}

/// Waits for the child, polling `interrupt`; on a signal, stops the child's process group
/// and returns `Err(signal)` once it is gone. When the child ends by itself (or is
/// killed by someone else), whatever it left running in its group — a rig evaluator — is
/// killed before the child is reaped.
fn wait(child: &mut Child, interrupt: &Interrupt) -> io::Result<Result<ExitStatus, i32>> {
    loop {
        if ended(child)? {
            kill_group(child);
            return child.wait().map(Ok);
        }
        if let Some(signal) = interrupt.received() {
            stop_group(child)?;
            return Ok(Err(signal));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Whether the child has ended, without reaping it: until it is reaped its pid — and so
/// its process group's id — cannot be reused, so [`kill_group`] reaches only its group.
#[cfg(unix)]
fn ended(child: &mut Child) -> io::Result<bool> {
    use rustix::process::{waitid, Pid, WaitId, WaitIdOptions};
    let Some(pid) = i32::try_from(child.id()).ok().and_then(Pid::from_raw) else {
        return child.try_wait().map(|s| s.is_some());
    };
    let options = WaitIdOptions::EXITED | WaitIdOptions::NOHANG | WaitIdOptions::NOWAIT;
    Ok(waitid(WaitId::Pid(pid), options)?.is_some())
}

#[cfg(not(unix))]
fn ended(child: &mut Child) -> io::Result<bool> {
    child.try_wait().map(|s| s.is_some())
}

/// SIGKILL to the child's process group (the child and anything it started).
fn kill_group(child: &Child) {
    #[cfg(unix)]
    {
        use rustix::process::{kill_process_group, Pid, Signal};
        if let Some(group) = i32::try_from(child.id()).ok().and_then(Pid::from_raw) {
            let _ = kill_process_group(group, Signal::KILL);
        }
    }
    #[cfg(not(unix))]
    let _ = child;
}

/// SIGTERM to the child's process group, SIGKILL after [`GRACE`] (or as soon as the child
/// is gone, for anything it started), then reaps the child.
fn stop_group(child: &mut Child) -> io::Result<()> {
    #[cfg(unix)]
    {
        use rustix::process::{kill_process_group, Pid, Signal};
        if let Some(group) = i32::try_from(child.id()).ok().and_then(Pid::from_raw) {
            let _ = kill_process_group(group, Signal::TERM);
            let deadline = Instant::now() + GRACE;
            while Instant::now() < deadline && !ended(child)? {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    }
    kill_group(child);
    let _ = child.kill();
    child.wait().map(drop)
}

#[cfg(unix)]
fn outcome(status: ExitStatus) -> Outcome {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(0), _) => Outcome::Success,
        (Some(code), _) => Outcome::Failed(code),
        (None, Some(signal)) => Outcome::Killed(signal),
        (None, None) => Outcome::Failed(reprise_stagekit::exit::FAILURE),
    }
}

#[cfg(not(unix))]
fn outcome(status: ExitStatus) -> Outcome {
    match status.code() {
        Some(0) => Outcome::Success,
        Some(code) => Outcome::Failed(code),
        None => Outcome::Failed(reprise_stagekit::exit::FAILURE),
    }
}

/// The conventional name of a POSIX signal number (Linux numbering).
#[must_use]
pub fn signal_name(signal: i32) -> &'static str {
    match signal {
        1 => "SIGHUP",
        2 => "SIGINT",
        3 => "SIGQUIT",
        4 => "SIGILL",
        5 => "SIGTRAP",
        6 => "SIGABRT",
        7 => "SIGBUS",
        8 => "SIGFPE",
        9 => "SIGKILL",
        10 => "SIGUSR1",
        11 => "SIGSEGV",
        12 => "SIGUSR2",
        13 => "SIGPIPE",
        14 => "SIGALRM",
        15 => "SIGTERM",
        24 => "SIGXCPU",
        25 => "SIGXFSZ",
        _ => "unknown signal",
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::pipeline::Pipeline;

    #[test]
    fn command_line_of_a_stage() {
        let text = r#"
            [pipeline]
            name = "t"
            [stage.label]
            bin = "reprise-label"
            inputs.frames = "./artifacts/frames.parquet"
            inputs.label_file = "datasets/labels.toml"
            outputs.segments = "artifacts/segments.parquet"
            params.min_segment_length = 12
            params.mask = ["eye_*", "lid_*"]
            params.share = 0.85
            params.offset = -3
            params.verbose = false
        "#;
        let p = Pipeline::parse(text, "pipeline.toml", Path::new("/p")).unwrap();
        let args: Vec<String> = stage_args(&p.stages[0]).into_iter().map(|a| a.into_string().unwrap()).collect();
        assert_eq!(
            args,
            [
                "--frames",
                "artifacts/frames.parquet",
                "--label-file",
                "datasets/labels.toml",
                "--segments",
                "artifacts/segments.parquet",
                "--min-segment-length",
                "12",
                "--mask",
                "eye_*,lid_*",
                "--share",
                "0.85",
                "--offset=-3",
                "--verbose",
                "false",
            ]
        );
    }

    #[test]
    fn signal_names() {
        assert_eq!(signal_name(9), "SIGKILL");
        assert_eq!(signal_name(11), "SIGSEGV");
        assert_eq!(signal_name(99), "unknown signal");
    }
}
