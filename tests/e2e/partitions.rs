//! Partitioned stages: scale, pca and gplvm run one label at a time, bridges one ordered
//! pair of labels at a time, each cached on its own. Changing one label's frames reruns
//! that label only (and the 2·(L−1) pairs holding it), and the merged outputs equal one
//! run of the stage over every label.

use std::collections::BTreeMap;

use reprise_artifact::Table;

use crate::util::Project;

/// Each partition of each stage in the lock, with its key.
fn partition_keys(p: &Project) -> BTreeMap<(String, String), String> {
    let lock: serde_json::Value = serde_json::from_str(&p.read("artifacts/dragon-face/reprise.lock")).unwrap();
    let mut keys = BTreeMap::new();
    for (stage, entry) in lock["stages"].as_object().unwrap() {
        for (name, record) in entry["partitions"].as_object().into_iter().flatten() {
            keys.insert((stage.clone(), name.clone()), record["key"].as_str().unwrap().to_string());
        }
    }
    keys
}

/// The partitions of `stage` whose key changed from `before` to `after` (those that ran),
/// or all of them when `before` is empty. Counted from the lock, not the log, whose lines
/// stages running side by side may interleave.
fn reran(
    before: &BTreeMap<(String, String), String>,
    after: &BTreeMap<(String, String), String>,
    stage: &str,
) -> Vec<String> {
    after
        .iter()
        .filter(|(at, key)| at.0 == stage && before.get(*at) != Some(*key))
        .map(|((_, name), _)| name.clone())
        .collect()
}

#[test]
fn one_label_changed_reruns_one_partition_per_stage() {
    let p = Project::dragon_face();
    let toml =
        p.read("pipeline.toml").replace("max_iters = 10000", "max_iters = 15").replace("stride = 1", "stride = 5");
    p.write("pipeline.toml", &toml.replace("heldout_every = 10", "heldout_every = 0"));
    p.reprise(&["run", "--to", "bridges", "--jobs", "2"]).ok();
    let first = partition_keys(&p);
    for stage in ["scale", "pca", "gplvm"] {
        assert_eq!(reran(&BTreeMap::new(), &first, stage).len(), 8, "{stage}: every label runs the first time");
    }
    assert_eq!(reran(&BTreeMap::new(), &first, "bridges").len(), 56, "every ordered pair");

    // Six frames of one neutral take excluded: only `neutral` changes downstream of label.
    let labels =
        p.read("datasets/dragon-face/labels.toml") + "\n[[exclude]]\nclip = \"neutral_take01\"\nstart = 0\nend = 5\n";
    p.write("datasets/dragon-face/labels.toml", &labels);
    let second = p.reprise(&["run", "--to", "bridges"]).ok();
    let after = partition_keys(&p);
    for stage in ["scale", "pca", "gplvm"] {
        assert_eq!(reran(&first, &after, stage), ["neutral"], "{stage}\n{second}");
        assert!(second.contains(&format!("{stage}: 1 of 8 labels to run (`neutral`)")), "{second}");
    }
    let pairs = reran(&first, &after, "bridges");
    assert_eq!(pairs.len(), 14, "2·(8−1) pairs hold neutral: {pairs:?}\n{second}");
    assert!(pairs.iter().all(|l| l.starts_with("neutral → ") || l.ends_with(" → neutral")), "{pairs:?}");
    assert!(second.contains("bridges: 14 of 56 label pairs to run"), "{second}");

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
    let content = |path: &str| {
        Table::read_any(&p.path(path)).unwrap().metadata()[reprise_artifact::provenance::KEY_CONTENT].clone()
    };
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
    p.reprise(&["run", "--to", "gplvm"]).ok();
    assert_eq!(reran(&after, &partition_keys(&p), "gplvm").len(), 8);
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
