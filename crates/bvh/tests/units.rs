//! Small hand-written BVH files: Euler order, rotation-vector continuity, non-root
//! position channels, resampling, names.

mod common;

use std::f64::consts::PI;

use common::{fk_from_channels, max_diff};
use reprise_bvh::{parse, resample, rotation, BvhRig};

/// One joint with the given CHANNELS line and an End Site at (1, 2, 3); one frame.
fn one_joint(channels: &str, values: &str) -> String {
    format!(
        "HIERARCHY\nROOT J\n{{\n  OFFSET 0 0 0\n  CHANNELS {channels}\n  End Site\n  {{\n    OFFSET 1 2 3\n  }}\n}}\n\
         MOTION\nFrames: 1\nFrame Time: 0.1\n{values}\n"
    )
}

fn end_site_position(channels: &str, values: &str) -> Vec<f64> {
    let bvh = parse("one.bvh", &one_joint(channels, values)).unwrap();
    let curves = resample(&bvh, "one", 10.0).unwrap();
    let rig = BvhRig::from_bvh(&bvh);
    let mut out = vec![0.0; 6];
    rig.evaluate(curves.frame(0), &mut out);
    out[3..].to_vec()
}

#[test]
fn euler_order_zxy_and_xyz_give_their_known_matrices() {
    let m = |order: [usize; 3]| rotation::matrix(rotation::euler(order.map(|axis| (axis, 90.0))));
    // Rz(90)·Rx(90)·Ry(90) and Rx(90)·Ry(90)·Rz(90), worked out by hand.
    let zxy = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0];
    let xyz = [0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0];
    assert!(max_diff(&m([2, 0, 1]), &zxy) < 1e-15, "{:?}", m([2, 0, 1]));
    assert!(max_diff(&m([0, 1, 2]), &xyz) < 1e-15, "{:?}", m([0, 1, 2]));

    // The same through parse → ingest (rotation vectors) → FK: the End Site (1, 2, 3).
    let p = end_site_position("3 Zrotation Xrotation Yrotation", "90 90 90");
    assert!(max_diff(&p, &[-1.0, 3.0, 2.0]) < 1e-12, "{p:?}");
    let p = end_site_position("3 Xrotation Yrotation Zrotation", "90 90 90");
    assert!(max_diff(&p, &[3.0, -2.0, 1.0]) < 1e-12, "{p:?}");
    // Values map to channels in declared order: only the first (Z) channel is set.
    let p = end_site_position("3 Zrotation Xrotation Yrotation", "90 0 0");
    assert!(max_diff(&p, &[-2.0, 1.0, 3.0]) < 1e-12, "{p:?}");
    let p = end_site_position("3 Xrotation Yrotation Zrotation", "0 0 90");
    assert!(max_diff(&p, &[-2.0, 1.0, 3.0]) < 1e-12, "{p:?}");
}

#[test]
fn general_euler_angles_match_matrix_products() {
    for (channels, values) in [
        ("3 Zrotation Xrotation Yrotation", "31 -47 112"),
        ("3 Xrotation Yrotation Zrotation", "31 -47 112"),
        ("3 Yrotation Zrotation Xrotation", "-170 89.9 5"),
        ("3 Zrotation Yrotation Zrotation", "10 20 30"),
        ("1 Xrotation", "179.999"),
    ] {
        let bvh = parse("one.bvh", &one_joint(channels, values)).unwrap();
        let expected = fk_from_channels(&bvh, bvh.frame(0));
        let p = end_site_position(channels, values);
        assert!(max_diff(&p, &expected[3..]) < 1e-12, "{channels} {values}: {p:?} vs {expected:?}");
    }
}

#[test]
fn rotation_vector_stays_continuous_through_a_long_spin() {
    // Three full turns about Y (declared among other axes) at 10° a frame, then back.
    let frames: Vec<f64> = (0..=108).map(|k| 10.0 * k as f64).chain((0..=108).rev().map(|k| 10.0 * k as f64)).collect();
    let motion: String = frames.iter().map(|y| format!("0 0 {y}\n")).collect();
    let text = format!(
        "HIERARCHY\nROOT J\n{{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {{\n    OFFSET 1 0 0\n  }}\n}}\n\
         MOTION\nFrames: {}\nFrame Time: 0.0333333\n{motion}",
        frames.len()
    );
    let bvh = parse("spin.bvh", &text).unwrap();
    assert_eq!(bvh.source_fps(), 30.0);
    let rig = BvhRig::from_bvh(&bvh);
    for fps in [30.0, 15.0] {
        let curves = resample(&bvh, "spin", fps).unwrap();
        let step = 30.0 / fps;
        assert_eq!(curves.frames, frames.len().div_ceil(step as usize));
        let mut out = [0.0; 6];
        for k in 0..curves.frames {
            let degrees = frames[(k as f64 * step) as usize];
            let v = curves.frame(k);
            assert!(max_diff(v, &[0.0, degrees.to_radians(), 0.0]) < 1e-9, "{fps} fps frame {k}: {v:?}");
            rig.evaluate(v, &mut out);
            let (s, c) = degrees.to_radians().sin_cos();
            assert!(max_diff(&out[3..], &[c, 0.0, -s]) < 1e-12);
        }
        let ry = &curves.controls[1];
        assert!((ry.max - 6.0 * PI).abs() < 1e-9 && ry.min.abs() < 1e-12, "{ry:?}");
    }
}

#[test]
fn continuity_picks_the_nearest_equivalent_vector_with_a_tilted_axis() {
    // Fixed 30° tilt about Z then a spin about the tilted joint's Y up to 250°: the
    // rotation angle passes π, where the raw log flips the axis; the continuous vector
    // must not jump.
    let motion: String = (0..=50).map(|k| format!("30 0 {}\n", 5.0 * k as f64)).collect();
    let text = format!(
        "HIERARCHY\nROOT J\n{{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {{\n    OFFSET 1 0 0\n  }}\n}}\n\
         MOTION\nFrames: 51\nFrame Time: 0.04\n{motion}"
    );
    let bvh = parse("tilt.bvh", &text).unwrap();
    let curves = resample(&bvh, "tilt", 25.0).unwrap();
    let mut beyond_pi = 0;
    for k in 0..curves.frames {
        let v = curves.frame(k);
        // Same rotation as the Euler angles.
        let expected = rotation::matrix(rotation::euler([(2, 30.0), (0, 0.0), (1, 5.0 * k as f64)]));
        assert!(max_diff(&rotation::matrix(rotation::exp([v[0], v[1], v[2]])), &expected) < 1e-12);
        if k > 0 {
            let prev = curves.frame(k - 1);
            assert!(max_diff(v, prev) < 0.3, "jump at frame {k}: {prev:?} -> {v:?}");
        }
        let angle = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if angle > PI + 0.1 {
            beyond_pi += 1;
            // Here the raw log (angle in [0, π]) points the other way.
            let raw = rotation::log(rotation::exp([v[0], v[1], v[2]]));
            assert!(raw.iter().zip(v).map(|(a, b)| a * b).sum::<f64>() < 0.0);
        }
    }
    assert!(beyond_pi >= 5, "the spin should carry the vector past π ({beyond_pi} frames)");
}

const SIX_CHANNEL_ARM: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 1 0 0
    CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
    JOINT Hand
    {
      OFFSET 0 2 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 1 0
      }
    }
  }
  JOINT Leg
  {
    OFFSET 0 -1 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -2 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.1
0 0 0 0 0 0  1 0 0 0 0 0  0 0 0  0 0 0
0 0 0 0 0 0  1.5 0.25 -2 0 0 0  0 0 0  0 0 0
0 0 0 0 0 0  1.5 0.25 -2 90 0 0  0 0 0  0 0 0
";

#[test]
fn six_channel_non_root_joint_moves_its_subtree() {
    let bvh = parse("arm.bvh", SIX_CHANNEL_ARM).unwrap();
    let rig = BvhRig::from_bvh(&bvh);
    let names: Vec<&str> = rig.control_names().iter().map(String::as_str).collect();
    assert_eq!(&names[6..12], ["Arm.tx", "Arm.ty", "Arm.tz", "Arm.rx", "Arm.ry", "Arm.rz"]);
    assert_eq!(names.len(), 18);
    assert_eq!(rig.vertex_names(), ["Hips", "Arm", "Hand", "Hand.end", "Leg", "Leg.end"]);
    assert_eq!(rig.bones(), [(0, 1), (1, 2), (2, 3), (0, 4), (4, 5)]);

    let curves = resample(&bvh, "arm", 10.0).unwrap();
    assert_eq!(curves.frames, 3);
    let pose = |k: usize| {
        let mut out = vec![0.0; 18];
        rig.evaluate(curves.frame(k), &mut out);
        out
    };
    let (p0, p1, p2) = (pose(0), pose(1), pose(2));
    // Frame 0: the position channels equal the OFFSET, so the rest skeleton.
    assert!(max_diff(&p0, &[0., 0., 0., 1., 0., 0., 1., 2., 0., 1., 3., 0., 0., -1., 0., 0., -3., 0.]) < 1e-12);
    // Frame 1: Arm, Hand and Hand.end move by (0.5, 0.25, −2); Hips and the leg stay.
    for (vertex, delta) in [(0, [0.0; 3]), (1, [0.5, 0.25, -2.0]), (2, [0.5, 0.25, -2.0]), (3, [0.5, 0.25, -2.0])]
        .into_iter()
        .chain([(4, [0.0; 3]), (5, [0.0; 3])])
    {
        let moved: Vec<f64> = (0..3).map(|a| p1[3 * vertex + a] - p0[3 * vertex + a]).collect();
        assert!(max_diff(&moved, &delta) < 1e-12, "vertex {vertex}: {moved:?}");
    }
    // Frame 2: Arm also turns 90° about Z at its translated position.
    let arm = [1.5, 0.25, -2.0];
    assert!(max_diff(&p2[3..6], &arm) < 1e-12);
    assert!(max_diff(&p2[6..9], &[arm[0] - 2.0, arm[1], arm[2]]) < 1e-12, "{:?}", &p2[6..9]);
    assert!(max_diff(&p2[9..12], &[arm[0] - 3.0, arm[1], arm[2]]) < 1e-12);
    // And agrees with the independent matrix FK on every frame.
    for (k, p) in [p0, p1, p2].iter().enumerate() {
        assert!(max_diff(p, &fk_from_channels(&bvh, bvh.frame(k))) < 1e-12);
    }
}

#[test]
fn partial_position_channels_keep_the_offset_on_other_axes() {
    let text = "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS 0\n JOINT Slider\n {\n  OFFSET 4 5 6\n  CHANNELS 1 Yposition\n  End Site\n  {\n   OFFSET 0 0 1\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 1\n7\n";
    let bvh = parse("slider.bvh", text).unwrap();
    let curves = resample(&bvh, "slider", 1.0).unwrap();
    assert_eq!(curves.frame(0), [4.0, 7.0, 6.0]);
    let rig = BvhRig::from_bvh(&bvh);
    let mut out = [0.0; 9];
    rig.evaluate(curves.frame(0), &mut out);
    assert_eq!(out, [0.0, 0.0, 0.0, 4.0, 7.0, 6.0, 4.0, 7.0, 7.0]);
}

#[test]
fn resampling_lerps_translations_and_slerps_rotations() {
    // 10 fps source, 4 frames (0.3 s): to 25 fps gives t = 0, 0.04, …, 0.28 (8 frames).
    let text = "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS 4 Xposition Yposition Zposition Zrotation\n}\nMOTION\n\
                Frames: 4\nFrame Time: 0.1\n0 0 0 0\n1 2 3 40\n1 2 3 40\n-1 0 0 -40\n";
    // (A ROOT without children or End Site is allowed.)
    let bvh = parse("lerp.bvh", text).unwrap();
    let curves = resample(&bvh, "lerp", 25.0).unwrap();
    assert_eq!(curves.frames, 8);
    for k in 0..8 {
        let s = 0.4 * k as f64; // position in source frames
        let i = (s.floor() as usize).min(2);
        let f = s - i as f64;
        let (a, b) = (bvh.frame(i), bvh.frame(i + 1));
        let lerp = |c: usize| a[c] + f * (b[c] - a[c]);
        let row = curves.frame(k);
        assert!(max_diff(&row[..3], &[lerp(0), lerp(1), lerp(2)]) < 1e-12, "frame {k}");
        // Single-axis rotations: slerp is linear in the angle.
        assert!(max_diff(&row[3..], &[0.0, 0.0, lerp(3).to_radians()]) < 1e-12, "frame {k}: {row:?}");
    }
    assert_eq!(resample(&bvh, "lerp", 10.0).unwrap().frames, 4);
    assert_eq!(resample(&bvh, "lerp", 3.0).unwrap().frames, 1);
}

#[test]
fn duplicate_joint_names_get_numbered() {
    let text = "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 1 Xrotation\n JOINT A\n {\n  OFFSET 1 0 0\n  CHANNELS 1 Xrotation\n  End Site\n  {\n   OFFSET 1 0 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 1\n0 0\n";
    let rig = BvhRig::from_bvh(&parse("dup.bvh", text).unwrap());
    assert_eq!(rig.control_names(), ["A.rx", "A.ry", "A.rz", "A#2.rx", "A#2.ry", "A#2.rz"]);
    assert_eq!(rig.vertex_names(), ["A", "A#2", "A#2.end"]);
}

#[test]
fn crlf_and_braces_on_keyword_lines_parse() {
    let text = "HIERARCHY\r\nROOT Hips {\r\n OFFSET 0 0 0\r\n CHANNELS 3 Xposition Yposition Zposition\r\n End Site {\r\n  OFFSET 0 1 0 }\r\n}\r\nMOTION\r\nFrames:\t2\r\nFrame Time:\t.5\r\n1 2 3\r\n4 5 6\r\n\r\n";
    let bvh = parse("crlf.bvh", text).unwrap();
    assert_eq!(bvh.nodes.len(), 2);
    assert_eq!(bvh.nodes[1].offset, [0.0, 1.0, 0.0]);
    assert_eq!(bvh.motion, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(bvh.source_fps(), 2.0);
}

#[test]
fn ingest_names_the_clip_by_file_stem() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("walk_07.bvh");
    std::fs::write(&path, SIX_CHANNEL_ARM).unwrap();
    let curves = reprise_bvh::ingest(&path, 5.0).unwrap();
    assert_eq!(curves.clip, "walk_07");
    assert_eq!(curves.frames, 2);
    assert_eq!(curves.source_fps, 10.0);
    let rig = BvhRig::open(&path).unwrap();
    assert_eq!(rig.control_names(), curves.controls.iter().map(|c| c.name.clone()).collect::<Vec<_>>());
    assert_eq!(rig.default_controls(), vec![0.0; 18]);
    assert!(rig.describe().contains("walk_07.bvh: 4 joints, 2 end sites, 18 controls"), "{}", rig.describe());
}

#[test]
fn rig_is_send_sync_clone_and_a_bom_is_ignored() {
    fn shareable<T: Send + Sync + Clone>(_: &T) {}
    let rig = BvhRig::from_bvh(&parse("bom.bvh", &format!("\u{feff}{SIX_CHANNEL_ARM}")).unwrap());
    shareable(&rig);
    assert_eq!(rig.clone().vertex_count(), 6);
}

#[test]
fn batch_evaluation_matches_single_evaluation() {
    let bvh = parse("arm.bvh", SIX_CHANNEL_ARM).unwrap();
    let rig = BvhRig::from_bvh(&bvh);
    let curves = resample(&bvh, "arm", 10.0).unwrap();
    let mut batch = vec![0.0; 3 * 18];
    rig.evaluate_batch(&curves.values, &mut batch);
    for k in 0..3 {
        let mut one = vec![0.0; 18];
        rig.evaluate(curves.frame(k), &mut one);
        assert_eq!(one, batch[18 * k..18 * (k + 1)]);
    }
}

#[test]
fn a_skeleton_without_channels_has_no_controls() {
    let text = "HIERARCHY\nROOT R\n{\n OFFSET 1 2 3\n End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.5\n\n\n";
    let bvh = parse("still.bvh", text);
    // Two empty motion lines are indistinguishable from blank lines, which are skipped.
    assert!(bvh.is_err());
    let text = text.replace("Frames: 2", "Frames: 0");
    let bvh = parse("still.bvh", &text).unwrap();
    let rig = BvhRig::from_bvh(&bvh);
    assert!(rig.control_names().is_empty());
    let mut out = [0.0; 6];
    rig.evaluate(&[], &mut out);
    assert_eq!(out, [1.0, 2.0, 3.0, 1.0, 3.0, 3.0]);
}

/// Takes of one skeleton compare equal; another joint name, channel order or bone
/// length is named with its line. A position channel's axis is not compared.
#[test]
fn skeleton_difference_names_the_first_mismatch() {
    let base =
        parse("a.bvh", &one_joint("6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "0 0 0 0 0 0"))
            .unwrap();
    let moved = one_joint("6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "5 5 5 1 2 3")
        .replace("OFFSET 0 0 0", "OFFSET 9 9 9");
    assert_eq!(base.skeleton_difference(&parse("b.bvh", &moved).unwrap()), None, "same skeleton, other motion");
    let order = one_joint("6 Xposition Yposition Zposition Xrotation Yrotation Zrotation", "0 0 0 0 0 0");
    let why = base.skeleton_difference(&parse("c.bvh", &order).unwrap()).unwrap();
    assert!(why.contains("line 2") && why.contains("channels"), "{why}");
    let longer = one_joint("6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "0 0 0 0 0 0")
        .replace("OFFSET 1 2 3", "OFFSET 1 2 4");
    let why = base.skeleton_difference(&parse("d.bvh", &longer).unwrap()).unwrap();
    assert!(why.contains("J.end") && why.contains("Z differs"), "{why}");
    // Within the tolerance (2 % of the largest OFFSET, 3): one skeleton, the gap reported.
    let recalibrated = one_joint("6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "0 0 0 0 0 0")
        .replace("OFFSET 1 2 3", "OFFSET 1 2 3.05");
    let other = parse("f.bvh", &recalibrated).unwrap();
    assert_eq!(base.skeleton_difference(&other), None);
    let (joint, gap) = base.offset_gap(&other).unwrap();
    assert!(joint == "J.end" && (gap - 0.05).abs() < 1e-9, "{joint} {gap}");
    assert_eq!(base.offset_gap(&base), None);
    let renamed = one_joint("6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "0 0 0 0 0 0")
        .replace("ROOT J", "ROOT K");
    let why = base.skeleton_difference(&parse("e.bvh", &renamed).unwrap()).unwrap();
    assert!(why.contains("`K` where the first file has `J`"), "{why}");
}
