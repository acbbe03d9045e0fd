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
    pub fn new(dir: &Path, declared: &str) -> Self {
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

/// `path` made absolute against `base` (an absolute directory), normalised.
pub fn absolute(base: &Path, path: &Path) -> PathBuf {
    normalize(&base.join(path))
}

/// `target` relative to the directory `from` (both absolute and normalised), `/`-separated,
/// as a pipeline file names it: `../shared/x.glb`. `target` itself when they share no
/// root; `.` when they are the same.
pub fn relative(from: &Path, target: &Path) -> String {
    let (a, b): (Vec<Component>, Vec<Component>) = (from.components().collect(), target.components().collect());
    // Sharing only the root (or nothing): the absolute path says more than `../../..`.
    if a.first() != b.first() || a.iter().zip(&b).take_while(|(x, y)| x == y).count() < 2 {
        return target.to_string_lossy().replace('\\', "/");
    }
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for part in &b[common..] {
        out.push(part.as_os_str());
    }
    let text = out.to_string_lossy().replace('\\', "/");
    if text.is_empty() {
        ".".into()
    } else {
        text
    }
}

/// Whether a declared input is a glob: it holds `*`, `?`, `[` or `{`.
pub fn is_glob(declared: &str) -> bool {
    declared.contains(['*', '?', '[', '{'])
}

/// The files a glob names, relative to `dir` as the glob is (`takes/*.bvh` →
/// `takes/a.bvh`, `takes/b.bvh`), sorted by name. Only the last component may hold
/// wildcards; directories and hidden files (`.x`) are not matched. An error says why in
/// words: a bad pattern, an unreadable directory, or no match.
pub fn expand_glob(dir: &Path, declared: &str) -> Result<Vec<String>, String> {
    let declared = declared.replace('\\', "/");
    let (parent, pattern) = declared.rsplit_once('/').map_or(("", declared.as_str()), |(p, f)| (p, f));
    if is_glob(parent) {
        return Err("only the file name may hold wildcards, not the directories above it".into());
    }
    let matcher = globset::GlobBuilder::new(pattern)
        .literal_separator(true)
        .build()
        .map_err(|e| format!("bad pattern: {e}"))?
        .compile_matcher();
    let folder = dir.join(if parent.is_empty() { "." } else { parent });
    let entries = std::fs::read_dir(&folder).map_err(|e| format!("cannot list `{}`: {e}", folder.display()))?;
    let mut names: Vec<String> = entries
        .filter_map(|entry| entry.ok())
        .filter(|entry| entry.path().is_file())
        .filter_map(|entry| entry.file_name().to_str().map(str::to_string))
        .filter(|name| !name.starts_with('.') && matcher.is_match(name))
        .collect();
    if names.is_empty() {
        return Err(format!("no file in `{}` matches it", folder.display()));
    }
    names.sort();
    Ok(names.into_iter().map(|n| if parent.is_empty() { n } else { format!("{parent}/{n}") }).collect())
}

/// A file or directory name for `name` (a label, or `stage[label]`): kept when it is made
/// of letters, digits, `_`, `-`, `.`, `[` and `]` (and does not start with `.`), else those
/// characters with the rest as `_`, plus 8 hex digits of its blake3 so that two names
/// never share one.
pub(crate) fn file_name(name: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-.[]".contains(c);
    if !name.is_empty() && !name.starts_with('.') && name.chars().all(plain) {
        return name.to_string();
    }
    let kept: String = name.chars().map(|c| if plain(c) { c } else { '_' }).collect();
    format!("{}-{}", kept.trim_start_matches('.'), &blake3::hash(name.as_bytes()).to_hex()[..8])
}

#[cfg(test)]
mod tests {
    /// Plain names stay; others keep their plain characters and gain a hash, so two
    /// labels differing only in a replaced character get two directories.
    #[test]
    fn file_names_are_safe_and_distinct() {
        assert_eq!(file_name("head_shake"), "head_shake");
        assert_eq!(file_name("gplvm[Dance-2]"), "gplvm[Dance-2]");
        let (a, b) = (file_name("walk/run"), file_name("walk run"));
        assert!(a.starts_with("walk_run-") && b.starts_with("walk_run-") && a != b, "{a} {b}");
        assert!(!file_name("..").starts_with('.') && !file_name("").is_empty());
        assert!(!file_name("a/../../b").contains('/'));
    }

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

    #[test]
    fn relative_paths_climb_to_the_common_directory() {
        assert_eq!(relative(Path::new("/w/a/b"), Path::new("/w/shared/x.glb")), "../../shared/x.glb");
        assert_eq!(relative(Path::new("/w/a"), Path::new("/w/a/labels.toml")), "labels.toml");
        assert_eq!(relative(Path::new("/w/a"), Path::new("/w/a")), ".");
        assert_eq!(relative(Path::new("/tmp/p"), Path::new("/w/x.glb")), "/w/x.glb", "only the root in common");
        assert_eq!(absolute(Path::new("/w/a"), Path::new("../b/./c")), PathBuf::from("/w/b/c"));
        assert_eq!(absolute(Path::new("/w/a"), Path::new("/x")), PathBuf::from("/x"));
    }

    #[test]
    fn globs_name_the_files_of_one_directory_in_order() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("takes/sub.bvh")).unwrap();
        for f in ["takes/b.bvh", "takes/a.bvh", "takes/.hidden.bvh", "takes/c.txt"] {
            std::fs::write(dir.path().join(f), "x").unwrap();
        }
        assert!(is_glob("takes/*.bvh") && is_glob("t/a?.bvh") && !is_glob("takes/a.bvh"));
        assert_eq!(expand_glob(dir.path(), "takes/*.bvh").unwrap(), ["takes/a.bvh", "takes/b.bvh"]);
        assert_eq!(expand_glob(&dir.path().join("takes"), "{a,c}.*").unwrap(), ["a.bvh", "c.txt"]);
        assert!(expand_glob(dir.path(), "takes/*.fbx").unwrap_err().contains("no file in"));
        assert!(expand_glob(dir.path(), "*/a.bvh").unwrap_err().contains("only the file name"));
        assert!(expand_glob(dir.path(), "none/*.bvh").unwrap_err().contains("cannot list"));
        assert!(expand_glob(dir.path(), "takes/[.bvh").unwrap_err().contains("bad pattern"));
    }
}
