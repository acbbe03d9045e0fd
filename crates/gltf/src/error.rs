//! The one error type of this crate. Every message names the file and the thing at fault.

use std::path::PathBuf;

/// Why a glTF file could not be ingested or turned into a rig.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The file (or one of its external buffers) could not be read.
    #[error("{}: cannot read {what}: {source}", path.display())]
    Io {
        path: PathBuf,
        what: String,
        #[source]
        source: std::io::Error,
    },

    /// The file (or a buffer it names) is not a regular file, or is past the size bound.
    #[error(transparent)]
    Input(#[from] reprise_artifact::input::InputError),

    /// The file is not parseable glTF 2.0 / GLB, or fails the `gltf` crate's validation.
    #[error("{}: not a valid glTF 2.0 file: {reason}", path.display())]
    Parse { path: PathBuf, reason: String },

    /// `extensionsRequired` names an extension this crate cannot honour (e.g. mesh compression).
    #[error("{}: required extension {extension} is not supported (listed in extensionsRequired)", path.display())]
    UnsupportedExtension { path: PathBuf, extension: String },

    /// A buffer is missing, truncated, or has a URI we cannot resolve.
    #[error("{}: buffer {index}: {reason}", path.display())]
    Buffer { path: PathBuf, index: usize, reason: String },

    /// A mesh/skin accessor is missing or has an unusable layout.
    #[error("{}: {what}: {reason}", path.display())]
    Accessor { path: PathBuf, what: String, reason: String },

    /// An animation sampler is inconsistent (counts, times, accessor types).
    #[error("{}: animation '{animation}', sampler {sampler}: {reason}", path.display())]
    Sampler { path: PathBuf, animation: String, sampler: usize, reason: String },

    /// The node hierarchy is not a forest (a node with two parents, or a cycle).
    #[error("{}: node '{node}': {reason}", path.display())]
    Node { path: PathBuf, node: String, reason: String },

    /// Ingest needs at least one animation.
    #[error("{}: no animations: nothing to ingest", path.display())]
    NoAnimations { path: PathBuf },

    /// A rig needs at least one skin or morph target.
    #[error("{}: no skins or morph targets: nothing a control can move", path.display())]
    NothingToMove { path: PathBuf },

    /// The requested resampling rate is not a positive finite number.
    #[error("{}: fps must be positive and finite, got {fps}", path.display())]
    BadFps { path: PathBuf, fps: f64 },

    /// Resampling would make more frames than the limit (a key time typo, or an absurd
    /// rate), refused before anything is allocated.
    #[error(
        "{}: animation '{animation}' lasts {duration} s, which at {fps} fps makes {frames:.0} frames ({total:.0} in all \
         animations), more than the limit of {limit} (ingest --max-frames); is a key time wrong?",
        path.display()
    )]
    TooLong { path: PathBuf, animation: String, duration: f64, fps: f64, frames: f64, total: f64, limit: usize },
}

impl GltfError {
    /// Runs a read of `path` that goes through the `gltf` crate, turning a panic of that
    /// crate on a damaged file (found by the generative tests: `Checked::unwrap` of an
    /// invalid animation path, indexing past an array during validation) into
    /// [`GltfError::Parse`] naming the file.
    pub(crate) fn contain<T>(path: &std::path::Path, read: impl FnOnce() -> Result<T, Self>) -> Result<T, Self> {
        reprise_artifact::contain::contain(read).unwrap_or_else(|panic| {
            Err(Self::Parse {
                path: path.to_path_buf(),
                reason: format!("the glTF library failed on it ({panic}); an index or enum value is wrong"),
            })
        })
    }
}
