//! `reprise init`'s pipeline template copies no stage default: every parameter it writes
//! differs from the default of the stage that reads it (a default lives in the stage's
//! flags only, so it cannot drift from a copy), and names a flag the stage has.

use reprise_runner::init::{pipeline_text, Source};

/// The `[stage.NAME.params]` entries of a pipeline text: (stage, key, value without quotes
/// or comment).
fn params(text: &str) -> Vec<(String, String, String)> {
    let mut stage = None;
    let mut out = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('[') {
            stage = line.strip_prefix("[stage.").and_then(|l| l.strip_suffix(".params]")).map(str::to_string);
            continue;
        }
        let (Some(stage), Some((key, value))) = (&stage, line.split_once('=')) else { continue };
        let value = value.split('#').next().unwrap_or_default().trim().trim_matches('"');
        out.push((stage.clone(), key.trim().to_string(), value.to_string()));
    }
    out
}

fn command(stage: &str) -> clap::Command {
    reprise::command(stage).unwrap_or_else(|| panic!("the template has a stage `{stage}` reprise does not have"))
}

/// Whether two flag values are the same (numbers compared as numbers: `16.0` is `16`).
fn same(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

#[test]
fn the_init_template_writes_only_what_differs_from_the_stages() {
    let text = pipeline_text("kenney", &Source::Gltf("character.glb".into()), 30.0, "labels.toml");
    let params = params(&text);
    assert!(params.iter().any(|(s, k, _)| s == "gplvm" && k == "heldout_every"), "{text}");
    for (stage, key, value) in &params {
        let cmd = command(stage);
        let arg = cmd
            .get_arguments()
            .find(|a| a.get_id().as_str() == key)
            .unwrap_or_else(|| panic!("`{stage}` has no flag for the template's `{key}`"));
        let defaults: Vec<String> = arg.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
        assert!(
            !(defaults.len() == 1 && same(&defaults[0], value)),
            "the template sets `{stage}.{key} = {value}`, the stage's own default: leave it to the stage"
        );
    }
}

/// The parser above reads what it must: a section's entries, unquoted, without comments;
/// and the comparison takes `16.0` for `16`.
#[test]
fn the_template_reader_reads_entries() {
    let p = params("[stage.a]\n[stage.a.params]\nx = 1.0  # one\ny = \"s\"\n[stage.b]\nz = 3\n");
    assert_eq!(p, vec![("a".into(), "x".into(), "1.0".into()), ("a".into(), "y".into(), "s".into())]);
    assert!(same("16.0", "16") && !same("0.2", "0.25") && same("lbfgs", "lbfgs"));
}
