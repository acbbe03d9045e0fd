//! scale and pca through the runner on a rig with known answers: curves from a CSV and
//! the reference external evaluator (a linear rig), for which Eq. 3 has the exact
//! solution `w_j = ‖A_{:,j}‖`.

use reprise_artifact::pca;
use reprise_artifact::scales;
use reprise_rig::linear::LinearRig;

use crate::util::Project;

/// Two labels over four controls; control `k` is constant in label `b`, and the data of
/// label `a` has rank 2 (c2 = c0 + c1, c3 constant). The rig is the reference evaluator.
fn project() -> Project {
    let rig = env!("CARGO_BIN_EXE_reprise-example-rig");
    linear_project(&[rig, "--vertices", "5"])
}

/// [`project`] evaluated by the external rig `command` (program and arguments).
pub(crate) fn linear_project(command: &[&str]) -> Project {
    let p = Project::empty();
    let mut csv = String::from("clip,frame,k0,k1,k2,k3\n");
    for f in 0..40 {
        let t = f64::from(f) / 7.0;
        let (x, y) = (t.sin(), (2.0 * t).cos());
        csv.push_str(&format!("a,{f},{x},{y},{},{}\n", x + y, 0.5));
        csv.push_str(&format!("b,{f},{y},{x},{},{}\n", 0.25 * x, 0.75 * y));
    }
    // Label b holds k0 constant.
    let csv = csv
        .lines()
        .map(|l| {
            if l.starts_with("b,") {
                let mut c: Vec<&str> = l.split(',').collect();
                c[2] = "1.5";
                c.join(",")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    p.write("curves.csv", &csv);
    p.write("labels.toml", "[[rule]]\npattern = \"a\"\nlabel = \"a\"\n[[rule]]\npattern = \"b\"\nlabel = \"b\"\n");
    let command: Vec<String> = command.iter().map(|c| format!("{c:?}")).collect();
    p.write(
        "pipeline.toml",
        &format!(
            r#"[pipeline]
name = "linear"
[stage.ingest]
bin = "reprise-ingest"
inputs.curves = "curves.csv"
outputs.frames = "artifacts/linear/frames.parquet"
outputs.controls = "artifacts/linear/controls.parquet"
outputs.clips = "artifacts/linear/clips.parquet"
[stage.ingest.params]
external_rig = [{}]
[stage.label]
bin = "reprise-label"
inputs.frames = "artifacts/linear/frames.parquet"
inputs.labels = "labels.toml"
outputs.segments = "artifacts/linear/segments.parquet"
outputs.labeled_frames = "artifacts/linear/labeled_frames.parquet"
[stage.scale]
bin = "reprise-scale"
inputs.labeled_frames = "artifacts/linear/labeled_frames.parquet"
inputs.controls = "artifacts/linear/controls.parquet"
outputs.scales = "artifacts/linear/scales.parquet"
[stage.pca]
bin = "reprise-pca"
inputs.labeled_frames = "artifacts/linear/labeled_frames.parquet"
inputs.scales = "artifacts/linear/scales.parquet"
inputs.controls = "artifacts/linear/controls.parquet"
outputs.models = "artifacts/linear/pca_models.parquet"
outputs.coords = "artifacts/linear/pca_coords.parquet"
outputs.errors = "artifacts/linear/pca_errors.parquet"
[stage.pca.params]
min_components = 1
variance = 0.999999
write_unscaled = true
"#,
            command.join(", ")
        ),
    );
    p
}

#[test]
fn scale_recovers_analytic_weights_and_pca_finds_the_rank() {
    let p = project();
    p.reprise(&["run"]).ok();
    let rows = scales::read(&p.path("artifacts/linear/scales.parquet")).unwrap();
    let names: Vec<String> = (0..4).map(|i| format!("k{i}")).collect();
    let rig = LinearRig::new(names, 5);
    for s in &rows {
        let j: usize = s.control[1..].parse().unwrap();
        match (s.label.as_str(), j) {
            ("a", 3) | ("b", 0) => {
                assert!(!s.used && s.reason == "constant" && s.weight == 0.0, "{s:?}");
            }
            _ => {
                assert!(s.used, "{s:?}");
                let exact = rig.column_norm(j);
                assert!((s.weight - exact).abs() < 1e-9 * exact, "{s:?} vs {exact}");
                assert!(s.residual < 1e-9 * exact, "{s:?}");
            }
        }
    }
    let (_, models) = pca::read_models(&p.path("artifacts/linear/pca_models.parquet")).unwrap();
    let a = models.iter().find(|m| m.label == "a" && m.variant == pca::SCALED).unwrap();
    assert_eq!(a.d(), 2, "label a has rank 2");
    let errors: Vec<_> = {
        let t = reprise_artifact::Table::read(&p.path("artifacts/linear/pca_errors.parquet"), pca::PCA_ERRORS).unwrap();
        let (l, d, m) = (t.str("label").unwrap(), t.i64("d").unwrap().to_vec(), t.f64("mesh_rmse").unwrap().to_vec());
        l.into_iter().map(String::from).zip(d).zip(m).collect()
    };
    // At its full rank a label reconstructs exactly, in mesh space too.
    assert!(errors.iter().any(|((l, d), m)| l == "a" && *d == 2 && *m < 1e-9), "{errors:?}");
    let coords = pca::read_coords(&p.path("artifacts/linear/pca_coords.parquet")).unwrap();
    assert_eq!(coords.y.len(), 2 * 80, "both variants of both labels");
}

#[test]
fn mesh_stages_without_a_rig_say_so() {
    let p = project();
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("external_rig = [", "# external_rig = ["));
    let out = p.reprise(&["run"]).fails(reprise_stagekit::exit::INPUT);
    assert!(out.contains("names no rig"), "{out}");
}

/// An evaluator that answers NaN made `scale` exit 0 with `weight = NaN`, and after the
/// evaluator was fixed the next run still said `cached scale`. Now scale fails naming the
/// evaluator and the pose, writes nothing, and fixing the evaluator is enough.
#[cfg(unix)]
#[test]
fn a_nan_evaluator_fails_scale_and_fixing_it_is_enough() {
    use std::os::unix::fs::PermissionsExt;
    let rig = env!("CARGO_BIN_EXE_reprise-example-rig");
    // The evaluator is a script the user edits: the pipeline's command stays the same.
    let script = |flags: &str| format!("#!/bin/sh\nexec {rig} --vertices 5 {flags} \"$@\"\n");
    let dir = tempfile::tempdir().unwrap();
    let rig_sh = dir.path().join("rig.sh");
    std::fs::write(&rig_sh, script("--nan-after 1")).unwrap();
    std::fs::set_permissions(&rig_sh, std::fs::Permissions::from_mode(0o755)).unwrap();
    let p = linear_project(&[rig_sh.to_str().unwrap()]);
    let out = p.reprise(&["run", "--to", "scale"]).fails(reprise_stagekit::exit::INPUT);
    assert!(out.contains("it answered NaN for vertex 0 (x) of a pose") && out.contains("rig.sh"), "{out}");
    assert!(!p.path("artifacts/linear/scales.parquet").exists(), "nothing written");
    std::fs::write(&rig_sh, script("")).unwrap();
    let out = p.reprise(&["run", "--to", "scale"]).ok();
    assert!(out.contains("running scale") && !out.contains("cached scale"), "{out}");
    assert!(scales::read(&p.path("artifacts/linear/scales.parquet")).unwrap().iter().all(|s| s.weight.is_finite()));
}
