//! Reading a `.gltf`/`.glb` file and its buffers, without touching images.
//!
//! Buffers come from the GLB binary chunk, from base64 `data:` URIs, or from files next to
//! the `.gltf` (relative URIs). Nothing is fetched from the network and no image is decoded.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use gltf::json::validation::Validate as _;

use crate::error::GltfError;

/// Required extensions that do not change geometry, skinning or animation data, so a
/// reader that ignores materials, textures and lights can honour them by ignoring them.
/// Anything else in `extensionsRequired` (e.g. `KHR_draco_mesh_compression`,
/// `EXT_meshopt_compression`, `KHR_mesh_quantization`) is refused by name.
fn extension_is_harmless(name: &str) -> bool {
    name.starts_with("KHR_materials_")
        || matches!(
            name,
            "KHR_texture_transform"
                | "KHR_texture_basisu"
                | "EXT_texture_webp"
                | "EXT_texture_avif"
                | "MSFT_texture_dds"
                | "KHR_lights_punctual"
        )
}

/// A parsed, validated document with its buffers loaded.
pub(crate) struct Loaded {
    pub path: PathBuf,
    pub doc: gltf::Document,
    pub buffers: Vec<Vec<u8>>,
}

impl Loaded {
    /// Buffer accessor for the `gltf` crate's readers.
    pub fn buffer(&self, b: gltf::Buffer<'_>) -> Option<&[u8]> {
        self.buffers.get(b.index()).map(Vec::as_slice)
    }
}

/// Reads and validates `path`, refusing unsupported required extensions by name.
/// Why a binary glTF is cut short, if it is: its 12-byte header states the total length.
fn truncated_glb(bytes: &[u8]) -> Option<String> {
    if !bytes.starts_with(b"glTF") {
        return None;
    }
    let Some(length) = bytes.get(8..12) else {
        return Some(format!("the file is truncated: {} bytes, shorter than a GLB header", bytes.len()));
    };
    let declared = u32::from_le_bytes(length.try_into().ok()?) as usize;
    (bytes.len() < declared).then(|| {
        format!("the file is truncated: its header declares {declared} bytes, the file has {} (an interrupted copy or download?)", bytes.len())
    })
}

/// The largest glTF file, or external buffer, read: 1 GiB (a character with a film's
/// animation is tens of MB).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

pub(crate) fn load(path: &Path) -> Result<Loaded, GltfError> {
    let bytes = reprise_artifact::input::read(path, MAX_FILE_BYTES)?;
    let parse_err = |e: gltf::Error| GltfError::Parse { path: path.to_path_buf(), reason: e.to_string() };
    if let Some(reason) = truncated_glb(&bytes) {
        return Err(GltfError::Parse { path: path.to_path_buf(), reason });
    }
    let gltf::Gltf { document: doc, blob } = gltf::Gltf::from_slice_without_validation(&bytes).map_err(parse_err)?;

    if let Some(ext) = doc.extensions_required().find(|e| !extension_is_harmless(e)) {
        return Err(GltfError::UnsupportedExtension { path: path.to_path_buf(), extension: ext.to_string() });
    }
    // The crate's own validation (index bounds etc.), minus its complaint about required
    // extensions it was not compiled with: those were vetted above.
    // `gltf-json` 1.4 panics inside `validate` on some damaged files (an attribute naming
    // an accessor past the end): the callers contain it ([`GltfError::contain`]).
    let root = doc.as_json();
    let mut problems = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |p, e| {
        let p = p();
        if !p.as_str().starts_with("extensionsRequired") {
            problems.push(format!("{}: {e}", p.as_str()));
        }
    });
    if !problems.is_empty() {
        return Err(GltfError::Parse { path: path.to_path_buf(), reason: problems.join("; ") });
    }

    let buffers = doc.buffers().map(|b| load_buffer(path, &b, blob.as_deref())).collect::<Result<Vec<_>, _>>()?;
    check_accessor_sizes(path, &doc)?;
    Ok(Loaded { path: path.to_path_buf(), doc, buffers })
}

/// The most elements an accessor without a buffer view (all zeros, or sparse over zeros)
/// may declare: 16 Mi, far above any character's vertex or key count.
pub const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

/// Bounds every accessor's declared size by the data behind it, before anything is read:
/// the file's counts decide how much the readers allocate, so a count that its buffer
/// view cannot hold (a damaged or hand-edited file) is refused, naming the accessor, its
/// count and the bytes there are. Views must lie inside their buffers, and sparse
/// accessors may not hold more entries than elements.
fn check_accessor_sizes(path: &Path, doc: &gltf::Document) -> Result<(), GltfError> {
    let err = |what: String, reason: String| GltfError::Accessor { path: path.to_path_buf(), what, reason };
    for view in doc.views() {
        let (buffer, end) = (view.buffer(), view.offset().checked_add(view.length()));
        if end.is_none_or(|e| e > buffer.length()) {
            return Err(err(
                format!("bufferView {}", view.index()),
                format!(
                    "bytes {}..{} lie outside buffer {}, which has {} bytes",
                    view.offset(),
                    view.offset() as u128 + view.length() as u128,
                    buffer.index(),
                    buffer.length()
                ),
            ));
        }
    }
    for a in doc.accessors() {
        let what = format!("accessor {}", a.index());
        let (count, size) = (a.count(), a.size());
        match a.view() {
            Some(view) => {
                let stride = view.stride().unwrap_or(size).max(size);
                let need = count
                    .checked_sub(1)
                    .map_or(Some(0), |c| c.checked_mul(stride).and_then(|b| b.checked_add(size)))
                    .and_then(|b| b.checked_add(a.offset()));
                if need.is_none_or(|n| n > view.length()) {
                    return Err(err(
                        what,
                        format!(
                            "declares {count} elements of {size} bytes (from byte {}), but bufferView {} holds only {} \
                             bytes",
                            a.offset(),
                            view.index(),
                            view.length()
                        ),
                    ));
                }
            }
            None if count > MAX_VIEWLESS_ELEMENTS => {
                return Err(err(
                    what,
                    format!("declares {count} elements without a bufferView; at most {MAX_VIEWLESS_ELEMENTS} are read"),
                ));
            }
            None => {}
        }
        if let Some(sparse) = a.sparse() {
            if sparse.count() > count {
                return Err(err(what, format!("has {} sparse entries for {count} elements", sparse.count())));
            }
        }
    }
    Ok(())
}

fn load_buffer(path: &Path, b: &gltf::Buffer<'_>, blob: Option<&[u8]>) -> Result<Vec<u8>, GltfError> {
    let err = |reason: String| GltfError::Buffer { path: path.to_path_buf(), index: b.index(), reason };
    let mut data = match b.source() {
        gltf::buffer::Source::Bin => {
            blob.ok_or_else(|| err("refers to the GLB binary chunk, which is absent".into()))?.to_vec()
        }
        gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
            let (_, payload) =
                uri.split_once(";base64,").ok_or_else(|| err("data URI is not base64-encoded".into()))?;
            base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| err(format!("bad base64 in data URI: {e}")))?
        }
        gltf::buffer::Source::Uri(uri) => {
            if uri.contains("://") {
                return Err(err(format!("URI '{uri}' is not a local file (nothing is downloaded)")));
            }
            let file = path.parent().unwrap_or(Path::new(".")).join(uri);
            // A buffer is a regular file at least as long as it declares (checked before
            // anything is read: a `/dev/zero` or a FIFO would never end).
            let len = reprise_artifact::input::check_file(&file, MAX_FILE_BYTES).map_err(|e| err(e.to_string()))?;
            if len < b.length() as u64 {
                return Err(err(format!("declares {} bytes but {} has {len}", b.length(), file.display())));
            }
            reprise_artifact::input::read(&file, MAX_FILE_BYTES).map_err(|e| err(e.to_string()))?
        }
    };
    if data.len() < b.length() {
        return Err(err(format!("declares {} bytes but only {} are present", b.length(), data.len())));
    }
    data.truncate(b.length());
    Ok(data)
}

#[cfg(test)]
mod truncation_tests {
    #[test]
    fn truncated_glb_is_named() {
        let mut glb = b"glTF".to_vec();
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&1000u32.to_le_bytes());
        glb.extend_from_slice(&[0; 20]);
        assert!(super::truncated_glb(&glb).unwrap().contains("declares 1000 bytes, the file has 32"));
        assert!(super::truncated_glb(b"glTF\x02").unwrap().contains("shorter than a GLB header"));
        assert_eq!(super::truncated_glb(b"{\"asset\": {}}"), None);
    }
}
