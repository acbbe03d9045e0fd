//! Generative tests of the glTF reader: mutated copies of a small valid character — as
//! `.gltf` text with a base64 buffer and as binary `.glb` — ingest (and open as a rig,
//! and evaluate at its defaults) or fail with a [`GltfError`] naming the file; never a
//! panic, an allocation sized by a damaged count, or a hang. The nasty cases found are
//! kept below as ordinary tests.

mod common;

use std::path::PathBuf;

use common::Builder;
use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated, mutated_text, within, LIMIT};
use reprise_gltf::{ingest, GltfRig};
use serde_json::json;

const TOKENS: &[&str] = &[
    "\"count\": 4294967295",
    "\"byteLength\": 1e30",
    "\"byteOffset\": 18446744073709551615",
    "\"byteStride\": 252",
    "\"input\": 99",
    "\"node\": 7",
    "\"mesh\": 3",
    "\"sparse\": {\"count\": 1000000000}",
    "\"CUBICSPLINE\"",
    "\"STEP\"",
    "\"scale\"",
    "\"translation\"",
    "\"weights\"",
    "\"rotation\"",
    "\"children\": [0]",
    "[",
    "]",
    "{",
    "}",
    ":",
    "null",
    "-1",
    "1e400",
    "\"extensionsRequired\": [\"KHR_draco_mesh_compression\"]",
    "glTF",
    "JSON",
    "BIN\0",
];

/// The `.gltf` text of a triangle with a morph target on a node with a child, and one
/// animation of rotation, translation, scale and weights (LINEAR and STEP keys).
fn gltf_text() -> String {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let delta = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let times = b.floats(&[0.0, 0.5, 1.0], "SCALAR");
    let rot = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.38, 0.92, 0.0, 0.0, 0.71, 0.71], "VEC4");
    let tr = b.floats(&[1.0, 0.0, 0.0, 1.0, 0.5, 0.0, 1.0, 1.0, 0.0], "VEC3");
    let w = b.floats(&[0.0, 0.5, 1.0], "SCALAR");
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"name": "tri", "mesh": 0, "translation": [1.0, 0.0, 0.0], "children": [1]},
            {"name": "child", "scale": [1.0, 2.0, 1.0]}
        ],
        "meshes": [{
            "primitives": [{"attributes": {"POSITION": pos}, "targets": [{"POSITION": delta}]}],
            "weights": [0.0],
            "extras": {"targetNames": ["smile"]}
        }],
        "animations": [{
            "name": "spin",
            "samplers": [
                {"input": times, "output": rot, "interpolation": "LINEAR"},
                {"input": times, "output": tr, "interpolation": "STEP"},
                {"input": times, "output": w, "interpolation": "LINEAR"},
                {"input": times, "output": tr, "interpolation": "LINEAR"}
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 1, "target": {"node": 1, "path": "translation"}},
                {"sampler": 2, "target": {"node": 0, "path": "weights"}},
                {"sampler": 3, "target": {"node": 1, "path": "scale"}}
            ]
        }]
    });
    std::fs::read_to_string(b.write(dir.path(), "t.gltf", doc)).unwrap()
}

/// The same character as a `.glb`: the JSON chunk with the buffer moved to the BIN chunk.
fn glb_bytes() -> Vec<u8> {
    use base64::Engine as _;
    let mut doc: serde_json::Value = serde_json::from_str(&gltf_text()).unwrap();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
    let mut bin = base64::engine::general_purpose::STANDARD.decode(uri.split_once(',').unwrap().1).unwrap();
    doc["buffers"][0] = json!({"byteLength": bin.len()});
    let mut text = serde_json::to_vec(&doc).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    for v in [2, total as u32, text.len() as u32, 0x4E4F_534A] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

/// Ingests `bytes` as `name` at 30 fps, then opens it as a rig and evaluates the rest
/// pose; every error must name the file.
fn check(name: &'static str, bytes: Vec<u8>) {
    within(LIMIT, move || {
        let dir = tempfile::tempdir().unwrap();
        let path: PathBuf = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let named = |e: reprise_gltf::GltfError| {
            let msg = e.to_string();
            assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        };
        if let Err(e) = ingest(&path, 30.0) {
            named(e);
        }
        match GltfRig::open(&path) {
            Ok(rig) => {
                let _ = rig.evaluate_to_vec(&rig.default_controls());
            }
            Err(e) => named(e),
        }
    });
}

proptest! {
    #![proptest_config(config(150))]

    #[test]
    fn mutated_gltf_text(text in mutated_text(&gltf_text(), TOKENS)) {
        check("m.gltf", text.into_bytes());
    }

    #[test]
    fn mutated_glb(bytes in mutated(glb_bytes(), TOKENS)) {
        check("m.glb", bytes);
    }
}

/// The seeds ingest.
#[test]
fn the_seed_files_ingest() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in [("t.gltf", gltf_text().into_bytes()), ("t.glb", glb_bytes())] {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(ingest(&path, 30.0).unwrap().clips[0].frames, 31, "{name}");
        GltfRig::open(&path).unwrap();
    }
}

/// An error message for `text` as a `.gltf`.
fn error_of(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.gltf");
    std::fs::write(&path, text).unwrap();
    let e = ingest(&path, 30.0).expect_err("a bad file").to_string();
    assert!(e.contains("bad.gltf"), "{e}");
    e
}

/// Found: a key time of 1e30 s asked the resampler for 3·10³¹ frames (abort on allocation).
#[test]
fn key_time_typo_is_bounded_before_allocating() {
    let mut doc: serde_json::Value = serde_json::from_str(&gltf_text()).unwrap();
    doc["accessors"][2]["max"] = json!([1e30]);
    // The key times live in the buffer: rewrite the third time to 1e30.
    use base64::Engine as _;
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
    let mut bin = base64::engine::general_purpose::STANDARD.decode(uri.split_once(',').unwrap().1).unwrap();
    let off = doc["bufferViews"][2]["byteOffset"].as_u64().unwrap() as usize + 8;
    bin[off..off + 4].copy_from_slice(&1e30f32.to_le_bytes());
    let enc = base64::engine::general_purpose::STANDARD.encode(&bin);
    doc["buffers"][0]["uri"] = json!(format!("data:application/octet-stream;base64,{enc}"));
    let e = error_of(&doc.to_string());
    assert!(
        e.contains("animation 'spin' lasts 1000000015047466200000000000000 s")
            || e.contains("more than the limit of 1000000"),
        "{e}"
    );
    assert!(e.contains("ingest --max-frames"), "{e}");
}

/// A count its buffer view cannot hold is refused before reading, naming the accessor.
#[test]
fn accessor_count_beyond_its_view_is_refused() {
    let mut doc: serde_json::Value = serde_json::from_str(&gltf_text()).unwrap();
    doc["accessors"][0]["count"] = json!(4_000_000_000u64);
    let e = error_of(&doc.to_string());
    assert!(
        e.contains("accessor 0: declares 4000000000 elements of 12 bytes") && e.contains("holds only 36 bytes"),
        "{e}"
    );
}

/// A buffer view reaching past its buffer is refused, naming both.
#[test]
fn view_outside_its_buffer_is_refused() {
    let mut doc: serde_json::Value = serde_json::from_str(&gltf_text()).unwrap();
    doc["bufferViews"][1]["byteOffset"] = json!(1_000_000);
    let e = error_of(&doc.to_string());
    assert!(e.contains("bufferView 1: bytes 1000000..1000036 lie outside buffer 0"), "{e}");
}

/// Found: `gltf-json`'s own validation panicked on an animation path it does not know
/// ("attempted to unwrap an invalid item") and on a mesh attribute naming an accessor past
/// the end (index out of bounds); both are now parse errors naming the file.
#[test]
fn library_panics_on_damaged_files_are_parse_errors() {
    let text = gltf_text().replacen("\"rotation\"\n", "\"rotauion\"\n", 1);
    assert!(text.contains("rotauion"));
    let e = error_of(&text);
    assert!(e.contains("not a valid glTF 2.0 file") || e.contains("rotauion"), "{e}");
    let mut doc: serde_json::Value = serde_json::from_str(&gltf_text()).unwrap();
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99);
    let e = error_of(&doc.to_string());
    assert!(e.contains("not a valid glTF 2.0 file"), "{e}");
}
