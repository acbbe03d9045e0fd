//! Inputs from different runs are refused: an artifact whose provenance says it was made
//! from other files than the ones the stage was given.

use reprise_stagekit::exit;

use crate::util::Project;

/// The seed-7 `scales` (and `labeled_frames`) given to pca (and scale) beside the
/// controls of the seed-8 rig: refused, naming both controls files.
#[test]
fn artifacts_of_another_rig_are_refused_by_scale_and_pca() {
    let p = Project::dragon_face();
    p.reprise(&["run", "--to", "scale"]).ok();
    let seed8 =
        p.read("pipeline.toml").replace("artifacts/dragon-face", "artifacts/seed8").replace("seed = 7", "seed = 8");
    p.write("pipeline8.toml", &seed8.replace("name = \"dragon-face\"", "name = \"seed8\""));
    p.reprise(&["run", "--pipeline", "pipeline8.toml", "--to", "ingest"]).ok();
    p.write(
        "mix.toml",
        r#"[pipeline]
name = "mix"
[stage.pca]
bin = "reprise-pca"
inputs.labeled_frames = "artifacts/dragon-face/labeled_frames.parquet"
inputs.scales = "artifacts/dragon-face/scales.parquet"
inputs.controls = "artifacts/seed8/controls.parquet"
outputs.models = "artifacts/mix/pca_models.parquet"
outputs.coords = "artifacts/mix/pca_coords.parquet"
outputs.errors = "artifacts/mix/pca_errors.parquet"
"#,
    );
    let out = p.reprise(&["run", "--pipeline", "mix.toml"]).fails(exit::INPUT);
    assert!(
        out.contains("artifacts/dragon-face/scales.parquet: was made by `scale` from controls `artifacts/dragon-face/controls.parquet`")
            && out.contains("given controls `artifacts/seed8/controls.parquet`, whose content differs"),
        "{out}"
    );
    assert!(!p.path("artifacts/mix/pca_models.parquet").exists());
    let scale =
        p.read("mix.toml").replace("[stage.pca]\nbin = \"reprise-pca\"", "[stage.scale]\nbin = \"reprise-scale\"");
    let scale = scale.replace("inputs.scales = \"artifacts/dragon-face/scales.parquet\"\n", "");
    let scale = scale.replace("outputs.models = \"artifacts/mix/pca_models.parquet\"\noutputs.coords = \"artifacts/mix/pca_coords.parquet\"\noutputs.errors = \"artifacts/mix/pca_errors.parquet\"", "outputs.scales = \"artifacts/mix/scales.parquet\"");
    p.write("mix.toml", &scale);
    let out = p.reprise(&["run", "--pipeline", "mix.toml"]).fails(exit::INPUT);
    assert!(out.contains("labeled_frames.parquet: was made by `label` from controls"), "{out}");
}
