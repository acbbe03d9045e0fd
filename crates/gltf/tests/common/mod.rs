//! Shared test helpers: the real datasets beside the repository, and tiny synthetic glTFs.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::{json, Value};

/// `../shared/datasets/<rel>` beside the repository. `None` (after printing a SKIPPED line)
/// when the datasets directory is absent; panics instead when `CI` is set.
pub fn dataset(rel: &str, test: &str) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets");
    if !root.is_dir() {
        if std::env::var_os("CI").is_some() {
            panic!("{test}: ../shared/datasets not found at {} and CI is set", root.display());
        }
        eprintln!("SKIPPED {test}: ../shared/datasets not found");
        return None;
    }
    let p = root.join(rel);
    assert!(p.is_file(), "{test}: {} is missing from the datasets", p.display());
    Some(p)
}

/// Builds the binary buffer and accessors of a small glTF.
#[derive(Default)]
pub struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Adds float data of glTF type `ty` (`SCALAR`, `VEC3`, `VEC4`); returns the accessor index.
    pub fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let width = match ty {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => panic!("type {ty}"),
        };
        let offset = self.bin.len();
        for x in data {
            self.bin.extend_from_slice(&x.to_le_bytes());
        }
        self.views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
        let (mut min, mut max) = (vec![f32::INFINITY; width], vec![f32::NEG_INFINITY; width]);
        for (i, &x) in data.iter().enumerate() {
            min[i % width] = min[i % width].min(x);
            max[i % width] = max[i % width].max(x);
        }
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1, "componentType": 5126, "count": data.len() / width,
            "type": ty, "min": min, "max": max
        }));
        self.accessors.len() - 1
    }

    /// Completes `doc` (asset, buffers, bufferViews, accessors) and writes it as a `.gltf`
    /// with the buffer in a base64 `data:` URI.
    pub fn write(self, dir: &Path, name: &str, mut doc: Value) -> PathBuf {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        doc["asset"] = json!({"version": "2.0"});
        doc["buffers"] = json!([{"byteLength": self.bin.len(), "uri": uri}]);
        doc["bufferViews"] = Value::Array(self.views);
        doc["accessors"] = Value::Array(self.accessors);
        let path = dir.join(name);
        std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
        path
    }
}

/// Lower-case alphanumerics of a node name after dropping exporter de-duplication suffixes
/// (`#<index>` from this crate, `_<n>` from three.js): `Foot.L` ≅ `FootL`, `Torso#10` ≅ `Torso_1`.
pub fn normalise_node(name: &str) -> String {
    let mut s = name;
    if let Some((head, tail)) = s.rsplit_once('#') {
        if tail.chars().all(|c| c.is_ascii_digit()) {
            s = head;
        }
    }
    if let Some((head, tail)) = s.rsplit_once('_') {
        if !tail.is_empty() && tail.chars().all(|c| c.is_ascii_digit()) {
            s = head;
        }
    }
    s.chars().filter(char::is_ascii_alphanumeric).map(|c| c.to_ascii_lowercase()).collect()
}

/// Splits a joint control name `<node>.<rx|ry|rz|tx|ty|tz|sx|sy|sz>` into node and channel.
pub fn split_joint(name: &str) -> (&str, &str) {
    name.rsplit_once('.').expect("joint control name has a channel suffix")
}
