//! `reprise dag` and `reprise inspect` on a project.

use reprise_stagekit::exit;

use crate::project::Project;

#[test]
fn dag_as_text_and_mermaid() {
    let p = Project::new();
    let text = p.reprise(&["dag"]);
    assert_eq!(text.code, 0, "{}", text.stderr);
    assert!(
        text.stdout.contains("b (stage_b.sh)\n  <- in_a: art/a.txt (from `a`)\n  -> out: art/b.txt\n"),
        "{}",
        text.stdout
    );
    let mermaid = p.reprise(&["dag", "--format", "mermaid"]);
    assert!(mermaid.stdout.starts_with("flowchart LR\n"), "{}", mermaid.stdout);
    assert!(mermaid.stdout.contains("s0 -->|\"a.txt\"| s1"), "{}", mermaid.stdout);
    assert!(mermaid.stdout.contains("f0[/\"data/src.txt\"/]"), "{}", mermaid.stdout);
}

#[test]
fn inspect_refuses_a_text_artifact() {
    let p = Project::new();
    p.run_ok(&[]);
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let args = ["reprise", "inspect", p.path("art/a.txt").to_str().unwrap()].map(std::ffi::OsString::from);
    let code = reprise_runner::main_with_io(args, reprise_runner::Commands::default(), &mut out, &mut err);
    assert_eq!(code, exit::INPUT);
    let err = String::from_utf8(err).unwrap();
    assert!(err.contains("a.txt` is not a Parquet file"), "{err}");
}
