//! Partitioned stages: scale, pca and gplvm run one label at a time, bridges one ordered
//! pair of labels at a time, each cached on its own. Changing one label's frames reruns
//! that label only (and the 2·(L−1) pairs holding it), and the merged outputs equal one
//! run of the stage over every label.

use reprise_artifact::Table;

use crate::util::Project;

/// How many `ran <stage>[<label>]` lines `out` holds for `stage`.
fn partition_runs(out: &str, stage: &str) -> usize {
    out.lines().filter(|l| l.trim_start().starts_with(&format!("ran {stage}["))).count()
}

#[test]
fn one_label_changed_reruns_one_partition_per_stage() {
    let p = Project::dragon_face();
    let toml =
        p.read("pipeline.toml").replace("max_iters = 10000", "max_iters = 15").replace("stride = 1", "stride = 5");
    p.write("pipeline.toml", &toml.replace("heldout_every = 10", "heldout_every = 0"));
    let first = p.reprise(&["run", "--to", "bridges", "--jobs", "2"]).ok();
    for stage in ["scale", "pca", "gplvm"] {
        assert_eq!(partition_runs(&first, stage), 8, "{stage}: every label runs the first time\n{first}");
    }
    assert_eq!(partition_runs(&first, "bridges"), 56, "every ordered pair\n{first}");

    // Six frames of one neutral take excluded: only `neutral` changes downstream of label.
    let labels =
        p.read("datasets/dragon-face/labels.toml") + "\n[[exclude]]\nclip = \"neutral_take01\"\nstart = 0\nend = 5\n";
    p.write("datasets/dragon-face/labels.toml", &labels);
    let second = p.reprise(&["run", "--to", "bridges"]).ok();
    for stage in ["scale", "pca", "gplvm"] {
        assert_eq!(partition_runs(&second, stage), 1, "{stage}\n{second}");
        assert!(second.contains(&format!("ran {stage}[neutral]")), "{second}");
        assert!(second.contains(&format!("{stage}: 1 of 8 labels to run (`neutral`)")), "{second}");
    }
    let pairs: Vec<&str> = second.lines().map(str::trim_start).filter(|l| l.starts_with("ran bridges[")).collect();
    assert_eq!(pairs.len(), 14, "2·(8−1) pairs hold neutral\n{second}");
    assert!(pairs.iter().all(|l| l.contains("[neutral → ") || l.contains(" → neutral]")), "{pairs:?}");

    // The merged outputs equal one run of the stage over all labels on the same inputs
    // (fits are deterministic; segment ids renumbered to the current labeling).
    let a = |f: &str| format!("artifacts/dragon-face/{f}.parquet");
    let args: Vec<String> = [
        ("--coords", a("pca_coords")),
        ("--labeled-frames", a("labeled_frames")),
        ("--pca-models", a("pca_models")),
        ("--scales", a("scales")),
        ("--controls", a("controls")),
        ("--latents", "whole/latents.parquet".into()),
        ("--models", "whole/models.parquet".into()),
        ("--trace", "whole/trace.parquet".into()),
        ("--fits", "whole/fits.parquet".into()),
        ("--max-iters", "15".into()),
        ("--heldout-every", "0".into()),
    ]
    .into_iter()
    .flat_map(|(f, v)| [f.to_string(), v])
    .chain(params(&p))
    .collect();
    p.stage("reprise-gplvm", &args.iter().map(String::as_str).collect::<Vec<_>>()).ok();
    let content = |path: &str| Table::read_any(&p.path(path)).unwrap().metadata()["reprise.content_blake3"].clone();
    for (merged, whole) in [("gplvm_models", "models"), ("gplvm_latents", "latents")] {
        assert_eq!(content(&a(merged)), content(&format!("whole/{whole}.parquet")), "{merged}");
    }
    let bridges: Vec<String> = [
        ("--gplvm-models", a("gplvm_models")),
        ("--pca-models", a("pca_models")),
        ("--scales", a("scales")),
        ("--controls", a("controls")),
        ("--labeled-frames", a("labeled_frames")),
        ("--bridges", "whole/bridges.parquet".into()),
        ("--stride", "5".into()),
    ]
    .into_iter()
    .flat_map(|(f, v)| [f.to_string(), v])
    .collect();
    p.stage("reprise-bridges", &bridges.iter().map(String::as_str).collect::<Vec<_>>()).ok();
    assert_eq!(content(&a("bridges")), content("whole/bridges.parquet"), "bridges");
    let segments = |f: &str| -> Vec<(String, Vec<i64>)> {
        let labels = reprise_artifact::partition::labels_in_order(&p.path(&a(f))).unwrap();
        labels.into_iter().map(|l| (l.label, l.segments)).collect()
    };
    assert_eq!(segments("gplvm_latents"), segments("labeled_frames"), "segment ids are the current labeling's");
    // Downstream checks accept the merged files as one run.
    reprise_artifact::provenance::check_same_run(&p.path(&a("gplvm_latents")), &p.path(&a("gplvm_models")), &[])
        .unwrap();

    // Nothing changed: nothing runs. A stage parameter changed: every label reruns.
    assert!(p.reprise(&["run", "--to", "bridges"]).ok().contains("up to date"));
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("max_iters = 15", "max_iters = 12"));
    assert_eq!(partition_runs(&p.reprise(&["run", "--to", "gplvm"]).ok(), "gplvm"), 8);
}

/// The gplvm parameters of the pipeline other than those the test sets, as flags.
fn params(p: &Project) -> Vec<String> {
    let lock: serde_json::Value = serde_json::from_str(&p.read("artifacts/dragon-face/reprise.lock")).unwrap();
    let params = lock["stages"]["gplvm"]["params"].as_object().unwrap().clone();
    params
        .into_iter()
        .filter(|(k, _)| k != "max_iters" && k != "heldout_every")
        .map(|(k, v)| {
            let v = match v {
                serde_json::Value::String(s) => s,
                other => other.to_string(),
            };
            format!("--{}={v}", k.replace('_', "-"))
        })
        .collect()
}
