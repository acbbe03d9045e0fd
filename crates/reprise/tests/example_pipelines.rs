//! The example pipelines that extend the default one keep its settings.

use std::path::Path;

fn read(rel: &str) -> toml::Table {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(rel);
    std::fs::read_to_string(&path).unwrap().parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `datasets/dragon-face-invrig` models the recovered corpus exactly as the default
/// pipeline models the animator's: every stage after ingest has the default's parameters.
#[test]
fn the_invrig_dragon_face_pipeline_models_like_the_default() {
    let default = read("pipeline.toml");
    let invrig = read("datasets/dragon-face-invrig/pipeline.toml");
    let stages = |t: &toml::Table| t["stage"].as_table().unwrap().clone();
    let (d, i) = (stages(&default), stages(&invrig));
    for (name, table) in d.iter().filter(|(n, _)| n.as_str() != "ingest") {
        let params = |t: &toml::Value| t.get("params").cloned();
        let other = i.get(name).unwrap_or_else(|| panic!("stage `{name}` missing"));
        assert_eq!(params(other), params(table), "stage `{name}`'s parameters differ from pipeline.toml's");
    }
    assert_eq!(stages(&default)["ingest"]["params"], stages(&invrig)["ingest"]["params"]);
}
