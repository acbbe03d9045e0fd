//! Reading a user's input files with a bound: only regular files (a device such as
//! `/dev/zero`, a FIFO or a directory is refused by name — reading one never ends or
//! fails late), never more bytes than the caller allows (checked against the file's
//! length before anything is allocated, and again while reading, for files that grow or
//! report no length, such as those under `/proc`).

use std::io::Read;
use std::path::{Path, PathBuf};

/// Why an input file was not read.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// Not a regular file.
    #[error("{path}: {what}, not a regular file; give the path of a file")]
    NotRegular {
        /// The path.
        path: PathBuf,
        /// What it is ("a directory", "a character device", …).
        what: &'static str,
    },
    /// Longer than the caller allows.
    #[error("{path}: {len} bytes, more than the {max} this input may have{hint}")]
    TooLarge {
        /// The path.
        path: PathBuf,
        /// Its length (at least this many bytes).
        len: u64,
        /// The bound.
        max: u64,
        /// What to do.
        hint: String,
    },
    /// The operating system refused.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

impl InputError {
    /// The error without its path, for callers that name the file their own way.
    pub fn into_io(self) -> std::io::Error {
        use std::io::{Error, ErrorKind};
        match self {
            Self::Io { source, .. } => source,
            Self::NotRegular { what, .. } => {
                Error::new(ErrorKind::InvalidInput, format!("{what}, not a regular file; give the path of a file"))
            }
            Self::TooLarge { len, max, hint, .. } => Error::new(
                ErrorKind::InvalidInput,
                format!("{len} bytes, more than the {max} this input may have{hint}"),
            ),
        }
    }
}

/// What `path` is, when it is not a regular file.
fn not_regular(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some(if t.is_dir() { "a directory" } else { "not a file" })
}

/// Checks that `path` is a regular file of at most `max` bytes; returns its length.
pub fn check_file(path: &Path, max: u64) -> Result<u64, InputError> {
    let meta = std::fs::metadata(path).map_err(|source| InputError::Io { path: path.into(), source })?;
    if let Some(what) = not_regular(&meta) {
        return Err(InputError::NotRegular { path: path.into(), what });
    }
    if meta.len() > max {
        return Err(InputError::TooLarge { path: path.into(), len: meta.len(), max, hint: String::new() });
    }
    Ok(meta.len())
}

/// Opens the regular file `path` for reading (a FIFO would block the open itself, a
/// device never end), as an artifact error naming the path.
pub fn open_regular(path: &Path) -> crate::error::Result<std::fs::File> {
    check_file(path, u64::MAX).map_err(|e| crate::ArtifactError::io(path, e.into_io()))?;
    std::fs::File::open(path).map_err(|e| crate::ArtifactError::io(path, e))
}

/// The bytes of the regular file `path`, at most `max` of them (else [`InputError::TooLarge`]).
pub fn read(path: &Path, max: u64) -> Result<Vec<u8>, InputError> {
    let len = check_file(path, max)?;
    let file = std::fs::File::open(path).map_err(|source| InputError::Io { path: path.into(), source })?;
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|source| InputError::Io { path: path.into(), source })?;
    if bytes.len() as u64 > max {
        return Err(InputError::TooLarge { path: path.into(), len: bytes.len() as u64, max, hint: String::new() });
    }
    Ok(bytes)
}

/// The text of the regular file `path` (UTF-8), at most `max` bytes. A file in another
/// encoding is named with a hint: UTF-16 (as some editors on Windows save) is recognised
/// by its byte-order mark.
pub fn read_text(path: &Path, max: u64) -> Result<String, InputError> {
    let bytes = read(path, max)?;
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let utf16 = bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]);
        let at = e.utf8_error().valid_up_to();
        let message = if utf16 {
            "the file is UTF-16 text; save it as UTF-8 (most editors: \"Save with encoding\" → UTF-8)".to_string()
        } else {
            format!("the file is not UTF-8 text (the first invalid byte is at offset {at}); save it as UTF-8")
        };
        InputError::Io { path: path.into(), source: std::io::Error::new(std::io::ErrorKind::InvalidData, message) }
    })
}

/// The most bytes a text input a person writes (a labels file, a script, a pipeline) may
/// have: 64 MiB, far past any real one.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

#[cfg(test)]
mod tests {
    use super::*;

    /// A device, a directory and a FIFO are refused by name, at once; a file past the
    /// bound is refused before it is read; a file within it reads whole.
    #[test]
    fn only_regular_files_within_the_bound_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let e = read(Path::new("/dev/zero"), 1 << 20).unwrap_err().to_string();
        assert!(e.contains("/dev/zero: a character device, not a regular file"), "{e}");
        let e = read(dir.path(), 10).unwrap_err().to_string();
        assert!(e.contains("a directory, not a regular file"), "{e}");
        let file = dir.path().join("f.txt");
        std::fs::write(&file, "hello").unwrap();
        assert_eq!(read(&file, 5).unwrap(), b"hello");
        let e = read(&file, 4).unwrap_err().to_string();
        assert!(e.contains("5 bytes, more than the 4 this input may have"), "{e}");
        #[cfg(unix)]
        {
            let fifo = dir.path().join("fifo");
            assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
            let e = read(&fifo, 10).unwrap_err().to_string();
            assert!(e.contains("a FIFO (named pipe), not a regular file"), "{e}");
        }
        let e = read(&dir.path().join("absent"), 10).unwrap_err().to_string();
        assert!(e.contains("absent"), "{e}");
    }

    /// A file that reports no length (procfs) is still cut at the bound.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_file_without_a_length_is_bounded_while_read() {
        let e = read(Path::new("/proc/self/maps"), 8).unwrap_err().to_string();
        assert!(e.contains("more than the 8 this input may have"), "{e}");
    }

    /// UTF-16 text is named as such, with what to do.
    #[test]
    fn utf16_text_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("labels.toml");
        let mut bytes = vec![0xFF, 0xFE];
        bytes.extend("[[rule]]".encode_utf16().flat_map(u16::to_le_bytes));
        std::fs::write(&file, bytes).unwrap();
        let e = read_text(&file, MAX_TEXT_BYTES).unwrap_err().to_string();
        assert!(e.contains("labels.toml") && e.contains("UTF-16") && e.contains("save it as UTF-8"), "{e}");
        std::fs::write(&file, b"ok \xC3\x28").unwrap();
        let e = read_text(&file, MAX_TEXT_BYTES).unwrap_err().to_string();
        assert!(e.contains("not UTF-8 text (the first invalid byte is at offset 3)"), "{e}");
    }
}
