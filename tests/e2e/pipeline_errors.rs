//! Bad pipelines and failing stages: a clear message, a non-zero exit, earlier
//! artifacts untouched, and the lock recording only stages that succeeded.

use reprise_stagekit::exit;

use crate::util::Project;

const CSV: &str = "clip,frame,jaw,brow\na,0,0,1\na,1,1,1\na,2,2,0\nb,0,1,1\nb,1,0,1\n";

/// A two-stage pipeline over a small CSV: ingest, then label.
fn small(extra_label_params: &str) -> Project {
    let p = Project::empty();
    p.write("curves.csv", CSV);
    p.write("labels.toml", "[[rule]]\npattern = \"*\"\nlabel = \"all\"\n");
    p.write(
        "pipeline.toml",
        &format!(
            r#"[pipeline]
name = "small"

[stage.ingest]
bin = "reprise-ingest"
inputs.curves = "curves.csv"
outputs.frames = "artifacts/small/frames.parquet"
outputs.controls = "artifacts/small/controls.parquet"
outputs.clips = "artifacts/small/clips.parquet"

[stage.label]
bin = "reprise-label"
inputs.frames = "artifacts/small/frames.parquet"
inputs.labels = "labels.toml"
outputs.segments = "artifacts/small/segments.parquet"
outputs.labeled_frames = "artifacts/small/labeled_frames.parquet"
[stage.label.params]
{extra_label_params}
"#
        ),
    );
    p
}

#[test]
fn small_csv_pipeline_runs() {
    let p = small("min_segment_length = 1");
    p.reprise(&["run"]).ok();
    assert!(p.path("artifacts/small/labeled_frames.parquet").exists());
}

#[test]
fn unknown_key_in_pipeline_toml() {
    let p = small("");
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("inputs.labels", "inputz.labels"));
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(out.contains("pipeline.toml") && out.contains("inputz"), "{out}");
    assert!(!p.path("artifacts/small/frames.parquet").exists());
}

#[test]
fn unknown_parameter_is_caught_before_any_stage_runs() {
    let p = small("min_segmnt_length = 3");
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(out.contains("label") && out.contains("min-segmnt-length"), "{out}");
    assert!(!p.path("artifacts/small/frames.parquet").exists(), "ingest must not have run");
}

#[test]
fn dependency_cycle_and_unknown_stage() {
    let p = small("");
    let cyclic = p.read("pipeline.toml").replace(
        "[stage.ingest]\nbin = \"reprise-ingest\"\n",
        "[stage.ingest]\nbin = \"reprise-ingest\"\nafter = [\"label\"]\n",
    );
    p.write("pipeline.toml", &cyclic);
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(out.contains("cycle") && out.contains("ingest") && out.contains("label"), "{out}");
    let unknown = small("").read("pipeline.toml").replace(
        "[stage.ingest]\nbin = \"reprise-ingest\"\n",
        "[stage.ingest]\nbin = \"reprise-ingest\"\nafter = [\"scale\"]\n",
    );
    p.write("pipeline.toml", &unknown);
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(out.contains("scale"), "{out}");
}

/// Bad data in the middle of a run: ingest's outputs stay and are locked, label's
/// error names the labels file and entry, and label is not recorded.
#[test]
fn failing_stage_keeps_earlier_artifacts() {
    let p = small("");
    p.write("labels.toml", "[[range]]\nclip = \"c\"\nstart = 0\nend = 1\nlabel = \"x\"\n");
    let out = p.reprise(&["run"]).fails(exit::INPUT);
    assert!(out.contains("labels.toml") && out.contains("range 1") && out.contains("matches no clip"), "{out}");
    assert!(p.path("artifacts/small/frames.parquet").exists());
    assert!(!p.path("artifacts/small/segments.parquet").exists());
    let lock = p.read("artifacts/small/reprise.lock");
    assert!(lock.contains("\"ingest\"") && !lock.contains("\"label\""), "{lock}");
    // Fixing the labels reruns only label.
    p.write("labels.toml", "[[rule]]\npattern = \"*\"\nlabel = \"all\"\n");
    let out = p.reprise(&["run"]).ok();
    assert!(p.path("artifacts/small/segments.parquet").exists(), "{out}");
}

/// A stage binary that dies from a signal mid-run.
#[test]
fn crashing_stage_binary() {
    let p = small("");
    p.write(
        "crash.sh",
        "#!/bin/sh\nfor a in \"$@\"; do [ \"$a\" = --check ] && exit 0; done\necho 'about to crash' >&2\nkill -9 $$\n",
    );
    std::process::Command::new("chmod").args(["+x", p.path("crash.sh").to_str().unwrap()]).status().unwrap();
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("bin = \"reprise-label\"", "bin = \"./crash.sh\""));
    let out = p.reprise(&["run"]).fails(exit::STAGE_CRASHED);
    assert!(out.contains("about to crash") && out.contains("label"), "{out}");
    assert!(p.path("artifacts/small/frames.parquet").exists());
    let lock = p.read("artifacts/small/reprise.lock");
    assert!(!lock.contains("\"label\""), "{lock}");
}

#[test]
fn bad_curves_file_through_the_runner() {
    let p = small("");
    p.write("curves.csv", "clip,frame,jaw\na,0,1\na,0,2\n");
    let out = p.reprise(&["run"]).fails(exit::INPUT);
    assert!(out.contains("curves.csv") && out.contains("line 3") && out.contains("repeats"), "{out}");
}

#[test]
fn dag_lists_stages_and_artifacts() {
    let p = small("");
    let out = p.reprise(&["dag", "--format", "mermaid"]).ok();
    assert!(out.contains("flowchart") && out.contains("ingest") && out.contains("label"), "{out}");
}

/// Two runs of one pipeline at once: the second refuses to start instead of interleaving.
#[test]
fn concurrent_run_is_refused() {
    let p = small("");
    std::fs::create_dir_all(p.path("artifacts/small")).unwrap();
    let held = std::fs::File::create(p.path("artifacts/small/.reprise.running")).unwrap();
    held.lock().unwrap();
    let out = p.reprise(&["run"]).fails(exit::FAILURE);
    assert!(out.contains("another `reprise run`"), "{out}");
    held.unlock().unwrap();
    p.reprise(&["run"]).ok();
}
