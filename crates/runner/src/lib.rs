//! The `reprise` runner: reads `pipeline.toml`, runs the stage binaries as separate
//! processes in dependency order, and skips every stage whose binary, parameters and input
//! contents are unchanged since its last successful run (recorded in
//! `<artifacts>/reprise.lock`, in the spirit of DVC's lock file).
//!
//! Map of the crate, in the order a `reprise run` goes through it:
//!
//! | module | owns |
//! |---|---|
//! | [`cli`] | the clap command line |
//! | [`pipeline`] | `pipeline.toml`: parsing and validation |
//! | [`wire`] | wiring by artifact: what a declared stage leaves out of `pipeline.toml` |
//! | [`paths`] | normalising and resolving declared paths |
//! | [`params`] | parameter values and their canonical forms |
//! | [`dag`] | dependencies, cycles, run order |
//! | [`guard`] | outputs that must not be written (user files, the pipeline file) |
//! | [`locate`] | finding stage binaries |
//! | [`hash`] | blake3 of files, memoised per command |
//! | [`key`] | the cache key |
//! | [`lock`] | the lock file |
//! | [`cache`] | freshness and the reasons a stage is stale |
//! | [`label_digest`] | the label partitions of an input, so `status` says which labels changed |
//! | `record` | a stage run's lock records and the temporary files a dead stage left |
//! | `partitioned` | running a partitioned stage one label at a time, cached per label, and merging |
//! | [`child`] | invoking a stage as a child process |
//! | [`executor`], [`slurm`] | where stage processes run: local children or Slurm job arrays |
//! | [`run`], [`status`], [`dag_text`], [`inspect`], [`serve`], [`replay`] | the subcommands (`init` is the `reprise-init` crate's, given in [`Commands`]) |
//! | [`error`] | the error type and its exit codes |
//!
//! There is no global state: [`main_with_args`] can be called any number of times in one
//! process.

pub mod cache;
pub mod child;
pub mod cli;
pub mod clock;
pub mod dag;
pub mod dag_text;
pub mod error;
pub mod executor;
pub mod guard;
pub mod hash;
pub mod inspect;
pub mod key;
pub mod label_digest;
pub mod locate;
pub mod lock;
pub mod params;
mod partitioned;
pub mod paths;
pub mod pipeline;
mod record;
pub mod replay;
pub mod run;
pub mod serve;
pub mod slurm;
pub mod status;
pub mod wire;

use std::ffi::OsString;
use std::io::Write;
use std::path::Path;

use clap::Parser;
use reprise_stagekit::exit;
use reprise_stagekit::wiring::Wiring;

pub use error::{Error, Result};

use crate::cli::{Cli, Command};
use crate::dag::Dag;
use crate::locate::BinDirs;
use crate::pipeline::Pipeline;

/// What the `reprise` executable gives the runner besides its own commands.
#[derive(Debug, Clone, Copy, Default)]
pub struct Commands {
    /// Every stage's declaration (see [`wire`]).
    pub known: &'static [Wiring],
    /// `reprise init` (the `reprise-init` crate, which builds on this one); without it,
    /// `init` says it is not part of this build.
    pub init: Option<InitCommand>,
    /// What `reprise-replay` reads and writes (the `reprise-replay` crate's declaration),
    /// for `reprise replay`; without it, `replay` says it is not part of this build.
    pub replay: Option<&'static Wiring>,
}

/// `reprise init`: given its arguments and where binaries are found (with the stages'
/// declarations), writes a pipeline and says what it wrote on `out`.
pub type InitCommand = fn(&cli::InitArgs, &BinDirs, &mut dyn Write) -> Result<()>;

/// Entry point of the `reprise` binary: parses `args` (program name first), runs the
/// command, prints any error once to stderr, and returns the process exit code.
pub fn main_with_args(args: impl IntoIterator<Item = OsString>, commands: Commands) -> i32 {
    main_with_io(args, commands, &mut std::io::stdout().lock(), &mut std::io::stderr())
}

/// As [`main_with_args`], writing the runner's own output to `stdout` and `stderr` (stage
/// processes still inherit the real ones). Bare stage binary names are looked up with the
/// process environment (`REPRISE_BIN_DIR`, the current executable's directory, `PATH`).
pub fn main_with_io(
    args: impl IntoIterator<Item = OsString>,
    commands: Commands,
    stdout: &mut dyn Write,
    stderr: &mut dyn Write,
) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let text = e.render().to_string();
            return if e.use_stderr() {
                let _ = write!(stderr, "{text}");
                exit::CONFIG
            } else {
                let _ = write!(stdout, "{text}");
                exit::OK
            };
        }
    };
    let dirs = BinDirs { known: commands.known, ..BinDirs::from_env() };
    let result = match &cli.command {
        Command::Run(args) => {
            let _ = stdout.flush();
            run::run(args, &dirs, stderr)
        }
        Command::Status(args) => status::status(&args.pipeline, &dirs, stdout, stderr),
        Command::Dag(args) => load(&args.pipeline.pipeline, dirs.known).map(|(p, d)| {
            let _ = write!(stdout, "{}", dag_text::render(&p, &d, args.format));
            if args.format == cli::DagFormat::Text {
                let _ = write!(stdout, "{}", status::jobs(&p));
            }
        }),
        Command::Inspect(args) => inspect::inspect(args).map(|text| {
            let _ = write!(stdout, "{text}");
        }),
        Command::Serve(args) => serve::serve(args, &dirs),
        Command::Replay(args) => match commands.replay {
            Some(wiring) => replay::replay(args, &dirs, wiring, stderr),
            None => Err(Error::Replay(
                "`replay` is not part of this build of the runner (the `reprise` executable has it)".into(),
            )),
        },
        Command::Init(args) => match commands.init {
            Some(init) => init(args, &dirs, stdout),
            None => Err(Error::Init(
                "`init` is not part of this build of the runner (the `reprise` executable has it)".into(),
            )),
        },
    };
    let _ = stdout.flush();
    match result {
        Ok(()) => exit::OK,
        Err(e) => {
            let _ = writeln!(stderr, "reprise: error: {e}");
            e.code()
        }
    }
}

/// Reads, validates and orders the pipeline at `path`, wiring the stages declared in
/// `known`.
pub fn load(path: &Path, known: &[Wiring]) -> Result<(Pipeline, Dag)> {
    let pipeline = Pipeline::load_wired(path, known)?;
    let dag = Dag::build(&pipeline)?;
    Ok((pipeline, dag))
}

/// Writes one progress line in one write (stages running beside it write to the same
/// stderr) and flushes it, so it lands whole and before the next child's output.
pub(crate) fn say(log: &mut dyn Write, line: &str) {
    let _ = log.write_all(format!("{line}\n").as_bytes());
    let _ = log.flush();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn call(args: &[&str]) -> (i32, String, String) {
        let (mut out, mut err) = (Vec::new(), Vec::new());
        let code = main_with_io(args.iter().map(OsString::from), Commands::default(), &mut out, &mut err);
        (code, String::from_utf8(out).unwrap(), String::from_utf8(err).unwrap())
    }

    #[test]
    fn help_and_usage_errors() {
        let (code, out, _) = call(&["reprise", "--help"]);
        assert_eq!(code, exit::OK);
        for sub in ["run", "status", "dag", "inspect", "init"] {
            assert!(out.contains(sub), "{out}");
        }
        let (code, out, _) = call(&["reprise", "run", "--help"]);
        assert_eq!(code, exit::OK);
        assert!(
            out.contains("--force <STAGE>") && out.contains("--to <STAGE>") && out.contains("--pipeline <FILE>"),
            "{out}"
        );
        let (code, _, err) = call(&["reprise", "frobnicate"]);
        assert_eq!(code, exit::CONFIG);
        assert!(err.contains("frobnicate"), "{err}");
    }

    #[test]
    fn missing_pipeline_is_a_config_error_printed_once() {
        let (code, _, err) = call(&["reprise", "status", "--pipeline", "/nonexistent/pipeline.toml"]);
        assert_eq!(code, exit::CONFIG);
        assert_eq!(err.matches("reprise: error:").count(), 1, "{err}");
        assert!(err.contains("cannot read `/nonexistent/pipeline.toml`"), "{err}");
    }

    #[test]
    fn can_be_called_twice_in_one_process() {
        for _ in 0..2 {
            assert_eq!(call(&["reprise", "--version"]).0, exit::OK);
            assert_eq!(call(&["reprise", "dag", "--pipeline", "/nonexistent.toml"]).0, exit::CONFIG);
        }
    }
}
