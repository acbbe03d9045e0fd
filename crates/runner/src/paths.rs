//! Paths named in `pipeline.toml`: lexical normalisation (so `./a//b/../c` and `a/c` are
//! the same artifact) and resolution against the pipeline file's directory.

use std::path::{Component, Path, PathBuf};

/// A file path declared in `pipeline.toml`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ArtifactPath {
    /// The declared path, lexically normalised, `/`-separated: what the lock file records,
    /// what messages show and what the stage is given (it runs in the pipeline directory).
    pub rel: String,
    /// The absolute path: the pipeline directory joined with `rel`, normalised.
    pub abs: PathBuf,
}

impl ArtifactPath {
    /// Resolves `declared` against the (absolute) pipeline directory `dir`.
    pub(crate) fn new(dir: &Path, declared: &str) -> Self {
        let rel = normalize(Path::new(declared));
        let abs = normalize(&dir.join(&rel));
        let rel = rel.to_string_lossy().replace('\\', "/");
        Self { rel: if rel.is_empty() { ".".into() } else { rel }, abs }
    }
}

/// Removes `.` components and folds `x/..` without touching the file system. Leading `..`
/// of a relative path are kept; `..` at the root is dropped.
pub(crate) fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => match out.components().next_back() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                Some(Component::ParentDir | Component::CurDir) | None => out.push(".."),
            },
            other => out.push(other.as_os_str()),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalises_lexically() {
        assert_eq!(normalize(Path::new("./a//b/../c")), PathBuf::from("a/c"));
        assert_eq!(normalize(Path::new("../x/./y")), PathBuf::from("../x/y"));
        assert_eq!(normalize(Path::new("a/../../b")), PathBuf::from("../b"));
        assert_eq!(normalize(Path::new("/a/../../b")), PathBuf::from("/b"));
    }

    #[test]
    fn resolves_against_the_pipeline_directory() {
        let p = ArtifactPath::new(Path::new("/work/p"), "./artifacts/../artifacts/x.parquet");
        assert_eq!(p.rel, "artifacts/x.parquet");
        assert_eq!(p.abs, PathBuf::from("/work/p/artifacts/x.parquet"));
        let q = ArtifactPath::new(Path::new("/work/p"), "/data/y.csv");
        assert_eq!(q.rel, "/data/y.csv");
        assert_eq!(q.abs, PathBuf::from("/data/y.csv"));
    }
}
