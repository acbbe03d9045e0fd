//! Export round trip: clips written into a copy of a character re-ingest to the same
//! curves (RobotExpressive, read in place from `../shared`).

mod common;

use common::dataset;
use reprise_gltf::{export, ingest, ExportClip};

/// Two new clips — a real one's curves with every control shifted, and the rest pose —
/// come back from the exported file with Float32 precision; the original clips are
/// untouched; a second export of the same name is refused; a JSON .gltf is refused.
#[test]
fn exported_clips_reingest_to_the_same_curves() {
    let Some(path) = dataset("robot_expressive/RobotExpressive.glb", "exported_clips_reingest_to_the_same_curves")
    else {
        return;
    };
    let before = ingest(&path, 24.0).unwrap();
    let wave = before.clip("Wave").unwrap();
    let names: Vec<String> = before.controls.iter().map(|c| c.name.clone()).collect();
    let n = names.len();
    // Perturb rotations a little so that the clip is new, keep it in the principal range.
    let values: Vec<f64> =
        wave.values.iter().enumerate().map(|(i, v)| v + 0.01 * ((i % n) as f64 / n as f64)).collect();
    let clips = vec![
        ExportClip { name: "reprise_wave".into(), fps: 24.0, controls: names.clone(), values: values.clone() },
        // Only two columns given: the rest hold their defaults.
        ExportClip { name: "reprise_rest".into(), fps: 24.0, controls: names[..2].to_vec(), values: vec![0.0; 2 * 5] },
    ];
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("robot_with_clips.glb");
    export(&path, &out, &clips, "reprise:stage=test").unwrap();
    let after = ingest(&out, 24.0).unwrap();
    assert_eq!(after.clips.len(), before.clips.len() + 2);
    assert_eq!(after.controls.iter().map(|c| &c.name).collect::<Vec<_>>(), names.iter().collect::<Vec<_>>());
    let back = after.clip("reprise_wave").unwrap();
    assert_eq!(back.frames, wave.frames);
    let worst = back.values.iter().zip(&values).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-5, "largest control difference after the round trip: {worst}");
    let rest = after.clip("reprise_rest").unwrap();
    assert_eq!(rest.frames, 5);
    let defaults: Vec<f64> = before.controls.iter().map(|c| c.default).collect();
    let worst_rest = rest.values[..n].iter().zip(&defaults).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst_rest < 1e-5, "{worst_rest}");
    let orig = after.clip("Wave").unwrap();
    assert!(orig.values.iter().zip(&wave.values).all(|(a, b)| (a - b).abs() < 1e-12));
    let err = export(&out, &dir.path().join("again.glb"), &clips[..1], "reprise:stage=test").unwrap_err().to_string();
    assert!(err.contains("already has an animation named `reprise_wave`"), "{err}");
    assert!(!dir.path().join("again.glb").exists());
}
