//! RobotExpressive (three.js's FBX2glTF conversion, and its three.js re-export).

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Instant;

use common::{dataset, normalise_node, split_joint};
use glam::{DMat4, DQuat, DVec3};
use reprise_gltf::{ingest, GltfCurves, GltfRig, SceneGraph};

const ROBOT: &str = "robot_expressive/RobotExpressive.glb";
const REEXPORT: &str = "robot_expressive/RobotExpressive_reexport.glb";

/// (clip, seconds) as listed in the datasets MANIFEST.
const CLIPS: [(&str, f64); 14] = [
    ("Dance", 3.333),
    ("Death", 0.958),
    ("Idle", 3.333),
    ("Jump", 0.708),
    ("No", 1.667),
    ("Punch", 0.833),
    ("Running", 0.958),
    ("Sitting", 0.417),
    ("Standing", 0.417),
    ("ThumbsUp", 1.583),
    ("Walking", 0.958),
    ("WalkJump", 0.833),
    ("Wave", 1.833),
    ("Yes", 1.667),
];

#[test]
fn robot_clips_and_frame_counts() {
    let Some(path) = dataset(ROBOT, "robot_clips_and_frame_counts") else { return };
    let curves = ingest(&path, 24.0).unwrap();
    let names: Vec<&str> = curves.clips.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, CLIPS.map(|(n, _)| n));
    for (clip, (_, secs)) in curves.clips.iter().zip(CLIPS) {
        assert_eq!(clip.frames, (secs * 24.0).round() as usize + 1, "{}", clip.name);
        assert_eq!(clip.values.len(), clip.frames * curves.controls.len());
        assert!((clip.source_fps - 24.0).abs() < 1e-3, "{}: source fps {}", clip.name, clip.source_fps);
        assert!(clip.values.iter().all(|v| v.is_finite()));
    }
    // 43-joint skeleton; rotation channels on the animated bones, morphs on the Head mesh.
    let morphs: Vec<&str> = curves.controls.iter().filter(|c| c.group == "morphs").map(|c| c.name.as_str()).collect();
    assert_eq!(morphs, ["Head#13.morph.Angry", "Head#13.morph.Surprised", "Head#13.morph.Sad"]);
    for c in &curves.controls {
        assert!(c.min <= c.default.max(c.min) && c.min <= c.max, "{c:?}");
        let unit = match c.name.rsplit('.').next().unwrap() {
            "rx" | "ry" | "rz" => "rad",
            "tx" | "ty" | "tz" => "m",
            _ => "weight",
        };
        assert_eq!(c.unit, unit, "{}", c.name);
    }
    // the arm really moves in Wave: some control spans a large angle
    let wave = curves.clip("Wave").unwrap();
    let ua = curves.control_index("UpperArm.R.rx").or(curves.control_index("UpperArm.L.rx")).unwrap();
    let n = curves.controls.len();
    let col: Vec<f64> = (0..wave.frames).map(|f| wave.values[f * n + ua]).collect();
    assert!(col.iter().any(|v| v.abs() > 1e-3), "UpperArm should move in Wave");
}

#[test]
fn robot_rig_controls_match_ingest() {
    let Some(path) = dataset(ROBOT, "robot_rig_controls_match_ingest") else { return };
    let curves = ingest(&path, 24.0).unwrap();
    let rig = GltfRig::open(&path).unwrap();
    let names: Vec<&str> = curves.controls.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(rig.control_names(), names.as_slice());
    assert_eq!(rig.default_controls(), curves.controls.iter().map(|c| c.default).collect::<Vec<_>>());
    assert_eq!(rig.vertex_count(), 7214);
    assert!(rig.triangles().iter().flatten().all(|&i| (i as usize) < rig.vertex_count()));
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<GltfRig>();
}

/// The rest pose (all controls at default) evaluates to what the raw accessors imply:
/// rigid primitives `G_node · POSITION`; skinned primitives `Σ wᵢ · G(jointᵢ) · IBMᵢ · POSITION`
/// with the joints at their rest transforms (weights renormalised: this file's WEIGHTS_0 sum
/// to as much as 1.76, and engines such as three.js renormalise). Computed here straight from
/// the `gltf` crate with 4×4 node matrices, not through the rig's code.
///
/// Note: RobotExpressive's rest (node TRS) pose is not its bind pose — for the hand skins
/// `G(joint) · IBM` differs from joint to joint at rest — so the identity "rest = POSITION ×
/// mesh matrix" does not hold for the hands; `kenney_rest_pose_is_bind_pose` tests that
/// identity on a file where it does hold.
#[test]
fn robot_rest_pose_matches_raw_accessors() {
    let Some(path) = dataset(ROBOT, "robot_rest_pose_matches_raw_accessors") else { return };
    let rig = GltfRig::open(&path).unwrap();
    let got = rig.evaluate_to_vec(&rig.default_controls());
    let want = independent_rest_vertices(&path);
    assert_eq!(got.len(), 3 * want.len());
    let worst = want
        .iter()
        .enumerate()
        .map(|(v, w)| (DVec3::from_slice(&got[3 * v..]) - *w).abs().max_element())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "rest pose differs from the raw accessors by {worst}");
}

fn independent_rest_vertices(path: &Path) -> Vec<DVec3> {
    let g = gltf::Gltf::open(path).unwrap();
    let blob = g.blob.as_deref().unwrap();
    let nodes: Vec<gltf::Node> = g.nodes().collect();
    let mut parent = vec![None; nodes.len()];
    for n in &nodes {
        for c in n.children() {
            parent[c.index()] = Some(n.index());
        }
    }
    fn global(i: usize, nodes: &[gltf::Node], parent: &[Option<usize>]) -> DMat4 {
        let m = nodes[i].transform().matrix().map(|c| c.map(f64::from));
        let local = DMat4::from_cols_array_2d(&m);
        parent[i].map_or(local, |p| global(p, nodes, parent) * local)
    }
    let scene = g.default_scene().unwrap();
    let mut order = Vec::new();
    fn visit(n: gltf::Node, order: &mut Vec<usize>) {
        order.push(n.index());
        for c in n.children() {
            visit(c, order);
        }
    }
    for n in scene.nodes() {
        visit(n, &mut order);
    }
    let mut out = Vec::new();
    for i in order {
        let node = &nodes[i];
        let Some(mesh) = node.mesh() else { continue };
        for p in mesh.primitives() {
            let r = p.reader(|_| Some(blob));
            let pos: Vec<DVec3> = r.read_positions().unwrap().map(|v| DVec3::from_array(v.map(f64::from))).collect();
            match node.skin() {
                None => {
                    let m = global(i, &nodes, &parent);
                    out.extend(pos.iter().map(|&x| m.transform_point3(x)));
                }
                Some(skin) => {
                    let ibm: Vec<DMat4> = skin
                        .reader(|_| Some(blob))
                        .read_inverse_bind_matrices()
                        .unwrap()
                        .map(|m| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from))))
                        .collect();
                    let mats: Vec<DMat4> =
                        skin.joints().zip(&ibm).map(|(j, b)| global(j.index(), &nodes, &parent) * *b).collect();
                    let js: Vec<[u16; 4]> = r.read_joints(0).unwrap().into_u16().collect();
                    let ws: Vec<[f32; 4]> = r.read_weights(0).unwrap().into_f32().collect();
                    for (v, x) in pos.iter().enumerate() {
                        let total: f64 = ws[v].iter().map(|&w| f64::from(w)).sum();
                        let mut acc = DVec3::ZERO;
                        for c in 0..4 {
                            acc += f64::from(ws[v][c]) / total * mats[js[v][c] as usize].transform_point3(*x);
                        }
                        out.push(acc);
                    }
                }
            }
        }
    }
    out
}

/// ingest → rig for clip Wave, frame 10 at 24 fps, against vertices computed independently
/// in Python (see the fixture's "how").
#[test]
fn robot_wave_frame_matches_python_reference() {
    let Some(path) = dataset(ROBOT, "robot_wave_frame_matches_python_reference") else { return };
    let fixture: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/robot_wave_f10.json"))
            .unwrap(),
    )
    .unwrap();
    let fps = fixture["fps"].as_f64().unwrap();
    let frame = fixture["frame"].as_u64().unwrap() as usize;
    let curves = ingest(&path, fps).unwrap();
    let clip = curves.clip(fixture["clip"].as_str().unwrap()).unwrap();
    let rig = GltfRig::open(&path).unwrap();
    let got = rig.evaluate_to_vec(curves.frame(clip, frame));
    assert_eq!(rig.vertex_count() as u64, fixture["vertex_count"].as_u64().unwrap());
    let check = |v: usize, want: &serde_json::Value| {
        for a in 0..3 {
            let w = want[a].as_f64().unwrap();
            assert!((got[3 * v + a] - w).abs() < 1e-4, "vertex {v} axis {a}: {} vs python {w}", got[3 * v + a]);
        }
    };
    for (v, want) in fixture["first_vertices"].as_array().unwrap().iter().enumerate() {
        check(v, want);
    }
    let stride = fixture["strided_every"].as_u64().unwrap() as usize;
    for (k, want) in fixture["strided_vertices"].as_array().unwrap().iter().enumerate() {
        check(k * stride, want);
    }
    let sums = &fixture["checksum"];
    let sum: f64 = got.iter().sum();
    let sum_abs: f64 = got.iter().map(|x| x.abs()).sum();
    let sum_sq: f64 = got.iter().map(|x| x * x).sum();
    let sum_weighted: f64 = got.chunks(3).enumerate().map(|(v, p)| (v % 7 + 1) as f64 * p.iter().sum::<f64>()).sum();
    for (name, value) in [("sum", sum), ("sum_abs", sum_abs), ("sum_sq", sum_sq), ("sum_weighted", sum_weighted)] {
        let want = sums[name].as_f64().unwrap();
        assert!((value - want).abs() < 1e-6 * want.abs().max(1.0), "checksum {name}: {value} vs python {want}");
    }
    // and the frame is not the rest pose
    let rest = rig.evaluate_to_vec(&rig.default_controls());
    assert!(rest.iter().zip(&got).any(|(a, b)| (a - b).abs() > 1e-2));
}

/// Absolute local rotation and translation of every animated node per clip and frame, keyed
/// by normalised node name: `R = R_rest · exp(v)`, `t = t_rest + Δt`; plus whether the node
/// leaves its rest rotation / rest translation at all in that clip.
type Tracks = BTreeMap<(String, String), ((bool, bool), Vec<(DQuat, DVec3)>)>;
fn absolute_tracks(curves: &GltfCurves, graph: &SceneGraph) -> Tracks {
    let by_name: BTreeMap<&str, usize> = graph.nodes.iter().enumerate().map(|(i, n)| (n.name.as_str(), i)).collect();
    let n = curves.controls.len();
    let mut out = BTreeMap::new();
    let mut nodes: BTreeSet<&str> = BTreeSet::new();
    for c in curves.controls.iter().filter(|c| c.group == "joints") {
        nodes.insert(split_joint(&c.name).0);
    }
    for clip in &curves.clips {
        for node in &nodes {
            let rest = &graph.nodes[by_name[node]];
            let rot = curves.control_index(&format!("{node}.rx"));
            let tr = curves.control_index(&format!("{node}.tx"));
            let moves = |c: Option<usize>| {
                c.is_some_and(|b| {
                    (0..clip.frames).any(|f| clip.values[f * n + b..f * n + b + 3].iter().any(|&v| v != 0.0))
                })
            };
            let moves = (moves(rot), moves(tr));
            let track = (0..clip.frames)
                .map(|f| {
                    let row = &clip.values[f * n..(f + 1) * n];
                    let q = rot.map_or(rest.rotation, |b| {
                        rest.rotation * reprise_gltf::rotation::exp(DVec3::from_slice(&row[b..]))
                    });
                    let t = tr.map_or(rest.translation, |b| rest.translation + DVec3::from_slice(&row[b..]));
                    (q, t)
                })
                .collect();
            out.insert((clip.name.clone(), normalise_node(node)), (moves, track));
        }
    }
    out
}

/// The two exports give the same motion. Controls are matched by normalised node name
/// (`Foot.L` ≅ `FootL`, `Torso#10` ≅ `Torso_1`).
///
/// Legitimate differences, checked as such rather than ignored:
/// * three.js wrote the re-export's rest transforms from a posed skeleton, so ten bones
///   (Body, Head, Upper/LowerArm.L/R, Upper/LowerLeg.L/R) have a different rest rotation (and
///   Body a different rest translation). Their controls are relative to the rest, so the
///   control values differ; the absolute local rotation `R_rest · exp(v)` and translation
///   are compared instead (for every node a clip animates), and the raw control values only
///   for nodes whose rest transform is the same in both files. In a clip that does not
///   animate such a bone, each file holds its own rest pose: the controls agree (all zero)
///   while the absolute rotations legitimately differ.
/// * the re-export duplicates the Head mesh's morph targets onto three meshes (three
///   `Head_<n>.morph.*` sets instead of one); all weights are zero in both files.
#[test]
fn robot_reexport_gives_the_same_curves() {
    let (Some(a_path), Some(b_path)) = (
        dataset(ROBOT, "robot_reexport_gives_the_same_curves"),
        dataset(REEXPORT, "robot_reexport_gives_the_same_curves"),
    ) else {
        return;
    };
    let (a, b) = (ingest(&a_path, 24.0).unwrap(), ingest(&b_path, 24.0).unwrap());
    let (ga, gb) = (SceneGraph::open(&a_path).unwrap(), SceneGraph::open(&b_path).unwrap());
    assert_eq!(
        a.clips.iter().map(|c| (&c.name, c.frames)).collect::<Vec<_>>(),
        b.clips.iter().map(|c| (&c.name, c.frames)).collect::<Vec<_>>()
    );

    // same joint controls up to naming: normalised "node.channel" → (control index, node name)
    let joint_names = |c: &GltfCurves| -> BTreeMap<String, (usize, String)> {
        c.controls
            .iter()
            .enumerate()
            .filter(|(_, c)| c.group == "joints")
            .map(|(i, c)| {
                let (node, ch) = split_joint(&c.name);
                (format!("{}.{ch}", normalise_node(node)), (i, node.to_string()))
            })
            .collect()
    };
    let (ja, jb) = (joint_names(&a), joint_names(&b));
    assert_eq!(ja.keys().collect::<Vec<_>>(), jb.keys().collect::<Vec<_>>());
    assert_eq!(ja.len(), 90);

    // absolute local transforms agree everywhere
    let (ta, tb) = (absolute_tracks(&a, &ga), absolute_tracks(&b, &gb));
    assert_eq!(ta.keys().collect::<Vec<_>>(), tb.keys().collect::<Vec<_>>());
    let mut compared_rotations = 0;
    for (key, (moves_a, fa)) in &ta {
        let (moves_b, fb) = &tb[key];
        // A property that stays at its rest value in both files is (or may be) not animated
        // by the clip: each file then holds its own rest value (see above) and the controls
        // agree (all zero). If it leaves the rest in either file, the motion must agree.
        let (rot, tr) = (moves_a.0 || moves_b.0, moves_a.1 || moves_b.1);
        compared_rotations += usize::from(rot);
        for (f, ((qa, pa), (qb, pb))) in fa.iter().zip(fb).enumerate() {
            let angle = 2.0 * qa.dot(*qb).abs().min(1.0).acos();
            assert!(!rot || angle < 1e-4, "{key:?} frame {f}: rotations differ by {angle} rad");
            // bone translations are in the armature's units (1/100 of the world): tighter
            assert!(!tr || pa.distance(*pb) < 1e-6, "{key:?} frame {f}: translations {pa} vs {pb}");
        }
    }

    // the 14 clips have 147 rotation channels between them
    assert!(compared_rotations >= 140, "only {compared_rotations} animated rotation tracks compared");

    // raw control values agree wherever the rest transforms agree
    let rest = |g: &SceneGraph, node: &str| -> (DQuat, DVec3) {
        let n = g.nodes.iter().find(|n| n.name == node).unwrap();
        (n.rotation, n.translation)
    };
    let mut differing_rest = BTreeSet::new();
    let (n_a, n_b) = (a.controls.len(), b.controls.len());
    for (name, (ia, node_a)) in &ja {
        let (ib, node_b) = &jb[name];
        let ((qa, ta_), (qb, tb_)) = (rest(&ga, node_a), rest(&gb, node_b));
        if qa.dot(qb).abs() < 1.0 - 1e-10 || ta_.distance(tb_) > 1e-9 {
            differing_rest.insert(normalise_node(node_a));
            continue;
        }
        for (ca, cb) in a.clips.iter().zip(&b.clips) {
            for f in 0..ca.frames {
                let (va, vb) = (ca.values[f * n_a + ia], cb.values[f * n_b + ib]);
                assert!((va - vb).abs() < 1e-4, "{name} clip {} frame {f}: {va} vs {vb}", ca.name);
            }
        }
    }
    let expected: BTreeSet<String> = [
        "body",
        "head",
        "lowerarml",
        "lowerarmr",
        "lowerlegl",
        "lowerlegr",
        "upperarml",
        "upperarmr",
        "upperlegl",
        "upperlegr",
    ]
    .map(String::from)
    .into();
    assert_eq!(differing_rest, expected);

    // morphs: same target names, all zero in every clip of both files
    for c in [&a, &b] {
        let idx: Vec<usize> = (0..c.controls.len()).filter(|&i| c.controls[i].group == "morphs").collect();
        let targets: BTreeSet<&str> = idx.iter().map(|&i| c.controls[i].name.rsplit('.').next().unwrap()).collect();
        assert_eq!(targets, BTreeSet::from(["Angry", "Surprised", "Sad"]));
        let n = c.controls.len();
        assert!(c
            .clips
            .iter()
            .all(|clip| idx.iter().all(|&i| (0..clip.frames).all(|f| clip.values[f * n + i] == 0.0))));
    }
}

/// Prints evaluations per second (release build, one thread) for the lead's report.
#[test]
fn robot_rig_speed() {
    let Some(path) = dataset(ROBOT, "robot_rig_speed") else { return };
    let curves = ingest(&path, 24.0).unwrap();
    let rig = GltfRig::open(&path).unwrap();
    let clip = curves.clip("Dance").unwrap();
    let mut out = vec![0.0; 3 * rig.vertex_count()];
    let n = 2000;
    let t0 = Instant::now();
    for k in 0..n {
        rig.evaluate(curves.frame(clip, k % clip.frames), &mut out);
    }
    let per_sec = n as f64 / t0.elapsed().as_secs_f64();
    eprintln!("RobotExpressive: {} vertices, {per_sec:.0} evaluations/second", rig.vertex_count());
    assert!(per_sec > 200.0, "rig evaluation too slow: {per_sec:.0}/s");
}
