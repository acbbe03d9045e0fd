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

/// What one read of a file yields.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Digest {
    /// Hex blake3 of the content.
    blake3: String,
    /// The code identity embedded in it (a stage binary's; see
    /// [`reprise_stagekit::code_id!`]), if exactly one is.
    code_id: Option<String>,
}

/// blake3 of files (and the code identity of stage binaries), memoised by path.
#[derive(Debug, Default)]
pub struct FileHasher {
    memo: HashMap<PathBuf, Option<Digest>>,
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
        Ok(self.digest(path)?.map(|d| d.blake3))
    }

    /// The code identity embedded in the file at `path` (`None`: the file is missing, or
    /// holds no identity, or several). Read with its hash, in the same pass.
    pub fn code_id(&mut self, path: &Path) -> Result<Option<String>> {
        Ok(self.digest(path)?.and_then(|d| d.code_id))
    }

    fn digest(&mut self, path: &Path) -> Result<Option<Digest>> {
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

/// Finds `reprise-code-id=<64 hex>;` in a stream of chunks, across chunk boundaries.
#[derive(Debug, Default)]
struct IdScan {
    /// The end of the previous chunk, long enough to hold a marker cut by the boundary.
    tail: Vec<u8>,
    found: std::collections::BTreeSet<String>,
}

impl IdScan {
    const HEX: usize = 64;

    fn feed(&mut self, chunk: &[u8]) {
        let marker = reprise_stagekit::CODE_ID_MARKER.as_bytes();
        let whole = marker.len() + Self::HEX + 1;
        let mut buf = std::mem::take(&mut self.tail);
        buf.extend_from_slice(chunk);
        for at in memchr::memmem::find_iter(&buf, marker) {
            let Some(rest) = buf.get(at + marker.len()..at + whole) else { continue };
            let (hex, end) = rest.split_at(Self::HEX);
            if end == b";" && hex.iter().all(u8::is_ascii_hexdigit) {
                self.found.insert(String::from_utf8_lossy(hex).into_owned());
            }
        }
        let keep = buf.len().saturating_sub(whole - 1);
        self.tail = buf.split_off(keep);
    }

    /// The identity, if exactly one was seen.
    fn finish(self) -> Option<String> {
        (self.found.len() == 1).then(|| self.found.into_iter().next()).flatten()
    }
}

fn hash_file(path: &Path) -> io::Result<Option<Digest>> {
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
    let mut scan = IdScan::default();
    loop {
        match file.read(&mut buffer) {
            Ok(0) => break,
            Ok(n) => {
                hasher.update(&buffer[..n]);
                scan.feed(&buffer[..n]);
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(Some(Digest { blake3: hasher.finalize().to_hex().to_string(), code_id: scan.finish() }))
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

    /// The identity is found wherever it lies, across a read boundary too; none, a
    /// malformed one, or two different ones give none.
    #[test]
    fn code_identity_is_found_in_the_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let id = "ab".repeat(32);
        let marked = |s: &str| format!("reprise-code-id={s};");
        let cases: [(Vec<u8>, Option<&str>); 5] = [
            ([vec![7u8; BUFFER - 20], marked(&id).into_bytes(), vec![0; 100]].concat(), Some(&id)),
            ([marked(&id), marked(&id), "reprise-code-id=".into()].concat().into_bytes(), Some(&id)),
            (b"no identity here".to_vec(), None),
            (marked(&"g".repeat(64)).into_bytes(), None),
            ([marked(&id), marked(&"cd".repeat(32))].concat().into_bytes(), None),
        ];
        for (i, (bytes, want)) in cases.into_iter().enumerate() {
            let path = dir.path().join(format!("bin{i}"));
            std::fs::write(&path, &bytes).unwrap();
            let mut hasher = FileHasher::new();
            assert_eq!(hasher.code_id(&path).unwrap().as_deref(), want, "case {i}");
            assert_eq!(hasher.hash(&path).unwrap().unwrap(), blake3::hash(&bytes).to_hex().to_string());
        }
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
