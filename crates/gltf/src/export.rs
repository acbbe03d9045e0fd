//! Writing rig-control curves back into a character: a copy of a `.glb` with each clip
//! added as a named animation, playable in Blender or any glTF viewer.
//!
//! Every control of the file's layout (see [`crate::controls`]) becomes a channel: for a
//! node with rotation controls, `rotation` keys $R = R_{rest}\exp([v]_\times)$ (unit
//! quaternions); translations `rest + t`; scales `rest · s` (or `s` where the rest component
//! is 0); morph weights as they are. Keys are at the clip's frame times `frame / fps`,
//! `LINEAR` (the reader slerps rotations), Float32 as glTF requires. Controls a clip does
//! not carry (masked or unmodelled ones) hold their default. Re-ingesting the file gives
//! back the clip's curves to Float32 precision, because ingest samples at those same times
//! and inverts each mapping.
//!
//! Only GLB files whose data sit in the binary chunk are written (the common case for
//! characters); the original JSON is kept as is, with accessors, buffer views and
//! animations appended and the buffer's length updated. The output is written atomically.

use std::path::Path;

use glam::{DQuat, DVec3};
use serde_json::{json, Value};

use crate::controls::layout;
use crate::error::GltfError;
use crate::load::load;
use crate::rotation;
use crate::scene::SceneGraph;

/// One clip to add.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportClip {
    /// The animation's name.
    pub name: String,
    /// Frames per second of the rows.
    pub fps: f64,
    /// The names of the columns of `values`.
    pub controls: Vec<String>,
    /// Row-major `frames × controls`.
    pub values: Vec<f64>,
}

const GLB_MAGIC: u32 = 0x4654_6c67;
const CHUNK_JSON: u32 = 0x4e4f_534a;
const CHUNK_BIN: u32 = 0x004e_4942;

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    b.get(at..at + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// The JSON and binary chunks of a GLB.
fn split_glb(path: &Path, bytes: &[u8]) -> Result<(Value, Vec<u8>), GltfError> {
    let bad = |reason: &str| GltfError::Parse { path: path.to_path_buf(), reason: format!("export: {reason}") };
    if u32_at(bytes, 0) != Some(GLB_MAGIC) {
        return Err(bad("only binary glTF (.glb) files can be exported into"));
    }
    let json_len = u32_at(bytes, 12).ok_or_else(|| bad("truncated header"))? as usize;
    if u32_at(bytes, 16) != Some(CHUNK_JSON) || bytes.len() < 20 + json_len {
        return Err(bad("the first chunk is not JSON"));
    }
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).map_err(|e| bad(&e.to_string()))?;
    let at = 20 + json_len;
    let bin = match (u32_at(bytes, at), u32_at(bytes, at + 4)) {
        (Some(len), Some(CHUNK_BIN)) if bytes.len() >= at + 8 + len as usize => {
            bytes[at + 8..at + 8 + len as usize].to_vec()
        }
        _ => return Err(bad("no binary chunk")),
    };
    let buffers = json.get("buffers").and_then(Value::as_array).map_or(0, Vec::len);
    if buffers != 1 || json["buffers"][0].get("uri").is_some() {
        return Err(bad("the file's data must be one buffer in the binary chunk"));
    }
    Ok((json, bin))
}

/// The GLB bytes of `json` and `bin`.
fn join_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).expect("JSON serialises");
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    for v in [GLB_MAGIC, 2, total as u32, j.len() as u32, CHUNK_JSON] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&b);
    out
}

/// Appends Float32 data as a buffer view and an accessor; returns the accessor index.
fn push_accessor(json: &mut Value, bin: &mut Vec<u8>, data: &[f32], kind: &str, count: usize, bounds: bool) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let offset = bin.len();
    data.iter().for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    let views = json["bufferViews"].as_array_mut().expect("bufferViews is an array");
    views.push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4 }));
    let view = views.len() - 1;
    let mut acc = json!({ "bufferView": view, "componentType": 5126, "count": count, "type": kind });
    if bounds {
        let (lo, hi) = data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        acc["min"] = json!([lo]);
        acc["max"] = json!([hi]);
    }
    let accessors = json["accessors"].as_array_mut().expect("accessors is an array");
    accessors.push(acc);
    accessors.len() - 1
}

/// Writes a copy of `src` to `dst` with `clips` added as animations (an existing
/// animation of the same name is an error).
///
/// `marker` goes to `asset.extras.reprise`: what wrote the file (see
/// `reprise_artifact::provenance::output_marker`), so a rerun knows it as its own.
pub fn export(src: &Path, dst: &Path, clips: &[ExportClip], marker: &str) -> Result<(), GltfError> {
    GltfError::contain(src, || export_into(src, dst, clips, marker))
}

fn export_into(src: &Path, dst: &Path, clips: &[ExportClip], marker: &str) -> Result<(), GltfError> {
    let l = load(src)?;
    let graph = SceneGraph::from_loaded(&l)?;
    let lay = layout(&l, &graph);
    let bytes = reprise_artifact::input::read(src, crate::load::MAX_FILE_BYTES)?;
    let (mut json, mut bin) = split_glb(src, &bytes)?;
    for key in ["bufferViews", "accessors", "animations"] {
        if json.get(key).is_none() {
            json[key] = json!([]);
        }
    }
    let bad = |reason: String| GltfError::Parse { path: src.to_path_buf(), reason: format!("export: {reason}") };
    let defaults = lay.defaults();
    for clip in clips {
        if json["animations"].as_array().is_some_and(|a| a.iter().any(|x| x["name"] == clip.name.as_str())) {
            return Err(bad(format!("the file already has an animation named `{}`", clip.name)));
        }
        let c = clip.controls.len();
        let fps_ok = clip.fps.is_finite() && clip.fps > 0.0;
        if c == 0 || !clip.values.len().is_multiple_of(c) || clip.values.is_empty() || !fps_ok {
            return Err(bad(format!("clip `{}`: no frames, or values not frames × controls", clip.name)));
        }
        let frames = clip.values.len() / c;
        // Column of each layout control in the clip (None: hold the default).
        let col: Vec<Option<usize>> =
            lay.infos.iter().map(|info| clip.controls.iter().position(|n| n == &info.name)).collect();
        let value = |f: usize, k: usize| col[k].map_or(defaults[k], |j| clip.values[f * c + j]);
        let times: Vec<f32> = (0..frames).map(|f| (f as f64 / clip.fps) as f32).collect();
        let input = push_accessor(&mut json, &mut bin, &times, "SCALAR", frames, true);
        let (mut samplers, mut channels) = (vec![], vec![]);
        let mut add =
            |json: &mut Value, bin: &mut Vec<u8>, node: usize, path: &str, kind: &str, data: Vec<f32>, count: usize| {
                let output = push_accessor(json, bin, &data, kind, count, false);
                samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
                channels.push(json!({ "sampler": samplers.len() - 1, "target": { "node": node, "path": path } }));
            };
        for nc in &lay.per_node {
            let rest = &graph.nodes[nc.node];
            if let Some(b) = nc.rotation {
                let data = (0..frames)
                    .flat_map(|f| {
                        let v = DVec3::new(value(f, b), value(f, b + 1), value(f, b + 2));
                        let q: DQuat = (rest.rotation * rotation::exp(v)).normalize();
                        [q.x as f32, q.y as f32, q.z as f32, q.w as f32]
                    })
                    .collect();
                add(&mut json, &mut bin, nc.node, "rotation", "VEC4", data, frames);
            }
            if let Some(b) = nc.translation {
                let data = (0..frames)
                    .flat_map(|f| (0..3).map(move |a| (rest.translation[a] + value(f, b + a)) as f32))
                    .collect::<Vec<_>>();
                add(&mut json, &mut bin, nc.node, "translation", "VEC3", data, frames);
            }
            if let Some(b) = nc.scale {
                let data = (0..frames)
                    .flat_map(|f| {
                        (0..3).map(move |a| {
                            let r = rest.scale[a];
                            (if r != 0.0 { r * value(f, b + a) } else { value(f, b + a) }) as f32
                        })
                    })
                    .collect::<Vec<_>>();
                add(&mut json, &mut bin, nc.node, "scale", "VEC3", data, frames);
            }
            if let Some((b, count)) = nc.morph {
                let data =
                    (0..frames).flat_map(|f| (0..count).map(move |k| value(f, b + k) as f32)).collect::<Vec<_>>();
                add(&mut json, &mut bin, nc.node, "weights", "SCALAR", data, frames * count);
            }
        }
        json["animations"].as_array_mut().expect("animations is an array").push(json!({
            "name": clip.name, "samplers": samplers, "channels": channels
        }));
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    json["buffers"][0]["byteLength"] = json!(bin.len());
    if json["asset"].get("extras").is_none_or(serde_json::Value::is_object) {
        json["asset"]["extras"]["reprise"] = json!(marker);
    }
    let out = join_glb(&json, &bin);
    reprise_artifact::table::write_atomic(dst, |file| {
        use std::io::Write as _;
        file.write_all(&out).map_err(|e| reprise_artifact::ArtifactError::io(dst, e))
    })
    .map_err(|e| GltfError::Parse { path: dst.to_path_buf(), reason: e.to_string() })
}
