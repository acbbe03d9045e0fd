//! Finding a stage's executable. A `bin` containing `/` is a path relative to the pipeline
//! file. A bare name is looked up, in order, in `$REPRISE_BIN_DIR`, in the directory of the
//! running `reprise` executable (where `cargo build --release` puts every stage), then on
//! `PATH`.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::pipeline::BinSpec;

/// Where bare binary names are looked up. Captured once per command from the process
/// environment, so lookups never read globals mid-run (and tests can build their own).
#[derive(Debug, Clone, Default)]
pub struct BinDirs {
    /// `$REPRISE_BIN_DIR`, searched first.
    pub env_dir: Option<PathBuf>,
    /// The directory of the running executable.
    pub exe_dir: Option<PathBuf>,
    /// The entries of `$PATH`.
    pub path: Vec<PathBuf>,
    /// The stages the runner knows the declarations of (their binaries are found here
    /// like any other; see [`crate::wire`]).
    pub known: &'static [reprise_stagekit::wiring::Wiring],
}

impl BinDirs {
    /// Reads `$REPRISE_BIN_DIR`, `std::env::current_exe()` and `$PATH`.
    #[must_use]
    pub fn from_env() -> Self {
        let env_dir = std::env::var_os("REPRISE_BIN_DIR").filter(|v| !v.is_empty()).map(PathBuf::from);
        let exe_dir = std::env::current_exe().ok().and_then(|exe| exe.parent().map(Path::to_path_buf));
        let path = std::env::var_os("PATH").map(|p| std::env::split_paths(&p).collect()).unwrap_or_default();
        Self { env_dir, exe_dir, path, known: &[] }
    }

    fn candidates(&self) -> impl Iterator<Item = &PathBuf> {
        self.env_dir.iter().chain(self.exe_dir.iter()).chain(self.path.iter())
    }
}

/// Resolves `spec` to an executable file, or describes where it looked.
pub fn locate(spec: &BinSpec, dirs: &BinDirs) -> Result<PathBuf, String> {
    match spec {
        BinSpec::Path(path) => {
            if is_executable(&path.abs) {
                Ok(path.abs.clone())
            } else {
                Err(format!("`{}`, relative to the pipeline file", path.abs.display()))
            }
        }
        BinSpec::Name(name) => {
            let name = OsString::from(name);
            if let Some(found) = dirs.candidates().map(|dir| dir.join(&name)).find(|p| is_executable(p)) {
                return Ok(found);
            }
            let mut places = Vec::new();
            if let Some(dir) = &dirs.env_dir {
                places.push(format!("$REPRISE_BIN_DIR `{}`", dir.display()));
            }
            if let Some(dir) = &dirs.exe_dir {
                places.push(format!("`{}` next to reprise", dir.display()));
            }
            places.push("$PATH".into());
            Err(places.join(", "))
        }
    }
}

#[cfg(unix)]
fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    path.metadata().is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

#[cfg(not(unix))]
fn is_executable(path: &Path) -> bool {
    path.is_file()
}

#[cfg(all(test, unix))]
mod tests {
    use std::os::unix::fs::PermissionsExt;

    use super::*;
    use crate::paths::ArtifactPath;

    fn exe(path: &Path) {
        std::fs::write(path, "#!/bin/sh\n").unwrap();
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
    }

    #[test]
    fn lookup_order_is_env_then_exe_dir_then_path() {
        let root = tempfile::tempdir().unwrap();
        let [env, exe_dir, path] = ["env", "exe", "path"].map(|d| {
            let dir = root.path().join(d);
            std::fs::create_dir(&dir).unwrap();
            dir
        });
        let dirs = BinDirs {
            env_dir: Some(env.clone()),
            exe_dir: Some(exe_dir.clone()),
            path: vec![path.clone()],
            known: &[],
        };
        let spec = BinSpec::Name("reprise-x".into());
        let err = locate(&spec, &dirs).unwrap_err();
        assert!(err.contains("$REPRISE_BIN_DIR") && err.contains("next to reprise") && err.contains("$PATH"), "{err}");
        exe(&path.join("reprise-x"));
        assert_eq!(locate(&spec, &dirs).unwrap(), path.join("reprise-x"));
        exe(&exe_dir.join("reprise-x"));
        assert_eq!(locate(&spec, &dirs).unwrap(), exe_dir.join("reprise-x"));
        exe(&env.join("reprise-x"));
        assert_eq!(locate(&spec, &dirs).unwrap(), env.join("reprise-x"));
    }

    #[test]
    fn non_executable_files_are_skipped() {
        let root = tempfile::tempdir().unwrap();
        std::fs::write(root.path().join("x.sh"), "").unwrap();
        let spec = BinSpec::Path(ArtifactPath::new(root.path(), "./x.sh"));
        assert!(locate(&spec, &BinDirs::default()).is_err());
        exe(&root.path().join("x.sh"));
        assert_eq!(locate(&spec, &BinDirs::default()).unwrap(), root.path().join("x.sh"));
    }
}
