//! Baked tracks as a glTF 2.0 binary (`.glb`): one mesh (the mean mesh, the triangles, the
//! morph targets), one node per track using it, placed side by side along +x, and one
//! animation whose channels drive each node's morph weights (linear interpolation, one key
//! per frame). Positions are 32-bit floats in the rig's length unit.

use serde_json::{json, Value};

use crate::bake::Baked;

/// The glTF component type of 32-bit floats.
const FLOAT: u32 = 5126;
/// Of 32-bit unsigned integers.
const UNSIGNED_INT: u32 = 5125;
/// Buffer-view targets.
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer and the JSON views and accessors into it.
#[derive(Default)]
struct Buffer {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    /// Appends `values` as a view and an accessor of `kind` (`SCALAR`, `VEC3`); returns the
    /// accessor's index. `bounds` adds the per-component min and max.
    fn floats(&mut self, values: &[f32], kind: &str, target: Option<u32>, bounds: bool) -> usize {
        let width = if kind == "VEC3" { 3 } else { 1 };
        let mut acc = json!({"componentType": FLOAT, "count": values.len() / width, "type": kind});
        if bounds {
            let (mut lo, mut hi) = (vec![f32::INFINITY; width], vec![f32::NEG_INFINITY; width]);
            for c in values.chunks_exact(width) {
                for j in 0..width {
                    lo[j] = lo[j].min(c[j]);
                    hi[j] = hi[j].max(c[j]);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.push(values.iter().flat_map(|v| v.to_le_bytes()).collect(), target, acc)
    }

    fn indices(&mut self, values: &[u32]) -> usize {
        let acc = json!({"componentType": UNSIGNED_INT, "count": values.len(), "type": "SCALAR"});
        self.push(values.iter().flat_map(|v| v.to_le_bytes()).collect(), Some(ELEMENT_ARRAY_BUFFER), acc)
    }

    fn push(&mut self, bytes: Vec<u8>, target: Option<u32>, mut accessor: Value) -> usize {
        let mut view = json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bytes.extend(bytes);
        self.views.push(view);
        accessor["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }
}

/// The `.glb` bytes of `baked` with `triangles`, the tracks named by `names` (one per
/// track), played at `fps`, in an animation called `animation`.
///
/// # Panics
/// When `names` does not name every track (a caller's bug, not data).
pub fn write(baked: &Baked, triangles: &[[u32; 3]], names: &[String], fps: f64, animation: &str) -> Vec<u8> {
    assert_eq!(names.len(), baked.weights.len(), "one name per track");
    let (k, m) = (baked.k(), 3 * baked.vertices);
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let mut buf = Buffer::default();
    let position = buf.floats(&f32s(&baked.mean), "VEC3", Some(ARRAY_BUFFER), true);
    let indices = buf.indices(&triangles.iter().flatten().copied().collect::<Vec<_>>());
    let targets: Vec<Value> = baked
        .targets
        .chunks_exact(m)
        .map(|t| json!({"POSITION": buf.floats(&f32s(t), "VEC3", Some(ARRAY_BUFFER), true)}))
        .collect();
    let mut primitive = json!({"attributes": {"POSITION": position}, "indices": indices, "mode": 4});
    let mut mesh = json!({"name": "baked", "primitives": [primitive.clone()]});
    if k > 0 {
        primitive["targets"] = json!(targets);
        mesh = json!({"name": "baked", "primitives": [primitive], "weights": vec![0.0; k]});
    }
    // Side by side: each track one and a quarter mesh widths to the right of the last.
    let (lo, hi) =
        baked.mean.chunks_exact(3).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v[0]), b.max(v[0])));
    let step = 1.25 * (hi - lo).max(1e-9);
    let nodes: Vec<Value> = names
        .iter()
        .enumerate()
        .map(|(t, name)| json!({"name": name, "mesh": 0, "translation": [step * t as f64, 0.0, 0.0]}))
        .collect();
    let mut root = json!({
        "asset": {"version": "2.0", "generator": "reprise (baked mesh animation)"},
        "scene": 0,
        "scenes": [{"nodes": (0..names.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [mesh],
    });
    let frames = baked.weights.first().map_or(0, |w| w.len() / k.max(1));
    if k > 0 && frames > 0 {
        let times: Vec<f32> = (0..frames).map(|i| (i as f64 / fps) as f32).collect();
        let input = buf.floats(&times, "SCALAR", None, true);
        let samplers: Vec<Value> = baked
            .weights
            .iter()
            .map(|w| json!({"input": input, "output": buf.floats(&f32s(w), "SCALAR", None, false), "interpolation": "LINEAR"}))
            .collect();
        let channels: Vec<Value> =
            (0..names.len()).map(|t| json!({"sampler": t, "target": {"node": t, "path": "weights"}})).collect();
        root["animations"] = json!([{"name": animation, "samplers": samplers, "channels": channels}]);
    }
    root["buffers"] = json!([{"byteLength": buf.bytes.len()}]);
    root["bufferViews"] = json!(buf.views);
    root["accessors"] = json!(buf.accessors);
    container(&root.to_string(), buf.bytes)
}

/// The GLB container: a 12-byte header, the JSON chunk (padded with spaces) and the binary
/// chunk (padded with zeros), each to a multiple of 4 bytes.
fn container(json: &str, mut bin: Vec<u8>) -> Vec<u8> {
    let mut text = json.as_bytes().to_vec();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::bake;

    #[test]
    fn a_glb_reads_back_with_its_animation() {
        // A triangle whose first vertex moves up and down, in two tracks.
        let frame = |t: f64| vec![0.0, t.sin(), 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let a: Vec<f64> = (0..12).flat_map(|i| frame(f64::from(i) * 0.5)).collect();
        let b: Vec<f64> = (0..12).flat_map(|i| frame(f64::from(i) * 0.5 + 1.0)).collect();
        let baked = bake(&[&a, &b], 3, 4).unwrap();
        assert_eq!(baked.k(), 1);
        let bytes = write(&baked, &[[0, 1, 2]], &["ours".into(), "known".into()], 24.0, "take");
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize, bytes.len());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.glb");
        std::fs::write(&path, &bytes).unwrap();
        let curves = reprise_gltf::ingest(&path, 24.0).unwrap();
        assert_eq!(curves.clips.len(), 1);
        let clip = &curves.clips[0];
        assert_eq!(clip.name, "take");
        assert_eq!(clip.frames, 12);
        // Each node's morph weight is a control; frame 3 of track "known" decodes to its mesh.
        let col = curves.controls.iter().position(|c| c.name.starts_with("known") && c.name.contains("morph")).unwrap();
        let w = clip.values[3 * curves.controls.len() + col];
        let y = baked.mean[1] + w * baked.targets[1];
        assert!((y - (1.5f64 + 1.0).sin()).abs() < 1e-5, "{y}");
    }
}
