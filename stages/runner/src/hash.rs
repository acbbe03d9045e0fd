//! Content hashing of inputs, outputs and stage binaries with blake3, memoised per path for
//! the length of one command: an artifact that is one stage's output and two stages' input
//! is read once. The memo of a path is dropped when a stage rewrites it. [`FileHasher::prefetch`]
//! hashes many files on all cores at once, so a no-op rerun (every binary, input and output
//! hashed) stays fast.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::error::{Error, Result};

/// Bytes per read when hashing: few system calls, and wide enough for every SIMD lane.
const BUFFER: usize = 1 << 20;

/// blake3 of files, memoised by path.
#[derive(Debug, Default)]
pub struct FileHasher {
    memo: HashMap<PathBuf, Option<String>>,
}

impl FileHasher {
    /// An empty memo.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The hex blake3 of the file at `path`, or `None` if it does not exist. A directory
    /// or an unreadable file is an error.
    pub fn hash(&mut self, path: &Path) -> Result<Option<String>> {
        if let Some(known) = self.memo.get(path) {
            return Ok(known.clone());
        }
        let digest = hash_file(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        self.memo.insert(path.to_path_buf(), digest.clone());
        Ok(digest)
    }

    /// Hashes the not-yet-known `paths` in parallel, one file per thread at a time, largest
    /// first. Failures are not kept: [`FileHasher::hash`] reports them when asked.
    pub fn prefetch(&mut self, paths: impl IntoIterator<Item = PathBuf>) {
        let mut todo: Vec<(u64, PathBuf)> = paths
            .into_iter()
            .filter(|p| !self.memo.contains_key(p))
            .filter_map(|p| p.metadata().ok().filter(std::fs::Metadata::is_file).map(|m| (m.len(), p)))
            .collect();
        todo.sort_unstable_by(|a, b| b.cmp(a));
        todo.dedup_by(|a, b| a.1 == b.1);
        let threads = std::thread::available_parallelism().map_or(1, usize::from).min(todo.len());
        if threads < 2 {
            return; // hashed on demand, in order
        }
        let next = AtomicUsize::new(0);
        let worker = || {
            let mut done = Vec::new();
            while let Some((_, path)) = todo.get(next.fetch_add(1, Ordering::Relaxed)) {
                if let Ok(digest) = hash_file(path) {
                    done.push((path.clone(), digest));
                }
            }
            done
        };
        let results: Vec<Vec<_>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads).map(|_| scope.spawn(worker)).collect();
            handles.into_iter().filter_map(|h| h.join().ok()).collect()
        });
        self.memo.extend(results.into_iter().flatten());
    }

    /// Forgets what is known about `path` (a stage is about to write it, or just did).
    pub fn forget(&mut self, path: &Path) {
        self.memo.remove(path);
    }
}

fn hash_file(path: &Path) -> io::Result<Option<String>> {
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    if meta.is_dir() {
        return Err(io::Error::other("is a directory, not a file"));
    }
    let mut file = File::open(path)?;
    let mut buffer = vec![0; BUFFER];
    let mut hasher = blake3::Hasher::new();
    loop {
        match file.read(&mut buffer) {
            Ok(0) => break,
            Ok(n) => {
                hasher.update(&buffer[..n]);
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(Some(hasher.finalize().to_hex().to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_content_and_memoises_until_forgotten() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, b"hello").unwrap();
        let mut hasher = FileHasher::new();
        let first = hasher.hash(&path).unwrap().unwrap();
        assert_eq!(first, blake3::hash(b"hello").to_hex().to_string());
        std::fs::write(&path, b"changed").unwrap();
        assert_eq!(hasher.hash(&path).unwrap().unwrap(), first, "memoised");
        hasher.forget(&path);
        assert_eq!(hasher.hash(&path).unwrap().unwrap(), blake3::hash(b"changed").to_hex().to_string());
    }

    #[test]
    fn prefetch_agrees_with_hash() {
        let dir = tempfile::tempdir().unwrap();
        let paths: Vec<PathBuf> = (0..5).map(|i| dir.path().join(format!("f{i}"))).collect();
        for (i, path) in paths.iter().enumerate() {
            std::fs::write(path, vec![u8::try_from(i).unwrap(); 1000 * i]).unwrap();
        }
        let mut prefetched = FileHasher::new();
        prefetched.prefetch(paths.iter().cloned().chain([dir.path().join("missing"), paths[0].clone()]));
        let mut plain = FileHasher::new();
        for path in &paths {
            assert_eq!(prefetched.hash(path).unwrap(), plain.hash(path).unwrap());
        }
        assert_eq!(prefetched.hash(&dir.path().join("missing")).unwrap(), None);
    }

    #[test]
    fn missing_is_none_and_directory_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let mut hasher = FileHasher::new();
        assert_eq!(hasher.hash(&dir.path().join("nope")).unwrap(), None);
        let err = hasher.hash(dir.path()).unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
    }
}
