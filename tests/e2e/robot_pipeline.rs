//! The RobotExpressive pipeline (`datasets/robot-expressive/`) end to end through synthesis and glTF export,
//! on the real glTF character read in place from `../shared`.

use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::pca;
use reprise_artifact::segments;

use crate::util::{repo, shared_dataset, Project};

#[test]
fn robot_expressive_through_gplvm() {
    let Some(glb) = shared_dataset("robot_expressive_through_gplvm", "robot_expressive/RobotExpressive.glb") else {
        return;
    };
    let p = Project::empty();
    let toml = std::fs::read_to_string(repo().join("datasets/robot-expressive/pipeline.toml"))
        .unwrap()
        .replace("../../../shared/datasets/robot_expressive/RobotExpressive.glb", &glb.display().to_string())
        .replace("../../artifacts", "artifacts")
        .replace("../../reports", "reports")
        .replace("max_iters = 10000", "max_iters = 20");
    p.write("pipeline.toml", &toml);
    p.write("labels.toml", &std::fs::read_to_string(repo().join("datasets/robot-expressive/labels.toml")).unwrap());
    p.write(
        "scripts/demo.toml",
        &std::fs::read_to_string(repo().join("datasets/robot-expressive/scripts/demo.toml")).unwrap(),
    );
    p.reprise(&["run"]).ok();
    let controls = Controls::read(&p.path("artifacts/robot-expressive/controls.parquet")).unwrap();
    assert!(matches!(controls.rig, RigRef::Gltf { .. }));
    let segs = segments::read(&p.path("artifacts/robot-expressive/segments.parquet")).unwrap();
    let labels: std::collections::BTreeSet<&str> = segs.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(labels.len(), 7, "{labels:?}");
    assert!(!segs.iter().any(|s| s.clip == "Death" || s.clip == "Sitting"));
    let (_, models) = pca::read_models(&p.path("artifacts/robot-expressive/pca_models.parquet")).unwrap();
    assert_eq!(models.len(), 7);
    assert!(models.iter().all(|m| m.d() >= 3));
    let gplvm = reprise_label_models::load(
        &p.path("artifacts/robot-expressive/gplvm_models.parquet"),
        &p.path("artifacts/robot-expressive/pca_models.parquet"),
        &p.path("artifacts/robot-expressive/scales.parquet"),
    )
    .unwrap();
    assert_eq!(gplvm.models.len(), 7);

    // The synthesized scripts, exported into a copy of the character, re-ingest to the
    // same poses: the same mesh to Float32 precision (a rotation vector may come back as
    // an equivalent one, 2π apart).
    let curves = reprise_artifact::curves::read(&p.path("artifacts/robot-expressive/curves.parquet")).unwrap();
    let exported =
        reprise_gltf::ingest(&p.path("artifacts/robot-expressive/RobotExpressive_reprise.glb"), 24.0).unwrap();
    assert_eq!(exported.clips.len(), 14 + 2);
    let rig = reprise_gltf::GltfRig::open(&glb).unwrap();
    assert_eq!(rig.control_names(), exported.controls.iter().map(|c| c.name.clone()).collect::<Vec<_>>());
    let n = curves.controls.len();
    for script in ["greeting", "no_then_yes"] {
        let clip = exported.clip(&format!("reprise_{script}")).unwrap();
        let rows: Vec<usize> = (0..curves.script.len()).filter(|&r| curves.script[r] == script).collect();
        assert_eq!(clip.frames, rows.len(), "{script}");
        let mut worst: f64 = 0.0;
        for (f, &r) in rows.iter().enumerate() {
            let mut pose = rig.default_controls();
            for (c, name) in curves.controls.iter().enumerate() {
                pose[exported.control_index(name).unwrap()] = curves.values[r * n + c];
            }
            let (a, b) = (rig.evaluate_to_vec(&pose), rig.evaluate_to_vec(exported.frame(clip, f)));
            worst = worst.max(a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max));
        }
        assert!(worst < 1e-4, "{script}: largest vertex difference after export and re-ingest {worst}");
    }
    // Its own comparison report.
    let md = p.read("reports/robot-expressive/report.md");
    for system in ["reprise", "Motion Graphs", "Motion matching", "Crossfade"] {
        assert!(md.contains(&format!("**{system}** is best on")), "{md}");
    }
    assert!(p.read("reports/robot-expressive/index.html").contains("id='coverage'"));
    // The character file is the rig: a file whose content differs from what ingest read
    // is refused, not silently evaluated.
    let RigRef::Gltf { path, .. } = &controls.rig else { unreachable!() };
    let stale = RigRef::Gltf { path: path.clone(), blake3: "0".repeat(64) };
    let err = reprise_rig::open(&stale, std::path::Path::new("."), &[], &[]).err().unwrap().to_string();
    assert!(err.contains("changed since ingest"), "{err}");

    // A lost lock costs a rerun, never a refusal: the report and the exported character
    // say which stage of which pipeline wrote them (they were refused as "no stage of
    // this pipeline wrote").
    std::fs::remove_file(p.path("artifacts/robot-expressive/reprise.lock")).unwrap();
    let out = p.reprise(&["run"]).ok();
    assert!(out.contains("running evaluate") && out.contains("running export "), "{out}");
    assert!(p
        .read("reports/robot-expressive/report.md")
        .contains("<!-- reprise:stage=evaluate;pipeline=robot-expressive -->"));

    // A second pipeline writing into the same artifacts directory is refused, naming both;
    // `--adopt-artifacts` takes the directory over.
    p.write("other.toml", &toml.replace("name = \"robot-expressive\"", "name = \"robot-two\""));
    let err = p.reprise(&["run", "-p", "other.toml", "--to", "ingest"]).fails(2);
    assert!(
        err.contains("belongs to pipeline `robot-expressive`") && err.contains("running `robot-two` there"),
        "{err}"
    );
    let out = p.reprise(&["run", "-p", "other.toml", "--to", "ingest", "--adopt-artifacts"]).ok();
    assert!(out.contains("adopting"), "{out}");
    let err = p.reprise(&["run", "--to", "ingest"]).fails(2);
    assert!(err.contains("belongs to pipeline `robot-two`"), "{err}");
}
