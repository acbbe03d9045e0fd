//! The one error type of the artifact crate. Every variant names the file, and where it
//! applies the column and row, so a stage can print it once and the user can act on it.

use std::path::PathBuf;

/// Result alias for artifact operations.
pub type Result<T> = std::result::Result<T, ArtifactError>;

/// Why an artifact could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
#[allow(missing_docs, reason = "fields are the file, column, row and value the message names")]
pub enum ArtifactError {
    /// The file could not be opened, created, renamed or read.
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    /// The Parquet or Arrow layer refused the file.
    #[error("{path}: not a readable Parquet file: {message}")]
    Parquet { path: PathBuf, message: String },
    /// The file was written by something else, or holds another kind of artifact.
    #[error("{path}: expected a reprise `{expected}` artifact, found {found}")]
    WrongKind { path: PathBuf, expected: String, found: String },
    /// The artifact's schema version is not the one this build reads.
    #[error("{path}: `{kind}` schema version {found}, this build reads version {expected}; rerun the producing stage")]
    SchemaVersion { path: PathBuf, kind: String, expected: u32, found: String },
    /// A required column is absent.
    #[error("{path}: missing column `{column}`")]
    MissingColumn { path: PathBuf, column: String },
    /// A column has the wrong Arrow type.
    #[error("{path}: column `{column}` has type {found}, expected {expected}")]
    ColumnType { path: PathBuf, column: String, expected: String, found: String },
    /// A column appears twice.
    #[error("{path}: duplicated column `{column}`")]
    DuplicateColumn { path: PathBuf, column: String },
    /// A column holds a null where a value is required.
    #[error("{path}: column `{column}`, row {row}: missing value (null)")]
    Null { path: PathBuf, column: String, row: usize },
    /// A float column holds NaN or ±Inf.
    #[error("{path}: column `{column}`, row {row}: value {value} is not finite")]
    NotFinite { path: PathBuf, column: String, row: usize, value: f64 },
    /// The provenance metadata is present but unreadable.
    #[error("{path}: metadata key `{key}`: {message}")]
    Metadata { path: PathBuf, key: String, message: String },
    /// The decoded content does not match the checksum written with it.
    #[error("{path}: its data does not match the checksum reprise wrote with it: it was changed after it was written (rewritten by another tool — columns reordered, values edited — or damaged on disk, in a copy or a download); rerun the stage that produced it")]
    Corrupt { path: PathBuf },
    /// Two artifacts given together do not belong together (made by different runs, or
    /// one indexes rows the other does not have); the message says how, and what to rerun.
    #[error("{path} and {other} do not belong together: {message}")]
    Mismatch { path: PathBuf, other: PathBuf, message: String },
    /// The data violates an invariant of its kind (stated in the message).
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

impl ArtifactError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io { path: path.into(), source }
    }

    pub(crate) fn parquet(path: impl Into<PathBuf>, e: impl std::error::Error + 'static) -> Self {
        // An I/O error under the Parquet layer (a full disk while a row group is flushed)
        // is the machine's, not the file's: keep it as I/O so its exit code says so.
        let mut source: Option<&(dyn std::error::Error + 'static)> = Some(&e);
        while let Some(s) = source {
            if let Some(io) = s.downcast_ref::<std::io::Error>() {
                return Self::Io { path: path.into(), source: std::io::Error::new(io.kind(), e.to_string()) };
            }
            source = s.source();
        }
        Self::Parquet { path: path.into(), message: e.to_string() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A full disk under the Parquet writer stays an I/O error of its kind (the stage then
    /// exits as an environment error, 6, not as bad input, 3); a format error stays one.
    #[test]
    fn io_errors_under_parquet_keep_their_kind() {
        let full =
            parquet::errors::ParquetError::External(Box::new(std::io::Error::from(std::io::ErrorKind::StorageFull)));
        match ArtifactError::parquet("t.parquet", full) {
            ArtifactError::Io { source, .. } => assert_eq!(source.kind(), std::io::ErrorKind::StorageFull),
            other => panic!("{other}"),
        }
        let format = parquet::errors::ParquetError::General("bad magic".into());
        assert!(matches!(ArtifactError::parquet("t.parquet", format), ArtifactError::Parquet { .. }));
    }
}
