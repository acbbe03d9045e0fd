//! `reprise serve`: finds the files the live server needs in a pipeline (the inputs of
//! the stage that answers the transition benchmark, and the controls table naming the
//! rig) and runs `reprise-serve` on them in the pipeline's directory.

use std::path::PathBuf;

use crate::cli::ServeArgs;
use crate::locate::{locate, BinDirs};
use crate::pipeline::BinSpec;
use crate::{Error, Result};

/// The inputs the server reads, by the role name stages give them, with its flag.
pub const ROLES: [(&str, &str); 9] = [
    ("gplvm_models", "--gplvm-models"),
    ("latents", "--latents"),
    ("pca_models", "--pca-models"),
    ("scales", "--scales"),
    ("bridges", "--bridges"),
    ("labeled_frames", "--labeled-frames"),
    ("mg_nodes", "--mg-nodes"),
    ("mg_edges", "--mg-edges"),
    ("controls", "--controls"),
];

/// The game file `reprise serve` uses when none is named, beside the pipeline.
pub const GAME_FILE: &str = "game.toml";

/// The files of [`ROLES`] in the pipeline at `args.pipeline`: for each role, the first
/// stage input of that name (in the pipeline's stage order).
///
/// # Errors
/// [`Error::Serve`] naming a role no stage reads, or a file not made yet.
pub fn files(args: &ServeArgs, dirs: &BinDirs) -> Result<(PathBuf, Vec<(&'static str, PathBuf)>)> {
    let (pipeline, _) = crate::load(&args.pipeline.pipeline, dirs.known)?;
    let mut out = Vec::new();
    for (role, flag) in ROLES {
        let found = pipeline.stages.iter().flat_map(|s| &s.inputs).find(|(r, _)| r == role);
        let Some((_, path)) = found else {
            return Err(Error::Serve(format!(
                "no stage of {} reads `{role}`; serve needs the transition benchmark's inputs (a `transitions` stage) \
                 and the controls table",
                pipeline.file
            )));
        };
        if !path.abs.is_file() {
            return Err(Error::Serve(format!("{} is not made yet: run `reprise run` first", path.rel)));
        }
        out.push((flag, path.abs.clone()));
    }
    Ok((pipeline.dir, out))
}

/// Runs the server until it stops: on Unix the runner's process becomes `reprise-serve`
/// (its exit status is the server's).
///
/// # Errors
/// As [`files`]; [`Error::NoBin`]-like [`Error::Serve`] when `reprise-serve` is not found;
/// [`Error::ServeExited`] when it exits with an error.
pub fn serve(args: &ServeArgs, dirs: &BinDirs) -> Result<()> {
    let (dir, files) = files(args, dirs)?;
    let bin = locate(&BinSpec::Name("reprise-serve".into()), dirs)
        .map_err(|looked| Error::Serve(format!("cannot find `reprise-serve` (looked in {looked})")))?;
    let mut cmd = std::process::Command::new(bin);
    cmd.current_dir(&dir);
    for (flag, path) in &files {
        cmd.arg(flag).arg(path);
    }
    cmd.arg("--listen").arg(&args.listen);
    cmd.arg("--max-sessions").arg(args.max_sessions.to_string());
    cmd.arg("--record-dir").arg(&args.record_dir);
    // The game file the user named (from where they stand), else the pipeline's own.
    let game = match &args.game {
        Some(g) => Some(std::path::absolute(g).map_err(|e| Error::Serve(format!("{}: {e}", g.display())))?),
        None => Some(dir.join(GAME_FILE)).filter(|g| g.is_file()),
    };
    if let Some(g) = game {
        cmd.arg("--game").arg(g);
    }
    // The runner becomes the server, so a signal for `reprise serve` (Ctrl-C, a kill)
    // reaches it and no server outlives the command that started it.
    #[cfg(unix)]
    {
        let e = std::os::unix::process::CommandExt::exec(&mut cmd);
        Err(Error::Serve(format!("cannot start reprise-serve: {e}")))
    }
    #[cfg(not(unix))]
    {
        wait(&mut cmd)
    }
}

/// Runs `cmd` to its end (where the runner cannot become the server).
#[cfg(not(unix))]
fn wait(cmd: &mut std::process::Command) -> Result<()> {
    let status = cmd.status().map_err(|e| Error::Serve(format!("cannot start reprise-serve: {e}")))?;
    match status.code() {
        Some(0) => Ok(()),
        Some(code) => Err(Error::ServeExited { code }),
        None => Err(Error::ServeExited { code: reprise_stagekit::exit::INTERRUPTED_BASE }),
    }
}
