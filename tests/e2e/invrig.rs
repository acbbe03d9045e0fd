//! Inverse rig mapping end to end: a mapping learned from curves, positions made from
//! held-out curves, and the curves recovered from the positions alone; on CMU 131 (the
//! paper's Table 1 claims) and on the dragon-face corpus (the roar through label, scale and
//! pca as if it were the animator's); and the stage's answers to bad positions.

use reprise_artifact::frames::{Frames, LabeledFrames};
use reprise_artifact::invrig::{read_errors, FrameError};
use reprise_artifact::positions::Positions;
use reprise_artifact::table::Columns;
use reprise_artifact::Provenance;

use reprise_stagekit::exit;

use crate::util::{shared_dataset, Project};

/// Mean of a column of one method's rows.
fn mean(rows: &[FrameError], method: &str, f: fn(&FrameError) -> f64) -> f64 {
    let r: Vec<f64> = rows.iter().filter(|e| e.method == method).map(f).collect();
    assert!(!r.is_empty(), "no rows of {method}");
    r.iter().sum::<f64>() / r.len() as f64
}

#[test]
fn cmu_hop_recovered_from_joint_positions() {
    let Some(dir) = shared_dataset("cmu_hop_recovered_from_joint_positions", "cmu_bvh") else { return };
    let p = Project::empty();
    p.write(
        "pipeline.toml",
        &format!(
            r#"[pipeline]
name = "cmu"
[stage.ingest]
inputs.bvh = ["{0}/131_01.bvh", "{0}/131_02.bvh", "{0}/131_03.bvh"]
[stage.ingest.params]
fps = 120.0
[stage.invrig-fit]
[stage.invrig-fit.params]
hold_out = ["131_03"]
[stage.positions]
[stage.positions.params]
clips = ["131_03"]
[stage.invrig-apply]
[stage.invrig-apply.params]
compare = ["gpr", "rest-computed-jacobian"]
"#,
            dir.display()
        ),
    );
    p.reprise(&["run"]).ok();
    let rows = read_errors(&p.path("artifacts/cmu/invrig_errors.parquet")).unwrap();
    let frames = |m: &str| rows.iter().filter(|e| e.method == m).count();
    assert_eq!(frames("gpr"), 1102, "every frame of the hop at its 120 fps");
    let je = |m| mean(&rows, m, |e| e.joint_error);
    let te = |m| mean(&rows, m, |e| e.truth_error.expect("the hop's curves are known"));
    // The issue's bar: the computed Jacobian at most halves the regression's joint MSE…
    assert!(je("gpr-computed-jacobian") <= 0.5 * je("gpr"), "{} vs {}", je("gpr-computed-jacobian"), je("gpr"));
    // …and the regression's start beats the rest pose's in the controls (the paper's Fig. 11).
    assert!(
        te("gpr-computed-jacobian") < te("rest-computed-jacobian"),
        "{} vs {}",
        te("gpr-computed-jacobian"),
        te("rest-computed-jacobian")
    );
    let recovered = Frames::read(&p.path("artifacts/cmu/invrig_frames.parquet")).unwrap();
    assert_eq!((recovered.rows(), recovered.controls.len()), (1102, 96));
    let report = p.read("reports/cmu/invrig.md");
    for row in ["| GPR |", "| GPR & computed Jacobian |", "| Rest pose & computed Jacobian |"] {
        assert!(report.contains(row), "{row} missing:\n{report}");
    }
}

/// A dragon-face project whose roar_take01 is recovered from 60 vertices by a small mapping.
fn dragon_roar() -> Project {
    let p = Project::dragon_face();
    p.write(
        "invrig.toml",
        r#"[pipeline]
name = "dragon"
artifacts = "artifacts/dragon"
[stage.ingest]
[stage.ingest.params]
generate = "dragon-face"
[stage.invrig-fit]
[stage.invrig-fit.params]
points = 60
hold_out = ["roar_take*"]
samples = 150
farthest = 30
batch = 40
cv_rows = 300
cv_candidates = 9
cv_rounds = 2
[stage.positions]
[stage.positions.params]
clips = ["roar_take01"]
[stage.invrig-apply]
[stage.invrig-apply.params]
method = "gpr-broyden-jacobian"
compare = ["gpr"]
iterations = 4
carry_clips = true
[stage.label]
inputs.frames = "artifacts/dragon/invrig_frames.parquet"
inputs.labels = "datasets/dragon-face/labels.toml"
[stage.label.params]
mask_group = ["eyes"]
[stage.scale]
[stage.pca]
"#,
    );
    p
}

#[test]
fn dragon_face_roar_from_vertices_is_modelled_like_the_animators_curves() {
    let p = dragon_roar();
    p.reprise(&["run", "-p", "invrig.toml"]).ok();
    let rows = read_errors(&p.path("artifacts/dragon/invrig_errors.parquet")).unwrap();
    let je = |m| mean(&rows, m, |e| e.joint_error);
    assert!(je("gpr-broyden-jacobian") < je("gpr"), "{} vs {}", je("gpr-broyden-jacobian"), je("gpr"));
    // The recovered take replaces the animator's, the other 31 takes are carried.
    let animator = Frames::read(&p.path("artifacts/dragon/frames.parquet")).unwrap();
    let recovered = Frames::read(&p.path("artifacts/dragon/invrig_frames.parquet")).unwrap();
    assert_eq!((recovered.rows(), recovered.clip_runs().len()), (animator.rows(), animator.clip_runs().len()));
    let row = recovered.clip.iter().position(|c| c == "roar_take01").unwrap();
    assert_ne!(recovered.row(row), animator.row(row), "the roar is the mapping's, not the animator's");
    // label, scale and pca read it as curves: the roar is a label with a PCA model.
    let labeled = LabeledFrames::read(&p.path("artifacts/dragon/labeled_frames.parquet")).unwrap();
    assert!(labeled.label.iter().any(|l| l == "roar"));
    let models = reprise_artifact::Table::read_any(&p.path("artifacts/dragon/pca_models.parquet")).unwrap();
    assert!(models.strings("label").unwrap().iter().any(|l| l == "roar"));
}

#[test]
fn bad_positions_are_named_and_unreachable_poses_are_reported() {
    let p = dragon_roar();
    p.reprise(&["run", "-p", "invrig.toml", "--to", "positions"]).ok();
    let apply = |positions: &str| {
        p.stage(
            "reprise-invrig-apply",
            &[
                "--invrig",
                "artifacts/dragon/invrig.parquet",
                "--positions",
                positions,
                "--controls",
                "artifacts/dragon/controls.parquet",
                "--recovered",
                "out/frames.parquet",
                "--errors",
                "out/errors.parquet",
                "--report",
                "out/invrig.md",
                "--method",
                "gpr-broyden-jacobian",
                "--compare",
                "gpr",
                "--iterations",
                "3",
            ],
        )
    };
    // Nothing left to learn from.
    let err = p
        .stage(
            "reprise-invrig-fit",
            &[
                "--frames",
                "artifacts/dragon/frames.parquet",
                "--controls",
                "artifacts/dragon/controls.parquet",
                "--invrig",
                "out/invrig.parquet",
                "--hold-out",
                "*_take*",
            ],
        )
        .fails(exit::INPUT);
    assert!(err.contains("every clip is held out") && err.contains("frames.parquet"), "{err}");

    let good = Positions::read(&p.path("artifacts/dragon/positions.parquet"), None).unwrap();
    let prov = Provenance::new("test", "0", serde_json::json!({}));

    // Other points than the mapping's.
    let mut other = good.clone();
    other.points[5] += 1;
    other.write(&p.path("other.parquet"), &prov).unwrap();
    let err = apply("other.parquet").fails(exit::INPUT);
    assert!(err.contains("other.parquet") && err.contains("first differ at position 5"), "{err}");
    assert!(!p.path("out/frames.parquet").exists(), "nothing written on bad input");

    // A NaN position, written as a user's tool might.
    let n = good.points.len();
    let cols = Columns::new()
        .str("clip", &vec!["roar_take01"; n])
        .i64("frame", vec![0; n])
        .i64("point", good.points.clone())
        .f64_any("x", (0..n).map(|k| if k == 7 { f64::NAN } else { good.values[3 * k] }).collect())
        .f64("y", (0..n).map(|k| good.values[3 * k + 1]).collect())
        .f64("z", (0..n).map(|k| good.values[3 * k + 2]).collect());
    reprise_artifact::table::write(
        &p.path("nan.parquet"),
        reprise_artifact::positions::POSITIONS,
        cols,
        &prov,
        &[("reprise.fps".into(), "24".into())],
    )
    .unwrap();
    let err = apply("nan.parquet").fails(exit::INPUT);
    assert!(err.contains("nan.parquet") && err.contains("`x`") && err.contains("row 7"), "{err}");

    // A face stretched to 1.5 × its size, which the rig cannot reach: answered, with its
    // distance in every frame's row and in the report's worst frame.
    let mut far = good.clone();
    far.values.iter_mut().for_each(|v| *v *= 1.5);
    far.write(&p.path("far.parquet"), &prov).unwrap();
    apply("far.parquet").ok();
    let rows = read_errors(&p.path("out/errors.parquet")).unwrap();
    let worst = rows.iter().map(|e| e.joint_distance).fold(0.0, f64::max);
    assert!(p.read("out/invrig.md").contains(&reprise_invrig_apply::report::sig(worst)));
    apply("artifacts/dragon/positions.parquet").ok();
    let reachable = read_errors(&p.path("out/errors.parquet")).unwrap();
    let d = |rows: &[FrameError]| mean(rows, "gpr-broyden-jacobian", |e| e.joint_distance);
    assert!(d(&rows) > 5.0 * d(&reachable), "unreachable {} vs reachable {}", d(&rows), d(&reachable));
}
