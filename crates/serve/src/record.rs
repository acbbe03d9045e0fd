//! Writing a session's recording: a new JSON file per session in the record directory,
//! written to a temporary file and renamed, never replacing a file that exists.

use std::io::Write;
use std::path::{Path, PathBuf};

use reprise_live::session::Recording;

/// The most sessions' files a directory gets (names `session-<unix seconds>-<n>.json`).
const MAX_TRIES: u32 = 10_000;

/// Writes `rec` to a new file in `dir` (created if missing); returns its path.
///
/// # Errors
/// The directory or the file cannot be written, with the path.
pub fn write(dir: &Path, rec: &Recording) -> Result<PathBuf, String> {
    let fail = |p: &Path, e: std::io::Error| format!("cannot write the session's recording to {}: {e}", p.display());
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, e))?;
    let text = serde_json::to_string_pretty(rec).expect("a recording serialises");
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| fail(dir, e))?;
    tmp.write_all(text.as_bytes()).map_err(|e| fail(tmp.path(), e))?;
    for n in 0..MAX_TRIES {
        let path = dir.join(format!("session-{secs}-{n}.json"));
        // `persist_noclobber` refuses an existing file: the next number is tried.
        match tmp.persist_noclobber(&path) {
            Ok(_) => return Ok(path),
            Err(e) if e.error.kind() == std::io::ErrorKind::AlreadyExists => tmp = e.file,
            Err(e) => return Err(fail(&path, e.error)),
        }
    }
    Err(format!("{}: {MAX_TRIES} recordings this second already", dir.display()))
}

/// Reads a recording written by [`write()`] (at most 64 MB).
///
/// # Errors
/// The file is missing, too large, or not a recording, with the path.
pub fn read(path: &Path) -> Result<Recording, String> {
    let text = reprise_artifact::input::read_text(path, 64 << 20).map_err(|e| e.to_string())?;
    serde_json::from_str(&text).map_err(|e| format!("{}: not a session recording: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recordings_get_new_names_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let rec = Recording {
            systems: vec!["crossfade".into()],
            start: "a".into(),
            seed: 3,
            frames: 10,
            commands: vec![],
            game: vec![],
        };
        let a = write(dir.path(), &rec).unwrap();
        let b = write(dir.path(), &rec).unwrap();
        assert_ne!(a, b);
        assert_eq!(read(&a).unwrap(), rec);
        std::fs::write(dir.path().join("bad.json"), "{\"systems\": 1}").unwrap();
        let e = read(&dir.path().join("bad.json")).unwrap_err();
        assert!(e.contains("bad.json") && e.contains("not a session recording"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3, "no temporary file is left");
    }
}
