//! Why a rig could not be opened or evaluated.

/// Errors of rig evaluators.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// The rig named by an artifact cannot be rebuilt as it was.
    #[error("rig {rig}: {message}")]
    Open {
        /// Which rig.
        rig: String,
        /// What went wrong.
        message: String,
    },
    /// A pose batch does not fit the rig.
    #[error("rig {rig}: pose batch of {values} values is not a whole number of {controls}-control poses")]
    BatchShape {
        /// Which rig.
        rig: String,
        /// Values given.
        values: usize,
        /// Controls per pose.
        controls: usize,
    },
    /// The external evaluator failed.
    #[error("external rig `{command}`: {message}")]
    External {
        /// The command line.
        command: String,
        /// What went wrong, with the evaluator's stderr where it said something.
        message: String,
    },
    /// The rig needs controls the frame table lacks, or the reverse.
    #[error("{0}")]
    Controls(String),
}
