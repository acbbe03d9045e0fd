//! Stages that fail, crash, lie or cannot start, and pipelines that cannot run.

use reprise_stagekit::exit;

use crate::project::Project;

#[test]
fn a_failing_middle_stage_stops_the_run_and_keeps_earlier_work() {
    let p = Project::new();
    p.set_mode("b", "fail");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, 7, "the stage's own exit code");
    assert!(run.stderr.contains("reprise: error: stage `b` failed (exit code 7)"), "{}", run.stderr);
    assert_eq!(p.runs(), ["a", "b"], "c never starts");
    assert!(p.path("art/a.txt").exists());
    assert!(!p.path("art/b.txt").exists());
    assert_eq!(p.locked(), ["a"], "a is recorded, b is not");

    p.set_mode("b", "ok");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["b", "c", "d"], "a stays cached");
}

#[test]
fn a_stage_that_fails_on_rerun_loses_its_lock_entry() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.set_mode("c", "fail");
    assert_eq!(p.reprise(&["run"]).code, 7);
    assert_eq!(p.runs(), ["c"]);
    assert_eq!(p.locked(), ["a", "b", "d"]);
}

#[test]
fn a_crashing_stage_is_reported_as_crashed() {
    let p = Project::new();
    p.set_mode("b", "crash");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::STAGE_CRASHED);
    assert!(run.stderr.contains("stage `b` crashed: killed by signal 9 (SIGKILL)"), "{}", run.stderr);
    assert_eq!(p.runs(), ["a", "b"]);
    assert_eq!(p.locked(), ["a"]);
}

#[test]
fn a_failed_check_prevents_every_stage_from_running() {
    let p = Project::new();
    p.set_mode("c", "badcheck");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::CONFIG);
    assert!(run.stderr.contains("stage `c`: parameter check failed"), "{}", run.stderr);
    assert_eq!(p.checks(), ["a", "b", "c", "d"], "all stages are checked, to report every problem");
    assert!(p.runs().is_empty(), "no stage ran");
    assert!(!p.path("art/reprise.lock").exists());
}

#[test]
fn a_stage_that_writes_nothing_is_an_error() {
    let p = Project::new();
    p.set_mode("d", "nowrite");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::FAILURE);
    assert!(run.stderr.contains("stage `d` exited 0 but did not write output `out` (art/d.txt)"), "{}", run.stderr);
    assert_eq!(p.locked(), ["a", "b", "c"]);
}

#[test]
fn a_missing_source_input_stops_before_any_stage() {
    let p = Project::new();
    std::fs::remove_file(p.path("data/other.txt")).unwrap();
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::INPUT);
    assert!(
        run.stderr.contains("stage `d`: input `in_src` not found: data/other.txt (no stage produces it)"),
        "{}",
        run.stderr
    );
    assert!(p.checks().is_empty() && p.runs().is_empty());
}

#[test]
fn a_missing_binary_names_it_and_suggests_building() {
    let p = Project::new();
    p.edit_pipeline("bin = \"./stage_d.sh\"", "bin = \"reprise-no-such-stage\"");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::STAGE_CRASHED);
    assert!(run.stderr.contains("stage `d`: binary `reprise-no-such-stage` not found (looked in"), "{}", run.stderr);
    assert!(run.stderr.contains("$PATH") && run.stderr.contains("cargo build --release"), "{}", run.stderr);
    assert!(p.runs().is_empty());
    assert_eq!(p.status_of("d"), "d  stale\n- never run\n- stage binary `reprise-no-such-stage` not found");
}

#[test]
fn pipeline_errors_are_config_errors() {
    let p = Project::new();
    p.edit_pipeline("outputs.out = \"art/b.txt\"", "ouputs.out = \"art/b.txt\"");
    let run = p.reprise(&["run"]);
    assert_eq!(run.code, exit::CONFIG);
    assert!(
        run.stderr.contains("pipeline.toml: stage `b`: unknown key `ouputs` (did you mean `outputs`?)"),
        "{}",
        run.stderr
    );
    assert_eq!(run.stderr.matches("error:").count(), 1, "printed once: {}", run.stderr);

    let p = Project::new();
    p.edit_pipeline("inputs.in_src = \"data/src.txt\"", "inputs.in_src = \"art/c.txt\"");
    let run = p.reprise(&["status"]);
    assert_eq!(run.code, exit::CONFIG);
    assert!(run.stderr.contains("dependency cycle: a -> b -> c -> a"), "{}", run.stderr);
}
