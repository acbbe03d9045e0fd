//! Running a stage as a child process:
//! `<bin> --<input> <path>… --<output> <path>… --<param> <value>… [--check]`.
//!
//! Names have `_` replaced by `-`. Paths are passed as declared (normalised); the child runs
//! in the pipeline file's directory, so they resolve against it. A value that starts with
//! `-` is passed as `--name=value` so the stage's parser cannot take it for a flag. The
//! child inherits stdout and stderr (its progress bars and messages show directly) and
//! gets an empty stdin.

use std::ffi::OsString;
use std::io;
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::time::Duration;

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
    for (name, path) in stage.inputs.iter().chain(&stage.outputs) {
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

/// Runs the stage binary `bin` in `dir` and waits for it; `check` appends `--check`;
/// `stats` asks the stage to write its statistics (peak memory) there.
pub fn invoke(stage: &Stage, bin: &Path, dir: &Path, check: bool, stats: Option<&Path>) -> Result<Outcome> {
    let mut command = Command::new(bin);
    command.args(stage_args(stage)).current_dir(dir).stdin(Stdio::null());
    if let Some(path) = stats {
        command.env(STATS_ENV, path);
    }
    if check {
        command.arg("--check");
    }
    let status = spawn_and_wait(&mut command).map_err(|source| Error::Spawn {
        stage: stage.name.clone(),
        bin: bin.to_path_buf(),
        source,
    })?;
    Ok(outcome(status))
}

/// Spawns, retrying briefly on `ETXTBSY`: on Linux, executing a file that another thread
/// of this process has just written can fail while a concurrently forked child still holds
/// the write descriptor.
fn spawn_and_wait(command: &mut Command) -> io::Result<ExitStatus> {
    const ETXTBSY: i32 = 26;
    let mut attempts = 0;
    loop {
        match command.spawn() {
            Ok(mut child) => return child.wait(),
            Err(e) if cfg!(target_os = "linux") && e.raw_os_error() == Some(ETXTBSY) && attempts < 50 => {
                attempts += 1;
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => return Err(e),
        }
    }
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
