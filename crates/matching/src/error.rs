//! The crate's one error type. Every public entry point validates its input and returns
//! one of these instead of panicking; variants carry the frame/column/name that failed.

/// What went wrong, with the offending frame, column or parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MatchError {
    /// The database has no frames.
    #[error("the database has no frames")]
    EmptyDatabase,
    /// A row dimension (controls `C` or PCA coordinates `q`) is zero.
    #[error("`{what}` dimension must be at least 1")]
    ZeroDimension {
        /// Which dimension.
        what: &'static str,
    },
    /// An input has the wrong number of values.
    #[error("`{what}` has {actual} values, expected {expected}")]
    Length {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        actual: usize,
    },
    /// A value is NaN or infinite.
    #[error("`{what}` at frame {frame}, column {column} is not finite ({value})")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Row (frame) index; 0 for a single query vector.
        frame: usize,
        /// Column index.
        column: usize,
        /// The offending value.
        value: f64,
    },
    /// The frame rate is not finite and positive.
    #[error("fps must be finite and positive, got {0}")]
    Fps(f64),
    /// A segment id reappears after another segment: frames of one take must be contiguous.
    #[error(
        "segment {segment} reappears at frame {frame} after another segment; \
         the frames of a segment must be contiguous"
    )]
    SegmentNotContiguous {
        /// First frame of the second run.
        frame: usize,
        /// The repeated segment id.
        segment: u32,
    },
    /// A parameter is outside its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    Param {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// A frame index is outside the database.
    #[error("frame {frame} is out of range (the database has {n} frames)")]
    FrameOutOfRange {
        /// The index given.
        frame: usize,
        /// Number of frames.
        n: usize,
    },
    /// A feature set or frame set was built for another database.
    #[error("`{what}` was built for {actual} frames but the database has {expected}")]
    Mismatch {
        /// Which object.
        what: &'static str,
        /// Frames in the database.
        expected: usize,
        /// Frames the object covers.
        actual: usize,
    },
    /// The target label has no frame a jump may land on: it has no frame, or only
    /// one-frame segments. (A label whose segments are merely shorter than the wanted
    /// window is served with a shorter one — [`crate::Database::label_window`] — so the
    /// least a candidate needs is 1 frame of continuation.)
    #[error(
        "label {label} has no searchable frame (a frame needs {needed} frame{} of \
         continuation in its segment)",
        plural(.needed)
    )]
    NoSearchableFrames {
        /// The requested label.
        label: u32,
        /// Frames of continuation a candidate needs at the least (1: the window shrinks to
        /// the label's segments, down to one frame).
        needed: usize,
    },
    /// Playback reached the end of a segment and no allowed frame could take over
    /// (every candidate excluded).
    #[error(
        "playback reached the end of its segment at frame {frame} and no frame of \
         label {label} could take over"
    )]
    DeadEnd {
        /// The last playable frame.
        frame: usize,
        /// The target label.
        label: u32,
    },
}

/// "s" after a count other than 1.
fn plural(n: &usize) -> &'static str {
    if *n == 1 {
        ""
    } else {
        "s"
    }
}

/// `Result` with [`MatchError`].
pub type Result<T> = std::result::Result<T, MatchError>;

/// Checks that every value of a row-major `rows × dim` matrix is finite.
pub(crate) fn check_finite(what: &'static str, values: &[f64], dim: usize) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(MatchError::NonFinite { what, frame: i / dim, column: i % dim, value: values[i] }),
    }
}

/// Checks `actual == expected`.
pub(crate) fn check_len(what: &'static str, expected: usize, actual: usize) -> Result<()> {
    if expected == actual {
        Ok(())
    } else {
        Err(MatchError::Length { what, expected, actual })
    }
}
