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

/// The issue's data loss: `outputs.clips = "labels.toml"` made ingest overwrite the
/// labels file with Parquet. Refused before any stage (or its `--check`) runs, and the
/// file is untouched; `allow_overwrite` is the explicit way out.
#[test]
fn output_over_a_user_file_is_refused() {
    let p = small("");
    let labels = p.read("labels.toml");
    let pipeline = p
        .read("pipeline.toml")
        .replace("outputs.clips = \"artifacts/small/clips.parquet\"", "outputs.clips = \"labels.toml\"");
    p.write("pipeline.toml", &pipeline);
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(
        out.contains(
            "stage `ingest`: output `clips` is `labels.toml`, an existing file that no stage of this pipeline wrote"
        ),
        "{out}"
    );
    assert!(out.contains("allow_overwrite = [\"clips\"]") && !out.contains("checking"), "{out}");
    assert_eq!(p.read("labels.toml"), labels);
    assert!(!p.path("artifacts/small/frames.parquet").exists(), "nothing ran");
}

/// An output set to the pipeline file replaced pipeline.toml with exit 0.
#[test]
fn output_over_the_pipeline_file_is_refused() {
    let p = small("");
    let pipeline = p
        .read("pipeline.toml")
        .replace("outputs.clips = \"artifacts/small/clips.parquet\"", "outputs.clips = \"./pipeline.toml\"");
    p.write("pipeline.toml", &pipeline);
    for command in [&["run"][..], &["status"]] {
        let out = p.reprise(command).fails(exit::CONFIG);
        assert!(out.contains("output `clips` is `pipeline.toml`, the pipeline file itself"), "{out}");
    }
    assert_eq!(p.read("pipeline.toml"), pipeline);
}

/// The pipeline's own outputs are rewritten freely: after a lost lock (a reprise
/// artifact of the same stage) and with `allow_overwrite` for a foreign file.
#[test]
fn own_outputs_and_allowed_overwrites_still_run() {
    let p = small("min_segment_length = 1");
    p.reprise(&["run"]).ok();
    std::fs::remove_file(p.path("artifacts/small/reprise.lock")).unwrap();
    p.reprise(&["run"]).ok();
    p.write("old-clips.parquet", "not mine to keep");
    let pipeline = p.read("pipeline.toml").replace(
        "outputs.clips = \"artifacts/small/clips.parquet\"",
        "outputs.clips = \"old-clips.parquet\"\nallow_overwrite = [\"clips\"]",
    );
    p.write("pipeline.toml", &pipeline);
    p.reprise(&["run"]).ok();
    assert!(std::fs::read(p.path("old-clips.parquet")).unwrap().starts_with(b"PAR1"));
}

/// An output under a path whose parent is a file, or in a read-only directory.
#[test]
fn unwritable_output_places() {
    let p = small("");
    p.write("afile", "x");
    let pipeline = p.read("pipeline.toml");
    p.write("pipeline.toml", &pipeline.replace("artifacts/small/clips.parquet", "afile/clips.parquet"));
    let out = p.reprise(&["run"]).fails(exit::CONFIG);
    assert!(
        out.contains("output `clips` is `afile/clips.parquet`, but")
            && out.contains("afile` is a file, not a directory"),
        "{out}"
    );

    // Read-only: the environment's fault (exit 6), not the data's (3). Root ignores
    // permissions, so this part only means something for other users.
    std::fs::create_dir_all(p.path("ro")).unwrap();
    std::process::Command::new("chmod").args(["555", p.path("ro").to_str().unwrap()]).status().unwrap();
    let probe = std::fs::File::create(p.path("ro/probe"));
    if probe.is_ok() {
        eprintln!("SKIPPED the read-only part of unwritable_output_places: running as root");
        return;
    }
    p.write("pipeline.toml", &pipeline.replace("artifacts/small/clips.parquet", "ro/clips.parquet"));
    let out = p.reprise(&["run"]).fails(exit::ENVIRONMENT);
    assert!(out.contains("ro/") && out.contains("ermission denied"), "{out}");
}

/// Labels that are empty or reserved are refused through the runner too.
#[test]
fn empty_label_name_is_refused() {
    let p = small("");
    p.write("labels.toml", "[[rule]]\npattern = \"*\"\nlabel = \"\"\n");
    let out = p.reprise(&["run"]).fails(exit::INPUT);
    assert!(out.contains("labels.toml: rule 1: label `` is empty"), "{out}");
}

/// `--executor slurm` where Slurm's commands cannot be run: refused before anything is
/// submitted or written, as an environment error naming what is missing.
#[test]
fn slurm_executor_without_slurm_is_an_environment_error() {
    let p = small("min_segment_length = 1");
    let empty = tempfile::tempdir().unwrap();
    let out = p.reprise_with(&["run", "--executor", "slurm"], &[("PATH", empty.path())]).fails(exit::ENVIRONMENT);
    assert!(out.contains("stage `ingest`: Slurm: `sbatch --version` does not run here"), "{out}");
    assert!(!p.path("artifacts/small/frames.parquet").exists());
}
