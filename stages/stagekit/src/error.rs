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
            Self::Artifact(ArtifactError::Io { .. }) | Self::Artifact(_) | Self::Input(_) => exit::INPUT,
            Self::Numerical(_) => exit::NUMERICAL,
        }
    }
}

/// Result alias for stage code.
pub type StageResult<T> = Result<T, StageError>;
