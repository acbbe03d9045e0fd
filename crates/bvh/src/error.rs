//! The one error type of this crate.
//!
//! Every message starts with the file name (as given to the parser, normally the file's
//! base name) and, where the problem sits in the file, the 1-based line number, then says
//! what was found and what was expected.

use thiserror::Error;

/// Everything that can go wrong reading a BVH file or resampling it.
#[derive(Debug, Error)]
pub enum BvhError {
    /// The file could not be read at all.
    #[error("{file}: cannot read the file: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },

    /// The hierarchy does not follow the grammar: a missing `{` or `}`, a missing
    /// keyword, or something else where a keyword was expected.
    #[error("{file}: line {line}: expected {expected}, found {found}")]
    Syntax { file: String, line: usize, expected: String, found: String },

    /// `OFFSET` must be followed by exactly three numbers on its line.
    #[error("{file}: line {line}: OFFSET needs 3 numbers on its line, found {found}")]
    Offset { file: String, line: usize, found: String },

    /// The count after `CHANNELS` differs from the number of channel names that follow it.
    #[error("{file}: line {line}: CHANNELS declares {declared} channels but names {named} ({names})")]
    ChannelCount { file: String, line: usize, declared: String, named: usize, names: String },

    /// A channel name that is not one of the six BVH channels.
    #[error(
        "{file}: line {line}: unknown channel name `{name}` \
         (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)"
    )]
    UnknownChannel { file: String, line: usize, name: String },

    /// The same position channel twice on one joint (rotations may repeat an axis).
    #[error("{file}: line {line}: channel `{name}` appears twice on joint `{joint}`")]
    DuplicateChannel { file: String, line: usize, name: String, joint: String },

    /// Something other than a single `OFFSET` inside an `End Site`, or a joint without `OFFSET`.
    #[error("{file}: line {line}: {message}")]
    Node { file: String, line: usize, message: String },

    /// The `Frames:` line is missing or does not hold a non-negative integer.
    #[error("{file}: line {line}: expected `Frames: <count>` (a non-negative integer), found {found}")]
    Frames { file: String, line: usize, found: String },

    /// The `Frame Time:` line is missing or does not hold a positive, finite number of seconds.
    #[error("{file}: line {line}: expected `Frame Time: <seconds>` (a positive number), found {found}")]
    FrameTime { file: String, line: usize, found: String },

    /// A motion line holds the wrong number of values.
    #[error("{file}: line {line}: motion line has {found} values, expected {expected} (the channels declared in the hierarchy)")]
    ValueCount { file: String, line: usize, found: usize, expected: usize },

    /// A motion value that is not a finite number.
    #[error("{file}: line {line}: motion value {column} `{text}` is not a finite number")]
    Number { file: String, line: usize, column: usize, text: String },

    /// The number of motion lines differs from `Frames:`.
    #[error("{file}: line {line}: `Frames:` (line {frames_line}) declares {declared} frames but {found}")]
    FrameCount { file: String, line: usize, frames_line: usize, declared: usize, found: String },

    /// Resampling needs at least one frame and a positive target rate.
    #[error("{file}: line {line}: cannot resample: {reason}")]
    Resample { file: String, line: usize, reason: String },
}
