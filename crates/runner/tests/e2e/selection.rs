//! `--to` and `--force`.

use reprise_stagekit::exit;

use crate::project::Project;

#[test]
fn to_runs_only_the_stage_and_its_ancestors() {
    let p = Project::new();
    let run = p.run_ok(&["--to", "b"]);
    assert_eq!(p.checks(), ["a", "b"]);
    assert_eq!(p.runs(), ["a", "b"]);
    assert!(run.stderr.contains("2 ran, 0 cached"), "{}", run.stderr);
    let again = p.run_ok(&["--to", "b"]);
    assert!(again.stderr.contains("all 2 stages up to `b` are up to date"), "{}", again.stderr);
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["c", "d"]);
}

#[test]
fn force_reruns_the_stage_and_its_downstream() {
    let p = Project::new();
    p.run_ok(&[]);
    p.runs();
    p.run_ok(&["--force", "a"]);
    assert_eq!(p.runs(), ["a", "b", "c"]);
    p.run_ok(&["--force", "d", "--force", "b"]);
    assert_eq!(p.runs(), ["b", "c", "d"]);
    p.run_ok(&["--to", "b", "--force", "a"]);
    assert_eq!(p.runs(), ["a", "b"]);
    // c was not selected, and now reads a newer b (same content here, but rewritten).
    p.run_ok(&[]);
    assert!(p.runs().is_empty(), "b's output did not change content, so c is fresh");
}

#[test]
fn selection_errors() {
    let p = Project::new();
    let run = p.reprise(&["run", "--to", "nope"]);
    assert_eq!(run.code, exit::CONFIG);
    assert!(run.stderr.contains("no stage named `nope` (stages: `a`, `b`, `c`, `d`)"), "{}", run.stderr);
    let run = p.reprise(&["run", "--to", "a", "--force", "c"]);
    assert_eq!(run.code, exit::CONFIG);
    assert!(run.stderr.contains("stage `c` is forced but `--to a` does not select it"), "{}", run.stderr);
    assert!(p.runs().is_empty());
}
