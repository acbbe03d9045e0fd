//! Kenney Mini Characters (UnityGLTF export): many short clips, two-key poses, 0.1 s clips.

mod common;

use common::dataset;
use reprise_gltf::{ingest, GltfRig};

const MALE: &str = "kenney_mini_characters/character-male-a.glb";
const FEMALE: &str = "kenney_mini_characters/character-female-a.glb";

#[test]
fn kenney_clips_including_two_key_and_short_ones() {
    let Some(path) = dataset(MALE, "kenney_clips_including_two_key_and_short_ones") else { return };
    let curves = ingest(&path, 30.0).unwrap();
    assert_eq!(curves.clips.len(), 32);
    let names: Vec<&str> = curves.clips.iter().map(|c| c.name.as_str()).collect();
    for want in ["idle", "walk", "sprint", "jump", "fall", "crouch", "sit", "die", "emote-yes", "emote-no"] {
        assert!(names.contains(&want), "missing clip {want}");
    }
    assert_eq!(names.iter().filter(|n| n.starts_with("attack-")).count(), 4);
    assert_eq!(names.iter().filter(|n| n.starts_with("interact-")).count(), 2);
    assert_eq!(names.iter().filter(|n| n.starts_with("wheelchair-")).count(), 7);
    // 7 joints, each with rotation, translation and (in clip "static") scale channels
    assert_eq!(curves.controls.len(), 7 * 9);
    assert!(curves.controls.iter().all(|c| c.group == "joints"));

    // "static": two keys, 0.1 s long → round(0.1 · 30) + 1 = 4 frames, key rate 10/s
    let st = curves.clip("static").unwrap();
    assert_eq!(st.frames, 4);
    assert!((st.source_fps - 10.0).abs() < 1e-3);
    // "idle": 40 keys over 1.333 s → 41 frames at 30 fps
    assert_eq!(curves.clip("idle").unwrap().frames, 41);

    // "sit": a pose — every channel has two equal keys 1/6 s apart → 6 frames, all the same
    // pose, away from the rest pose (the root drops, the arms and legs bend).
    let sit = curves.clip("sit").unwrap();
    assert_eq!(sit.frames, 6);
    assert!((sit.source_fps - 6.0).abs() < 1e-3);
    let n = curves.controls.len();
    let row = |f: usize| &sit.values[f * n..(f + 1) * n];
    assert!((1..sit.frames).all(|f| row(f) == row(0)));
    let defaults: Vec<f64> = curves.controls.iter().map(|c| c.default).collect();
    let moved: Vec<&str> =
        (0..n).filter(|&i| (row(0)[i] - defaults[i]).abs() > 1e-3).map(|i| curves.controls[i].name.as_str()).collect();
    for want in ["root.ty", "arm-left.rz", "leg-left.rx"] {
        assert!(moved.contains(&want), "{want} should differ from rest in sit; moved: {moved:?}");
    }
    // a clip with a mix of two-key and many-key channels samples over the longest one
    let jump = curves.clip("jump").unwrap();
    assert_eq!(jump.frames, 16);
}

#[test]
fn kenney_male_and_female_give_identical_curves() {
    let (Some(m), Some(f)) = (
        dataset(MALE, "kenney_male_and_female_give_identical_curves"),
        dataset(FEMALE, "kenney_male_and_female_give_identical_curves"),
    ) else {
        return;
    };
    let (a, b) = (ingest(&m, 30.0).unwrap(), ingest(&f, 30.0).unwrap());
    assert_eq!(a, b);
}

/// In this file the rest pose is the bind pose: with every control at its default, the rig
/// returns exactly the raw POSITION accessors (the skinned nodes sit at the identity and
/// `G(joint) · IBM = I` for every joint).
#[test]
fn kenney_rest_pose_is_bind_pose() {
    let Some(path) = dataset(MALE, "kenney_rest_pose_is_bind_pose") else { return };
    let rig = GltfRig::open(&path).unwrap();
    let got = rig.evaluate_to_vec(&rig.default_controls());
    let g = gltf::Gltf::open(&path).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let mut raw = Vec::new();
    for name in ["body-mesh", "head-mesh"] {
        let node = g.nodes().find(|n| n.name() == Some(name)).unwrap();
        for p in node.mesh().unwrap().primitives() {
            raw.extend(p.reader(|_| Some(blob)).read_positions().unwrap().flat_map(|v| v.map(f64::from)));
        }
    }
    assert_eq!(got.len(), raw.len());
    let worst = got.iter().zip(&raw).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-4, "rest pose differs from POSITION by {worst}");
    // and a pose moves it
    let curves = ingest(&path, 30.0).unwrap();
    let walk = curves.clip("walk").unwrap();
    let moved = rig.evaluate_to_vec(curves.frame(walk, 5));
    assert!(moved.iter().zip(&raw).any(|(a, b)| (a - b).abs() > 1e-3));
}
