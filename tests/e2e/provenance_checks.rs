//! Inputs from different runs are refused: an artifact whose provenance says it was made
//! from other files than the ones the stage was given.

use reprise_stagekit::exit;

use crate::util::Project;

/// `scales` from the rig of seed 8, fed to a pca given the seed-7 controls: refused,
/// naming both controls files.
#[test]
fn scales_of_another_rig_are_refused_by_pca() {
    let p = Project::dragon_face();
    p.reprise(&["run", "--to", "scale"]).ok();
    let seed8 = p.read("pipeline.toml").replace("artifacts/dragon-face", "artifacts/seed8").replace("seed = 7", "seed = 8");
    p.write("pipeline8.toml", &seed8.replace("name = \"dragon-face\"", "name = \"seed8\""));
    p.reprise(&["run", "--pipeline", "pipeline8.toml", "--to", "scale"]).ok();
    p.write(
        "mix.toml",
        r#"[pipeline]
name = "mix"
[stage.pca]
bin = "reprise-pca"
inputs.labeled_frames = "artifacts/dragon-face/labeled_frames.parquet"
inputs.scales = "artifacts/seed8/scales.parquet"
inputs.controls = "artifacts/dragon-face/controls.parquet"
outputs.models = "artifacts/mix/pca_models.parquet"
outputs.coords = "artifacts/mix/pca_coords.parquet"
outputs.errors = "artifacts/mix/pca_errors.parquet"
"#,
    );
    let out = p.reprise(&["run", "--pipeline", "mix.toml"]).fails(exit::INPUT);
    assert!(
        out.contains("artifacts/seed8/scales.parquet: was made by `scale` from controls `artifacts/seed8/controls.parquet`")
            && out.contains("given controls `artifacts/dragon-face/controls.parquet`, whose content differs"),
        "{out}"
    );
    assert!(!p.path("artifacts/mix/pca_models.parquet").exists());
}
