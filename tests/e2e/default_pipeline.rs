//! The README's first command on the built-in dragon-face corpus, and the cache.

use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::frames::{Frames, LabeledFrames};
use reprise_artifact::segments;
use reprise_artifact::Table;

use crate::util::Project;

#[test]
fn dragon_face_through_label_then_cached_then_one_param_changed() {
    let p = Project::dragon_face();
    // The whole README pipeline, with a short GPLVM fit (the default budget is benchmarked).
    let toml =
        p.read("pipeline.toml").replace("max_iters = 10000", "max_iters = 10").replace("stride = 1", "stride = 5");
    p.write("pipeline.toml", &toml.replace("heldout_every = 10", "heldout_every = 0"));
    let first = p.reprise(&["run"]).ok();
    assert!(
        first.contains("ingest")
            && first.contains("label")
            && first.contains("ran gplvm")
            && first.contains("ran synthesize"),
        "{first}"
    );
    assert!(p.path("artifacts/dragon-face/gplvm_models.parquet").exists());

    let frames = Frames::read(&p.path("artifacts/dragon-face/frames.parquet")).unwrap();
    assert!((700..=800).contains(&frames.controls.len()), "{} controls", frames.controls.len());
    assert_eq!(frames.fps, 24.0);
    let controls = Controls::read(&p.path("artifacts/dragon-face/controls.parquet")).unwrap();
    assert!(matches!(controls.rig, RigRef::DragonFace { seed: 7, .. }));

    let segs = segments::read(&p.path("artifacts/dragon-face/segments.parquet")).unwrap();
    let labeled = LabeledFrames::read(&p.path("artifacts/dragon-face/labeled_frames.parquet")).unwrap();
    let labels = ["happy", "grumpy", "bored", "curious", "neutral", "roar", "head_shake", "surprise"];
    for label in labels {
        let n: i64 = segs.iter().filter(|s| s.label == label).map(|s| s.frames()).sum();
        assert!((100..=800).contains(&n), "label {label}: {n} frames");
    }
    assert_eq!(labeled.frames.rows(), 3745, "labeled frames");
    assert!(labeled.frames.rows() < frames.rows(), "bad takes are excluded");
    assert!(labeled.masked_controls.iter().all(|c| c.starts_with("eye")), "{:?}", labeled.masked_controls);

    // At the paper's 0.85, every label needs more components than the 3-D latent space
    // (d_gplvm < d_pca), and the threshold, not the `min_components` guard, sets d.
    let (_, models) = reprise_artifact::pca::read_models(&p.path("artifacts/dragon-face/pca_models.parquet")).unwrap();
    for m in models.iter().filter(|m| m.variant == reprise_artifact::pca::SCALED) {
        let d = m.d();
        let before: f64 = m.explained[..d - 1].iter().sum();
        assert!(d >= 4 && before < 0.85, "{}: d = {d}, {before:.3} explained by {} components", m.label, d - 1);
    }
    assert!(!labeled.masked_controls.is_empty());
    let prov =
        Table::read(&p.path("artifacts/dragon-face/labeled_frames.parquet"), reprise_artifact::frames::LABELED_FRAMES)
            .unwrap()
            .provenance()
            .unwrap();
    assert_eq!(prov.stage, "label");
    assert_eq!(prov.inputs.len(), 3);

    // Nothing changed: no stage runs.
    let second = p.reprise(&["run"]).ok();
    assert!(!second.contains("ran "), "{second}");
    assert!(second.contains("up to date"), "{second}");

    // One label parameter changed: status says why, then only label reruns.
    let toml = p.read("pipeline.toml").replace("min_segment_length = 12", "min_segment_length = 24");
    p.write("pipeline.toml", &toml);
    let status = p.reprise(&["status"]).ok();
    assert!(status.contains("min_segment_length"), "{status}");
    let frames_before = std::fs::read(p.path("artifacts/dragon-face/frames.parquet")).unwrap();
    let third = p.reprise(&["run"]).ok();
    assert!(third.contains("label") && !third.contains("ran ingest"), "{third}");
    assert_eq!(std::fs::read(p.path("artifacts/dragon-face/frames.parquet")).unwrap(), frames_before);

    // inspect summarises an artifact with its provenance.
    let inspect = p.reprise(&["inspect", "artifacts/dragon-face/segments.parquet"]).ok();
    assert!(inspect.contains("segment_id") && inspect.contains("reprise.stage"), "{inspect}");
}
