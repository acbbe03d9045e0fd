//! Content caching across runs: what reruns after which change, and what status says.

use reprise_runner::main_with_args;

use crate::project::Project;

#[test]
fn first_run_runs_all_and_second_runs_none() {
    let p = Project::new();
    // Through the real entry point, twice in one process.
    assert_eq!(main_with_args(p.argv(&["run"]), reprise_runner::Commands::default()), 0);
    assert_eq!(p.checks(), ["a", "b", "c", "d"], "every stage is checked first");
    assert_eq!(p.runs(), ["a", "b", "c", "d"]);
    assert_eq!(p.read("art/c.txt"), "source\na mode=ok k=1\nb mode=ok k=1 shift=-0.5\nc mode=ok tags=x,y\n");
    assert_eq!(main_with_args(p.argv(&["run"]), reprise_runner::Commands::default()), 0);
    assert!(p.runs().is_empty());
    assert!(p.checks().is_empty(), "nothing to run, nothing to check");

    let again = p.run_ok(&[]);
    assert!(again.stderr.contains("all 4 stages are up to date"), "{}", again.stderr);
    let status = p.status();
    assert_eq!(status.matches("  fresh\n").count(), 4, "{status}");
    assert!(status.ends_with("4 stages: 4 fresh, 0 stale\n"), "{status}");
}

#[test]
fn lock_records_each_successful_stage() {
    let p = Project::new();
    p.run_ok(&[]);
    let lock = p.lock();
    assert_eq!(p.locked(), ["a", "b", "c", "d"]);
    let b = &lock["stages"]["b"];
    assert_eq!(b["key"].as_str().unwrap().len(), 64);
    assert_eq!(b["params"], serde_json::json!({ "k": 1, "mode": "ok", "shift": -0.5 }));
    assert_eq!(b["inputs"]["in_a"]["path"], "art/a.txt");
    let a_hash = blake3::hash(p.read("art/a.txt").as_bytes()).to_hex().to_string();
    assert_eq!(b["inputs"]["in_a"]["blake3"], a_hash.as_str());
    assert_eq!(lock["stages"]["a"]["outputs"]["out"]["blake3"], a_hash.as_str());
    let script_hash = blake3::hash(p.read("stage_b.sh").as_bytes()).to_hex().to_string();
    assert_eq!(b["bin"]["blake3"], script_hash.as_str());
    assert!(b["bin"]["path"].as_str().unwrap().ends_with("/stage_b.sh"));
    assert!(b["finished_at"].as_str().unwrap().ends_with('Z'));
    assert!(b["seconds"].as_f64().unwrap() >= 0.0);
}

#[test]
fn changing_a_param_reruns_that_stage_and_downstream() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.checks();
    p.edit_pipeline("params.k = 1\nparams.shift", "params.k = 24\nparams.shift");
    assert_eq!(p.status_of("a"), "a  fresh");
    assert_eq!(p.status_of("b"), "b  stale\n- parameter `k` changed: 1 -> 24");
    assert_eq!(p.status_of("c"), "c  stale\n- upstream stage `b` is stale (will rerun)");
    assert_eq!(p.status_of("d"), "d  fresh");
    let run = p.run_ok(&[]);
    assert_eq!(p.runs(), ["b", "c"]);
    assert_eq!(p.checks(), ["b", "c"]);
    assert!(run.stderr.contains("running b (parameter `k` changed: 1 -> 24)"), "{}", run.stderr);
    assert!(run.stderr.contains("cached a"), "{}", run.stderr);
    assert!(run.stderr.contains("2 ran, 2 cached"), "{}", run.stderr);
    p.run_ok(&[]);
    assert!(p.runs().is_empty());
}

#[test]
fn reordering_params_changes_nothing() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.edit_pipeline(
        "params.mode = \"ok\"\nparams.k = 1\nparams.shift = -0.5",
        "params.shift = -0.5\nparams.k = 1\nparams.mode = \"ok\"",
    );
    p.run_ok(&[]);
    assert!(p.runs().is_empty());
}

#[test]
fn modifying_a_source_input_reruns_its_dependents() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.write("data/src.txt", "new source\n");
    assert_eq!(p.status_of("a"), "a  stale\n- input `in_src` changed (data/src.txt)");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["a", "b", "c"]);
    assert!(p.read("art/c.txt").starts_with("new source\n"));
    p.write("data/other.txt", "new other\n");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["d"]);
}

#[test]
fn deleting_or_editing_an_output_reruns_that_stage() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    std::fs::remove_file(p.path("art/c.txt")).unwrap();
    assert_eq!(p.status_of("c"), "c  stale\n- output `out` missing (art/c.txt)");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["c"]);

    p.write("art/d.txt", "hand edited\n");
    assert_eq!(p.status_of("d"), "d  stale\n- output `out` modified since it was written (art/d.txt)");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["d"]);
    assert_eq!(p.read("art/d.txt"), "other\nd mode=ok\n");

    // A deleted upstream output reruns its stage and everything downstream of it.
    std::fs::remove_file(p.path("art/a.txt")).unwrap();
    assert_eq!(p.status_of("b"), "b  stale\n- upstream stage `a` is stale (will rerun)");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["a", "b", "c"]);
}

#[test]
fn changing_a_stage_binary_reruns_it() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    let script = p.read("stage_b.sh");
    p.write_script("stage_b.sh", &format!("{script}# rebuilt\n"));
    assert_eq!(p.status_of("b"), "b  stale\n- stage binary `stage_b.sh` changed");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["b", "c"]);
}

#[test]
fn status_before_any_run() {
    let p = Project::new();
    assert_eq!(p.status_of("a"), "a  stale\n- never run");
    assert_eq!(p.status_of("b"), "b  stale\n- upstream stage `a` is stale (will rerun)\n- never run");
    std::fs::remove_file(p.path("data/other.txt")).unwrap();
    assert_eq!(p.status_of("d"), "d  stale\n- never run\n- input `in_src` missing (data/other.txt)");
}

#[test]
fn an_empty_lock_file_is_recovered_from() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.write("art/reprise.lock", "garbage");
    let run = p.run_ok(&[]);
    assert!(run.stderr.contains("warning:") && run.stderr.contains("not a valid lock file"), "{}", run.stderr);
    assert_eq!(p.runs(), ["a", "b", "c", "d"]);
    assert_eq!(p.locked(), ["a", "b", "c", "d"]);
}
