//! Real data: CMU subject 131 (cgspeed BVH conversion), read in place from
//! `../shared/datasets/cmu_bvh/`.

mod common;

use std::collections::HashSet;

use common::{cmu_dir, fk_from_channels, max_diff};
use reprise_bvh::{ingest, read, rotation, BvhError, BvhRig};

const CLIPS: [(&str, usize); 3] = [("131_01", 994), ("131_02", 1247), ("131_03", 1102)];

#[test]
fn cmu_hierarchy_and_motion_sizes() {
    let Some(dir) = cmu_dir("cmu_hierarchy_and_motion_sizes") else { return };
    for (clip, frames) in CLIPS {
        let bvh = read(&dir.join(format!("{clip}.bvh"))).unwrap();
        assert_eq!(bvh.joint_count(), 31, "{clip}");
        assert_eq!(bvh.end_site_count(), 7, "{clip}");
        assert_eq!(bvh.channel_count, 96, "{clip}");
        assert_eq!(bvh.frames, frames, "{clip}");
        assert_eq!(bvh.motion.len(), frames * 96, "{clip}");
        assert_eq!(bvh.source_fps(), 120.0, "{clip}");
        assert_eq!(bvh.nodes[0].name, "Hips");
        assert_eq!(bvh.nodes[0].channels.len(), 6);

        let rig = BvhRig::from_bvh(&bvh);
        assert_eq!(rig.vertex_count(), 38);
        assert_eq!(rig.control_names().len(), 96);
        assert_eq!(rig.bones().len(), 37);
        assert!(rig.triangles().is_empty());
        let unique: HashSet<_> = rig.control_names().iter().collect();
        assert_eq!(unique.len(), 96, "control names must be unique");
        assert_eq!(&rig.control_names()[..6], ["Hips.tx", "Hips.ty", "Hips.tz", "Hips.rx", "Hips.ry", "Hips.rz"]);
    }
}

#[test]
fn cmu_resampled_to_24_fps() {
    let Some(dir) = cmu_dir("cmu_resampled_to_24_fps") else { return };
    for (clip, frames) in CLIPS {
        let curves = ingest(&dir.join(format!("{clip}.bvh")), 24.0).unwrap();
        assert_eq!(curves.clip, clip);
        assert_eq!(curves.source_fps, 120.0);
        assert_eq!(curves.fps, 24.0);
        assert_eq!(curves.frames, (frames - 1) / 5 + 1, "{clip}");
        assert_eq!(curves.values.len(), curves.frames * 96);
        for (j, control) in curves.controls.iter().enumerate() {
            assert_eq!(control.group, "joints");
            assert_eq!(control.default, 0.0);
            let expected_unit =
                if [".tx", ".ty", ".tz"].iter().any(|s| control.name.ends_with(s)) { "bvh" } else { "rad" };
            assert_eq!(control.unit, expected_unit, "{}", control.name);
            let column: Vec<f64> = (0..curves.frames).map(|k| curves.frame(k)[j]).collect();
            assert_eq!(control.min, column.iter().copied().fold(f64::INFINITY, f64::min));
            assert_eq!(control.max, column.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        }
        // Continuity: no rotation vector wraps between output frames. The data has real
        // fast moves (a toe flick of ~1.1 rad per 24 fps frame, thumb marker flips of
        // ~160° in one source frame), so where the log map is well conditioned (|v| < 2.5)
        // a step is bounded by the rotation it represents, |Δv| ≤ 2·(angle between the two
        // rotations), where a wrap would add ~2π. Everywhere, each vector is the nearest
        // of its equivalents v ± 2π·v̂ to the previous one.
        for (j, control) in curves.controls.iter().enumerate().step_by(3).skip(1) {
            for k in 1..curves.frames {
                let (a, b) = (&curves.frame(k - 1)[j..j + 3], &curves.frame(k)[j..j + 3]);
                let (qa, qb) = (rotation::exp([a[0], a[1], a[2]]), rotation::exp([b[0], b[1], b[2]]));
                let cos_half = (0..4).map(|i| qa[i] * qb[i]).sum::<f64>().abs().min(1.0);
                let angle = 2.0 * cos_half.acos();
                let step = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
                let small = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>() < 2.5 * 2.5;
                assert!(
                    !(small(a) && small(b)) || step <= 2.0 * angle + 1e-6,
                    "{clip} {} jumps at output frame {k}: {a:?} -> {b:?}",
                    control.name
                );
                let norm = b.iter().map(|x| x * x).sum::<f64>().sqrt();
                let dist = |v: &[f64]| v.iter().zip(a).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt();
                for turn in [-1.0, 1.0].into_iter().filter(|_| norm > 1e-12) {
                    let other: Vec<f64> = b.iter().map(|x| x + turn * 2.0 * std::f64::consts::PI * x / norm).collect();
                    assert!(dist(b) <= dist(&other) + 1e-12, "{clip} {} at {k}", control.name);
                }
            }
        }
    }
}

/// FK from the file's own Euler channels (independent 4×4 matrix code) equals the rig
/// evaluated on ingest's rotation vectors: checks Euler → rotation vector → FK.
#[test]
fn cmu_fk_round_trip_through_rotation_vectors() {
    let Some(dir) = cmu_dir("cmu_fk_round_trip_through_rotation_vectors") else { return };
    for (clip, _) in CLIPS {
        let path = dir.join(format!("{clip}.bvh"));
        let bvh = read(&path).unwrap();
        let rig = BvhRig::open(&path).unwrap();
        let mut out = vec![0.0; 3 * rig.vertex_count()];
        let mut worst: f64 = 0.0;

        // At 24 fps, output frame k is source frame 5k exactly.
        let curves = ingest(&path, 24.0).unwrap();
        let last = curves.frames - 1;
        for k in [0, 1, 7, 42, 100, last / 2, last] {
            rig.evaluate(curves.frame(k), &mut out);
            let expected = fk_from_channels(&bvh, bvh.frame(5 * k));
            worst = worst.max(max_diff(&out, &expected));
        }
        // At the source rate, every file frame.
        let curves = ingest(&path, 120.0).unwrap();
        assert_eq!(curves.frames, bvh.frames);
        for k in (0..bvh.frames).step_by(97).chain([bvh.frames - 1]) {
            rig.evaluate(curves.frame(k), &mut out);
            worst = worst.max(max_diff(&out, &fk_from_channels(&bvh, bvh.frame(k))));
        }
        eprintln!("{clip}: largest FK difference {worst:e} file units");
        assert!(worst < 1e-6, "{clip}: FK differs by {worst:e} file units");
        // The comparison is not vacuous: the skeleton really moves between frames.
        let (a, b) = (fk_from_channels(&bvh, bvh.frame(0)), fk_from_channels(&bvh, bvh.frame(500)));
        assert!(max_diff(&a, &b) > 1.0);
    }
}

#[test]
fn cmu_between_frames_interpolates() {
    let Some(dir) = cmu_dir("cmu_between_frames_interpolates") else { return };
    let path = dir.join("131_03.bvh");
    let bvh = read(&path).unwrap();
    let rig = BvhRig::from_bvh(&bvh);
    // At 240 fps odd output frames fall halfway between source frames: the pose lies
    // between the two source poses (close to their midpoint for smooth mocap).
    let curves = ingest(&path, 240.0).unwrap();
    assert_eq!(curves.frames, 2 * (bvh.frames - 1) + 1);
    let mut out = vec![0.0; 3 * rig.vertex_count()];
    for i in [10, 300, 900] {
        rig.evaluate(curves.frame(2 * i + 1), &mut out);
        let (a, b) = (fk_from_channels(&bvh, bvh.frame(i)), fk_from_channels(&bvh, bvh.frame(i + 1)));
        let mid: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
        assert!(max_diff(&out, &mid) < 0.05 * max_diff(&a, &b).max(1e-3), "frame {i}");
    }
}

#[test]
fn cmu_bad_motion_line_names_file_and_line() {
    let Some(dir) = cmu_dir("cmu_bad_motion_line_names_file_and_line") else { return };
    let text = std::fs::read_to_string(dir.join("131_01.bvh")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let first_motion = lines.iter().position(|l| l.starts_with("Frame Time")).unwrap() + 1;
    let shortened = lines[first_motion + 3].trim_end().rsplit_once(' ').unwrap().0.to_string();
    lines[first_motion + 3] = &shortened;
    let err = reprise_bvh::parse("131_01.bvh", &lines.join("\n")).unwrap_err();
    assert!(matches!(err, BvhError::ValueCount { found: 95, expected: 96, .. }), "{err:?}");
    let line = first_motion + 4;
    assert_eq!(
        err.to_string(),
        format!(
            "131_01.bvh: line {line}: motion line has 95 values, expected 96 (the channels declared in the hierarchy)"
        )
    );
}
