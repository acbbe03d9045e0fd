//! A temporary project directory with a pipeline, and the `reprise` binary run in it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap()
}

/// A project directory holding a copy of the repository's pipeline and labels.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Project {
    /// An empty project.
    pub fn empty() -> Self {
        Self { dir: tempfile::tempdir().unwrap() }
    }

    /// A project with the default dragon-face pipeline, its labels file, its scripts and its
    /// game file.
    pub fn dragon_face() -> Self {
        let p = Self::empty();
        p.write("pipeline.toml", &std::fs::read_to_string(repo().join("pipeline.toml")).unwrap());
        for file in ["datasets/dragon-face/labels.toml", "datasets/dragon-face/scripts/demo.toml", "game.toml"] {
            p.write(file, &std::fs::read_to_string(repo().join(file)).unwrap());
        }
        p
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    pub fn write(&self, rel: &str, text: &str) {
        let path = self.path(rel);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    pub fn read(&self, rel: &str) -> String {
        std::fs::read_to_string(self.path(rel)).unwrap()
    }

    /// Runs `reprise ARGS` in the project with the stage binaries of this build.
    pub fn reprise(&self, args: &[&str]) -> Run {
        self.reprise_with(args, &[])
    }

    /// [`Project::reprise`] with extra environment variables.
    pub fn reprise_with(&self, args: &[&str], env: &[(&str, &Path)]) -> Run {
        let exe = Path::new(env!("CARGO_BIN_EXE_reprise"));
        let mut command = Command::new(exe);
        command.args(args).current_dir(self.dir.path()).env("REPRISE_BIN_DIR", exe.parent().unwrap());
        for (key, value) in env {
            command.env(key, value);
        }
        Run { output: command.output().unwrap() }
    }
}

impl Project {
    /// Runs the stage binary `bin` (e.g. `reprise-motion-graph`) of this build directly,
    /// in the project, as a user calling it by hand would.
    pub fn stage(&self, bin: &str, args: &[&str]) -> Run {
        let exe = Path::new(env!("CARGO_BIN_EXE_reprise")).with_file_name(bin);
        Run { output: Command::new(exe).args(args).current_dir(self.dir.path()).output().unwrap() }
    }
}

/// The outcome of one command.
pub struct Run {
    pub output: Output,
}

impl Run {
    pub fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.output.stdout).into_owned()
    }
    pub fn stderr(&self) -> String {
        String::from_utf8_lossy(&self.output.stderr).into_owned()
    }
    pub fn all(&self) -> String {
        format!("{}{}", self.stdout(), self.stderr())
    }
    pub fn code(&self) -> Option<i32> {
        self.output.status.code()
    }
    /// Asserts success and returns stdout + stderr.
    pub fn ok(self) -> String {
        assert!(self.output.status.success(), "command failed ({:?}):\n{}", self.code(), self.all());
        self.all()
    }
    /// Asserts failure with `code` and returns stdout + stderr.
    pub fn fails(self, code: i32) -> String {
        assert_eq!(self.code(), Some(code), "expected exit code {code}:\n{}", self.all());
        self.all()
    }
}

/// A file under `../shared/datasets/`, or `None` (after saying the test is skipped)
/// where this clone has no `../shared`. In CI the data must be there.
pub fn shared_dataset(test: &str, rel: &str) -> Option<PathBuf> {
    let path = repo().join("../shared/datasets").join(rel);
    if path.exists() {
        return Some(path.canonicalize().unwrap());
    }
    assert!(std::env::var_os("CI").is_none(), "CI must have ../shared/datasets/{rel}");
    eprintln!("SKIPPED {test}: ../shared/datasets/{rel} not found (a user's clone has no ../shared)");
    None
}
