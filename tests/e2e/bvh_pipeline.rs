//! A real motion-capture take (CMU 131_03, BVH) through ingest, label, scale and pca,
//! with its skeleton as the rig.

use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::frames::Frames;
use reprise_artifact::scales;

use crate::util::{shared_dataset, Project};

#[test]
fn cmu_hop_through_pca() {
    let Some(bvh) = shared_dataset("cmu_hop_through_pca", "cmu_bvh/131_03.bvh") else { return };
    let p = Project::empty();
    p.write("labels.toml", "[[range]]\nclip = \"131_03\"\nstart = 0\nend = 80\nlabel = \"start\"\n[[range]]\nclip = \"131_03\"\nstart = 81\nend = 220\nlabel = \"hop\"\n");
    p.write(
        "pipeline.toml",
        &format!(
            r#"[pipeline]
name = "cmu"
[stage.ingest]
bin = "reprise-ingest"
inputs.bvh = "{}"
outputs.frames = "artifacts/cmu/frames.parquet"
outputs.controls = "artifacts/cmu/controls.parquet"
outputs.clips = "artifacts/cmu/clips.parquet"
[stage.label]
bin = "reprise-label"
inputs.frames = "artifacts/cmu/frames.parquet"
inputs.labels = "labels.toml"
outputs.segments = "artifacts/cmu/segments.parquet"
outputs.labeled_frames = "artifacts/cmu/labeled_frames.parquet"
[stage.scale]
bin = "reprise-scale"
inputs.labeled_frames = "artifacts/cmu/labeled_frames.parquet"
inputs.controls = "artifacts/cmu/controls.parquet"
outputs.scales = "artifacts/cmu/scales.parquet"
[stage.pca]
bin = "reprise-pca"
inputs.labeled_frames = "artifacts/cmu/labeled_frames.parquet"
inputs.scales = "artifacts/cmu/scales.parquet"
inputs.controls = "artifacts/cmu/controls.parquet"
outputs.models = "artifacts/cmu/pca_models.parquet"
outputs.coords = "artifacts/cmu/pca_coords.parquet"
outputs.errors = "artifacts/cmu/pca_errors.parquet"
"#,
            bvh.display()
        ),
    );
    p.reprise(&["run"]).ok();
    let frames = Frames::read(&p.path("artifacts/cmu/frames.parquet")).unwrap();
    assert_eq!(frames.rows(), (1102 - 1) / 5 + 1, "120 fps resampled to 24");
    assert_eq!(frames.controls.len(), 96);
    let controls = Controls::read(&p.path("artifacts/cmu/controls.parquet")).unwrap();
    assert!(matches!(controls.rig, RigRef::Bvh { .. }));
    let s = scales::read(&p.path("artifacts/cmu/scales.parquet")).unwrap();
    // The hips' rotation moves every joint; a finger's barely any.
    let w = |c: &str| s.iter().find(|r| r.label == "hop" && r.control == c).unwrap().weight;
    assert!(w("Hips.ry") > 5.0 * w("LThumb.rx"), "{} vs {}", w("Hips.ry"), w("LThumb.rx"));
    assert!(p.path("artifacts/cmu/pca_errors.parquet").exists());
}
