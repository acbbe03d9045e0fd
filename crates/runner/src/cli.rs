//! The `reprise` command line (clap derive). Only the shape of the flags lives here; each
//! subcommand's behaviour is in its own module.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Runs the reprise pipeline: stage binaries in dependency order, skipping every stage whose
/// binary, parameters and inputs are unchanged since its last successful run.
#[derive(Debug, Parser)]
#[command(name = "reprise", version, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the stale stages in dependency order (each stage's flags are checked first).
    ///
    /// A stage is stale when it never ran, its binary, parameters or inputs changed, one of
    /// its outputs is missing or was modified, or a stage it depends on is stale. A failing
    /// stage stops the run; stages that finished before it stay recorded in the lock file.
    Run(RunArgs),
    /// Say, for every stage, whether it is fresh or stale, and every reason it is stale.
    Status(PipelineArg),
    /// Print the stage graph as text or as a Mermaid flowchart.
    Dag(DagArgs),
    /// Summarise a Parquet artifact: size, rows, schema, provenance metadata, first rows.
    Inspect(InspectArgs),
    /// Write a working pipeline for a new character: `pipeline.toml`, a labels file with
    /// one label per clip (unless --labels) and a demo script, checked by ingesting and
    /// labeling the source; then `reprise run` runs it to the report.
    Init(InitArgs),
    /// Serve the pipeline's characters live in a browser (run it after `reprise run`):
    /// every benchmark system driven by the same commands, on loopback unless --listen
    /// says otherwise.
    Serve(ServeArgs),
    /// Measure a live session (run it after `reprise run`): every system replayed on the
    /// commands of a recording `reprise serve` wrote, as the transition benchmark's
    /// answers, then `evaluate` on them, writing its report to
    /// `reports/<name>/replay-<recording>/`.
    Replay(ReplayArgs),
}

/// `reprise replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The session's recording (`recordings/session-*.json`), relative to where you stand.
    #[arg(value_name = "RECORDING")]
    pub recording: PathBuf,
    /// The pipeline whose artifacts the systems play and whose `evaluate` measures them.
    #[command(flatten)]
    pub pipeline: PipelineArg,
    /// Seconds of each system's frames kept before every TRANSITION as context (as the
    /// benchmark's `hold`).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.5)]
    pub hold: f64,
}

/// `reprise serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The pipeline whose artifacts are served.
    #[command(flatten)]
    pub pipeline: PipelineArg,
    /// Address to listen on (loopback by default; another address exposes the server).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8024")]
    pub listen: String,
    /// At most this many sessions at once.
    #[arg(long, default_value_t = 32)]
    pub max_sessions: usize,
    /// Where each session's recording is written (relative to the pipeline's directory).
    #[arg(long, value_name = "DIR", default_value = "recordings")]
    pub record_dir: PathBuf,
    /// The Tic-Tac-Toe game file (docs/live.md); default `game.toml` beside the pipeline,
    /// if there is one.
    #[arg(long, value_name = "FILE")]
    pub game: Option<PathBuf>,
}

/// `reprise init`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["gltf", "bvh", "curves"])))]
pub struct InitArgs {
    /// The file to write; the labels file and `scripts/demo.toml` go beside it.
    #[command(flatten)]
    pub pipeline: PipelineArg,
    /// Source: a glTF 2.0 character (.glb/.gltf); each named animation is a clip.
    #[arg(long, value_name = "FILE")]
    pub gltf: Option<PathBuf>,
    /// Source: BVH takes of one skeleton, one clip per file: files, or a quoted glob
    /// (`'takes/*.bvh'`, wildcards in the file name only). Several values are a list.
    #[arg(long, value_name = "FILE|GLOB", num_args = 1..)]
    pub bvh: Vec<String>,
    /// Source: a curve table (.csv/.parquet); its `clip` column names the clips. Needs
    /// --external-rig.
    #[arg(long, value_name = "FILE")]
    pub curves: Option<PathBuf>,
    /// With --curves: the rig evaluator command (program and arguments, comma-separated).
    #[arg(long, value_name = "CMD", value_delimiter = ',', requires = "curves")]
    pub external_rig: Vec<String>,
    /// Your labels file (TOML or CSV); without it init writes `labels.toml`, one label per clip.
    #[arg(long, value_name = "FILE")]
    pub labels: Option<PathBuf>,
    /// The pipeline's name (`artifacts/<name>`, `reports/<name>`); default: from the source's file name.
    #[arg(long)]
    pub name: Option<String>,
    /// The pipeline's frame rate: every clip is resampled to it (default: ingest's own).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Replace the files init writes if they exist.
    #[arg(long)]
    pub force: bool,
}

/// `--pipeline`.
#[derive(Debug, Args)]
pub struct PipelineArg {
    /// The pipeline file; stage paths are relative to its directory, where stages also run.
    #[arg(long, short = 'p', value_name = "FILE", default_value = "pipeline.toml")]
    pub pipeline: PathBuf,
}

/// `reprise run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub pipeline: PipelineArg,
    /// Run only STAGE and the stages it depends on (directly or not).
    #[arg(long, value_name = "STAGE")]
    pub to: Option<String>,
    /// Rerun STAGE even if it is fresh, and therefore every stage downstream of it.
    /// Repeat to force several stages.
    #[arg(long, value_name = "STAGE")]
    pub force: Vec<String>,
    /// Run at most N partitions of a partitioned stage (labels of scale, pca and gplvm,
    /// label pairs of bridges) at once (default: one per core).
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Where stage processes run: `local` child processes, or `slurm` job arrays (one
    /// task per stale label of a partitioned stage; docs/cluster.md).
    #[arg(long, value_enum, default_value_t = ExecutorKind::Local)]
    pub executor: ExecutorKind,
    /// Slurm's `--partition` (its queue; not a label partition).
    #[arg(long, value_name = "NAME")]
    pub slurm_partition: Option<String>,
    /// Slurm's `--account`.
    #[arg(long, value_name = "NAME")]
    pub slurm_account: Option<String>,
    /// Slurm's `--time`: each task's time limit (e.g. `2:00:00`).
    #[arg(long, value_name = "LIMIT")]
    pub slurm_time: Option<String>,
    /// Take over an artifacts directory another pipeline wrote: its lock is replaced and
    /// its outputs at this pipeline's paths are overwritten (without this, refused).
    #[arg(long)]
    pub adopt_artifacts: bool,
}

/// `reprise run --executor`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ExecutorKind {
    /// Child processes of the runner.
    Local,
    /// Slurm job arrays, submitted with `sbatch`.
    Slurm,
}

/// `reprise dag`.
#[derive(Debug, Args)]
pub struct DagArgs {
    #[command(flatten)]
    pub pipeline: PipelineArg,
    /// Output format: `text` for reading, `mermaid` for a `flowchart LR` to paste into
    /// Markdown.
    #[arg(long, value_enum, default_value_t = DagFormat::Text)]
    pub format: DagFormat,
}

/// How `reprise dag` prints the graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DagFormat {
    /// Stages in run order with their inputs and outputs.
    Text,
    /// A Mermaid `flowchart LR`.
    Mermaid,
}

/// `reprise inspect`.
#[derive(Debug, Args)]
pub struct InspectArgs {
    /// The Parquet file to summarise.
    pub file: PathBuf,
    /// How many rows to print.
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub head: usize,
    /// Comma-separated columns to show in the schema and the rows (default: the first
    /// columns; wide tables list only the first 20 in the schema).
    #[arg(long, value_name = "A,B,C", value_delimiter = ',')]
    pub columns: Vec<String>,
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::*;

    #[test]
    fn cli_is_well_formed() {
        Cli::command().debug_assert();
    }

    #[test]
    fn every_flag_has_help() {
        let mut cli = Cli::command();
        cli.build();
        for sub in cli.get_subcommands() {
            assert!(sub.get_about().is_some(), "`{}` has no help", sub.get_name());
            for arg in sub.get_arguments() {
                assert!(arg.get_help().is_some(), "`{} {}` has no help", sub.get_name(), arg.get_id());
            }
        }
    }

    #[test]
    fn repeated_force_and_column_list() {
        let cli = Cli::try_parse_from(["reprise", "run", "--force", "a", "--force", "b", "--to", "c"]).unwrap();
        let Command::Run(run) = cli.command else { panic!("not run") };
        assert_eq!(run.force, ["a", "b"]);
        assert_eq!(run.to.as_deref(), Some("c"));
        assert_eq!(run.pipeline.pipeline, PathBuf::from("pipeline.toml"));
        let cli = Cli::try_parse_from(["reprise", "inspect", "f.parquet", "--columns", "a,b"]).unwrap();
        let Command::Inspect(inspect) = cli.command else { panic!("not inspect") };
        assert_eq!(inspect.columns, ["a", "b"]);
        assert_eq!(inspect.head, 5);
    }
}
