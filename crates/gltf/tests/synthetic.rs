//! Small hand-built glTF files with known answers, and the error cases.

mod common;

use std::f64::consts::PI;

use common::Builder;
use glam::{DQuat, DVec3};
use reprise_gltf::{ingest, GltfError, GltfRig};
use serde_json::json;

/// One triangle on node "tri" (rest translation (1, 0, 0)) with one morph target "smile";
/// animation "spin": rotation 0° → 90° about z and weight 0 → 1 over one second, LINEAR.
fn triangle_file(dir: &std::path::Path, interpolation: &str) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let delta = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC3");
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let q90 = DQuat::from_rotation_z(PI / 2.0);
    let (rot, weights) = if interpolation == "CUBICSPLINE" {
        // (in-tangent, value, out-tangent) per key, zero tangents
        let z = [0.0f32; 4];
        let q = [q90.x as f32, q90.y as f32, q90.z as f32, q90.w as f32];
        let rot = b.floats(&[z, [0.0, 0.0, 0.0, 1.0], z, z, q, z].concat(), "VEC4");
        let weights = b.floats(&[0.0, 0.0, 0.0, 0.0, 1.0, 0.0], "SCALAR");
        (rot, weights)
    } else {
        let rot = b.floats(&[0.0, 0.0, 0.0, 1.0, q90.x as f32, q90.y as f32, q90.z as f32, q90.w as f32], "VEC4");
        (rot, b.floats(&[0.0, 1.0], "SCALAR"))
    };
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "tri", "mesh": 0, "translation": [1.0, 0.0, 0.0]}],
        "meshes": [{
            "primitives": [{"attributes": {"POSITION": pos}, "targets": [{"POSITION": delta}]}],
            "weights": [0.0],
            "extras": {"targetNames": ["smile"]}
        }],
        "animations": [{
            "name": "spin",
            "samplers": [
                {"input": times, "output": rot, "interpolation": interpolation},
                {"input": times, "output": weights, "interpolation": interpolation}
            ],
            "channels": [
                {"sampler": 0, "target": {"node": 0, "path": "rotation"}},
                {"sampler": 1, "target": {"node": 0, "path": "weights"}}
            ]
        }]
    });
    b.write(dir, &format!("tri_{interpolation}.gltf"), doc)
}

#[test]
fn synthetic_triangle_ingest_and_rig_known_answers() {
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(dir.path(), "LINEAR");
    let curves = ingest(&path, 4.0).unwrap();
    let names: Vec<&str> = curves.controls.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["tri.rx", "tri.ry", "tri.rz", "tri.morph.smile"]);
    assert_eq!(curves.controls[3].group, "morphs");
    assert_eq!(curves.controls[3].unit, "weight");
    let clip = curves.clip("spin").unwrap();
    assert_eq!(clip.frames, 5);
    // frame 2 = t 0.5 s: 45° about z, weight ½
    let f2 = curves.frame(clip, 2);
    assert!((f2[2] - PI / 4.0).abs() < 1e-6 && f2[0].abs() < 1e-9 && f2[1].abs() < 1e-9, "{f2:?}");
    assert!((f2[3] - 0.5).abs() < 1e-6);
    assert!((curves.controls[2].max - PI / 2.0).abs() < 1e-6 && curves.controls[2].min.abs() < 1e-9);

    let rig = GltfRig::open(&path).unwrap();
    assert_eq!(rig.control_names(), names.as_slice());
    assert_eq!(rig.vertex_count(), 3);
    assert_eq!(rig.triangles(), &[[0, 1, 2]]);
    let out = rig.evaluate_to_vec(f2);
    let r = DQuat::from_rotation_z(PI / 4.0);
    for (v, p) in [DVec3::ZERO, DVec3::X, DVec3::Y].into_iter().enumerate() {
        let want = DVec3::X + r * (p + 0.5 * DVec3::Z);
        assert!(DVec3::from_slice(&out[3 * v..]).distance(want) < 1e-6, "vertex {v}");
    }
}

#[test]
fn synthetic_cubic_spline_ingest() {
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(dir.path(), "CUBICSPLINE");
    let curves = ingest(&path, 4.0).unwrap();
    let clip = curves.clip("spin").unwrap();
    // zero tangents: smoothstep. t = ¼ → s = 0.15625 for the weight; the quaternion is the
    // normalised blend (1 − s)·q0 + s·q1.
    let f1 = curves.frame(clip, 1);
    assert!((f1[3] - 0.15625).abs() < 1e-6, "{f1:?}");
    let s = 0.15625;
    let q = (DQuat::IDENTITY * (1.0 - s) + DQuat::from_rotation_z(PI / 2.0) * s).normalize();
    let angle = 2.0 * q.z.atan2(q.w);
    assert!((f1[2] - angle).abs() < 1e-6, "{} vs {angle}", f1[2]);
}

/// A full spin sampled once a second: the rotation vector grows through 350° instead of
/// wrapping to −10°.
#[test]
fn synthetic_rotation_stays_continuous_through_350_degrees() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let times: Vec<f32> = (0..=7).map(|k| k as f32).collect();
    let t = b.floats(&times, "SCALAR");
    let quats: Vec<f32> = (0..=7)
        .flat_map(|k| {
            let q = DQuat::from_rotation_y((50.0 * k as f64).to_radians());
            [q.x as f32, q.y as f32, q.z as f32, q.w as f32]
        })
        .collect();
    let r = b.floats(&quats, "VEC4");
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "spinner", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "animations": [{
            "samplers": [{"input": t, "output": r}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}]
        }]
    });
    let path = b.write(dir.path(), "spin.gltf", doc);
    let curves = ingest(&path, 2.0).unwrap();
    let clip = &curves.clips[0];
    assert_eq!(clip.name, "animation0");
    assert_eq!(clip.frames, 15);
    for f in 0..clip.frames {
        let ry = curves.frame(clip, f)[1];
        assert!((ry - (25.0 * f as f64).to_radians()).abs() < 1e-5, "frame {f}: {ry}");
    }
}

#[test]
fn unsupported_required_extension_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("draco.gltf");
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_draco_mesh_compression"],
        "extensionsRequired": ["KHR_draco_mesh_compression"]
    });
    std::fs::write(&path, doc.to_string()).unwrap();
    let err = ingest(&path, 24.0).unwrap_err();
    assert!(matches!(err, GltfError::UnsupportedExtension { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("KHR_draco_mesh_compression") && msg.contains("draco.gltf"), "{msg}");
    let err = GltfRig::open(&path).unwrap_err().to_string();
    assert!(err.contains("KHR_draco_mesh_compression"), "{err}");
}

#[test]
fn harmless_required_extension_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(dir.path(), "LINEAR");
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_unlit"]);
    doc["extensionsRequired"] = json!(["KHR_materials_unlit"]);
    std::fs::write(&path, doc.to_string()).unwrap();
    assert_eq!(ingest(&path, 4.0).unwrap().clips.len(), 1);
}

#[test]
fn no_animations_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "still", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]
    });
    let path = b.write(dir.path(), "still.gltf", doc);
    let msg = ingest(&path, 24.0).unwrap_err().to_string();
    assert!(msg.contains("no animations: nothing to ingest") && msg.contains("still.gltf"), "{msg}");
    // and with neither skins nor morph targets there is no rig either
    let msg = GltfRig::open(&path).unwrap_err().to_string();
    assert!(msg.contains("no skins or morph targets: nothing a control can move"), "{msg}");
}

#[test]
fn bad_sampler_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let t = b.floats(&[0.0, 1.0, 2.0], "SCALAR");
    let r = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], "VEC4"); // 2 outputs for 3 keys
    let doc = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "n", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "animations": [{"name": "broken", "samplers": [{"input": t, "output": r}],
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}]}]
    });
    let path = b.write(dir.path(), "broken.gltf", doc);
    let msg = ingest(&path, 24.0).unwrap_err().to_string();
    assert!(msg.contains("broken.gltf") && msg.contains("animation 'broken'") && msg.contains("sampler 0"), "{msg}");
}

#[test]
fn missing_file_and_bad_fps() {
    let msg = ingest(std::path::Path::new("/nonexistent/x.glb"), 24.0).unwrap_err().to_string();
    assert!(msg.contains("/nonexistent/x.glb"), "{msg}");
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(dir.path(), "LINEAR");
    assert!(matches!(ingest(&path, 0.0), Err(GltfError::BadFps { .. })));
}

/// A buffer `uri` naming `/dev/zero` with a huge `byteLength` drove ingest to 23.8 GB; a
/// device (or a FIFO, a directory) is refused by name before anything is read.
#[cfg(unix)]
#[test]
fn a_buffer_that_is_a_device_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("zero.gltf");
    let doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "/dev/zero", "byteLength": 100_000_000_000u64}],
        "bufferViews": [{"buffer": 0, "byteLength": 16}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "SCALAR"}],
        "nodes": [{"name": "n"}],
        "scenes": [{"nodes": [0]}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
                        "samplers": [{"input": 0, "output": 0}]}]
    });
    std::fs::write(&path, doc.to_string()).unwrap();
    let e = ingest(&path, 24.0).err().map(|e| e.to_string()).unwrap();
    assert!(e.contains("buffer 0: /dev/zero: a character device, not a regular file"), "{e}");
}
