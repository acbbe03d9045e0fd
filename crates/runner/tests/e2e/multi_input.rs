//! An input given as a list of files or a glob: one flag per file, every file's content in
//! the cache key, and `status` naming the file that changed.

use crate::project::Project;

/// Stage `d` reads every `data/takes/*.txt` instead of one file.
fn with_takes() -> Project {
    let p = Project::new();
    p.write("data/takes/b.txt", "take b\n");
    p.write("data/takes/a.txt", "take a\n");
    p.write("data/takes/notes.md", "not a take\n");
    p.edit_pipeline("inputs.in_src = \"data/other.txt\"", "inputs.in_src = \"data/takes/*.txt\"");
    p
}

#[test]
fn a_glob_passes_every_matching_file_in_name_order() {
    let p = with_takes();
    p.run_ok(&[]);
    p.runs();
    assert_eq!(p.read("art/d.txt"), "take a\ntake b\nd mode=ok\n");
    let lock = p.lock();
    let inputs = &lock["stages"]["d"]["inputs"];
    assert_eq!(inputs["in_src[0]"]["path"], "data/takes/a.txt");
    assert_eq!(inputs["in_src[1]"]["path"], "data/takes/b.txt");
    assert!(inputs.get("in_src[2]").is_none(), "notes.md does not match");
    let dag = p.reprise(&["dag"]);
    assert!(dag.stdout.contains("<- in_src[1]: data/takes/b.txt (source file)"), "{}", dag.stdout);
}

#[test]
fn changing_adding_or_removing_one_file_reruns_the_stage_and_says_which() {
    let p = with_takes();
    p.run_ok(&[]);
    p.runs();
    p.write("data/takes/b.txt", "take b, edited\n");
    assert_eq!(p.status_of("d"), "d  stale\n- input `in_src[1]` changed (data/takes/b.txt)");
    assert_eq!(p.status_of("a"), "a  fresh");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["d"]);
    assert_eq!(p.read("art/d.txt"), "take a\ntake b, edited\nd mode=ok\n");

    p.write("data/takes/c.txt", "take c\n");
    assert_eq!(p.status_of("d"), "d  stale\n- input `in_src[2]` added (data/takes/c.txt)");
    p.run_ok(&[]);
    assert_eq!(p.runs(), ["d"]);
    std::fs::remove_file(p.path("data/takes/a.txt")).unwrap();
    let status = p.status_of("d");
    assert!(status.contains("input `in_src[2]` removed") && status.contains("in_src[0]"), "{status}");
}

#[test]
fn a_list_mixes_files_and_globs_in_its_order() {
    let p = with_takes();
    p.edit_pipeline("inputs.in_src = \"data/takes/*.txt\"", "inputs.in_src = [\"data/other.txt\", \"data/takes/b*\"]");
    p.run_ok(&[]);
    assert_eq!(p.read("art/d.txt"), "other\ntake b\nd mode=ok\n");
}

#[test]
fn a_glob_without_match_or_a_bad_list_is_a_configuration_error() {
    let p = with_takes();
    p.edit_pipeline("inputs.in_src = \"data/takes/*.txt\"", "inputs.in_src = \"data/takes/*.bvh\"");
    let out = p.reprise(&["run"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert!(
        out.stderr.contains("stage `d`: input `in_src`: glob `data/takes/*.bvh`: no file in")
            && out.stderr.contains("matches it"),
        "{}",
        out.stderr
    );
    p.edit_pipeline("inputs.in_src = \"data/takes/*.bvh\"", "inputs.in_src = []");
    let out = p.reprise(&["run"]);
    assert_eq!(out.code, 2);
    assert!(
        out.stderr.contains("input `in_src` must be a non-empty path string or a list of them, found an empty list"),
        "{}",
        out.stderr
    );
    assert!(p.runs().is_empty());
}
