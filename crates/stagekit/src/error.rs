//! The error every stage returns from its `run`: a message plus the exit-code class.

use reprise_artifact::ArtifactError;

use crate::exit;

/// Why a stage failed; [`StageError::code`] is its process exit code.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StageError {
    /// A bad flag or parameter value.
    #[error("{0}")]
    Config(String),
    /// An artifact could not be read or written.
    #[error(transparent)]
    Artifact(#[from] ArtifactError),
    /// Input data that violates what the stage needs (the message names file, row, column).
    #[error("{0}")]
    Input(String),
    /// A numerical method failed.
    #[error("{0}")]
    Numerical(String),
}

impl StageError {
    /// The process exit code for this error (see [`crate::exit`]).
    pub fn code(&self) -> i32 {
        match self {
            Self::Config(_) => exit::CONFIG,
            Self::Artifact(ArtifactError::Io { source, .. }) if exit::is_environment(source) => exit::ENVIRONMENT,
            Self::Artifact(_) | Self::Input(_) => exit::INPUT,
            Self::Numerical(_) => exit::NUMERICAL,
        }
    }
}

/// Result alias for stage code.
pub type StageResult<T> = Result<T, StageError>;

#[cfg(test)]
mod tests {
    use super::*;

    /// A refused write is the environment's fault; a missing input file is bad input.
    #[test]
    fn io_errors_by_cause() {
        let io = |kind| StageError::Artifact(ArtifactError::io("x", std::io::Error::from(kind)));
        assert_eq!(io(std::io::ErrorKind::PermissionDenied).code(), exit::ENVIRONMENT);
        assert_eq!(io(std::io::ErrorKind::ReadOnlyFilesystem).code(), exit::ENVIRONMENT);
        assert_eq!(io(std::io::ErrorKind::StorageFull).code(), exit::ENVIRONMENT);
        assert_eq!(io(std::io::ErrorKind::NotFound).code(), exit::INPUT);
    }
}
