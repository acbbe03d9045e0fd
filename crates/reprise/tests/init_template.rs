//! `reprise init`'s pipeline template copies no stage default: every parameter it writes
//! differs from the default of the stage that reads it (a default lives in the stage's
//! flags only, so it cannot drift from a copy), and names a flag the stage has.

use reprise_init::{pipeline_text, Source};

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
    let text =
        pipeline_text(reprise::STAGES, "kenney", &Source::Gltf("character.glb".into()), Some(30.0), "labels.toml")
            .unwrap();
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

/// For every kind of source the template is a pipeline the runner reads, with a table per
/// stage the runner knows (`export-gltf` only for a glTF character), in at most 40 lines
/// besides comments; a stage needing a user's file init cannot name is refused.
#[test]
fn every_template_is_a_short_pipeline_of_every_stage() {
    let sources = [
        Source::Gltf("character.glb".into()),
        Source::Bvh(vec!["takes/*.bvh".into()]),
        Source::Bvh(vec!["a.bvh".into(), "b.bvh".into()]),
        Source::Curves { table: "curves.csv".into(), rig: vec!["rig-engine".into(), "--fast".into()] },
    ];
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::create_dir(dir.join("takes")).unwrap();
    std::fs::write(dir.join("takes/a.bvh"), "").unwrap();
    for source in &sources {
        let text = pipeline_text(reprise::STAGES, "c", source, None, "labels.toml").unwrap();
        let lines = text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')).count();
        assert!(lines <= 40, "{lines} lines:\n{text}");
        let pipeline = reprise_runner::pipeline::Pipeline::parse_wired(&text, "pipeline.toml", dir, reprise::STAGES)
            .unwrap_or_else(|e| panic!("{e}\n{text}"));
        let names: Vec<&str> = pipeline.stages.iter().map(|s| s.name.as_str()).collect();
        let want: Vec<&str> = reprise::STAGES
            .iter()
            .map(|w| w.stage)
            .filter(|s| *s != "export-gltf" || matches!(source, Source::Gltf(_)))
            .filter(|s| !reprise_init::OTHER_JOBS.contains(s))
            .collect();
        assert_eq!(names, want);
        assert!(!text.contains("fps ="), "no --fps, no fps: ingest's own default");
    }
    let with_fps = pipeline_text(reprise::STAGES, "c", &sources[0], Some(30.0), "l.toml").unwrap();
    assert!(with_fps.contains("[stage.ingest.params]\nfps = 30.0"), "{with_fps}");

    const NEEDY: [reprise_stagekit::wiring::Wiring; 1] = [reprise_stagekit::wiring::Wiring {
        stage: "needy",
        bin: "reprise-needy",
        inputs: &[reprise_stagekit::wiring::source("notes", "a notes file")],
        outputs: &[],
        derived: &[],
        partition: reprise_stagekit::wiring::Partition::Whole,
    }];
    let e = pipeline_text(&NEEDY, "c", &sources[0], None, "l.toml").unwrap_err().to_string();
    assert!(e.contains("stage `needy` needs your own a notes file (`inputs.notes`)"), "{e}");
}
