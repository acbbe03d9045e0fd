//! The RobotExpressive pipeline (`datasets/robot-expressive/`) end to end through gplvm,
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
        .replace("max_iters = 300", "max_iters = 20");
    p.write("pipeline.toml", &toml);
    p.write("labels.toml", &std::fs::read_to_string(repo().join("datasets/robot-expressive/labels.toml")).unwrap());
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
    let gplvm = reprise_model::load(
        &p.path("artifacts/robot-expressive/gplvm_models.parquet"),
        &p.path("artifacts/robot-expressive/pca_models.parquet"),
        &p.path("artifacts/robot-expressive/scales.parquet"),
    )
    .unwrap();
    assert_eq!(gplvm.models.len(), 7);
    // The character file is the rig: a file whose content differs from what ingest read
    // is refused, not silently evaluated.
    let RigRef::Gltf { path, .. } = &controls.rig else { unreachable!() };
    let stale = RigRef::Gltf { path: path.clone(), blake3: "0".repeat(64) };
    let err = reprise_rig::open(&stale, std::path::Path::new("."), &[], &[]).err().unwrap().to_string();
    assert!(err.contains("changed since ingest"), "{err}");
}
