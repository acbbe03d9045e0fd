//! Bad inputs to motion-graph and bridges, run as a user would — the stage binary by
//! hand, its exit code and its message — and the motion-graph checks that transitions
//! and evaluate rely on, run on a real graph.

use std::sync::OnceLock;

use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::motion_graph;
use reprise_stagekit::exit;

use crate::util::Project;

/// The dragon face up to motion-graph (ingest, label, scale, motion-graph), built once;
/// the tests only read it and write their own outputs under `out/<test>/`.
fn built() -> &'static Project {
    static P: OnceLock<Project> = OnceLock::new();
    P.get_or_init(|| {
        let p = Project::dragon_face();
        p.reprise(&["run", "--to", "motion-graph"]).ok();
        p
    })
}

const A: &str = "artifacts/dragon-face";

/// motion-graph's flags for the built artifacts, outputs under `out/<name>/`, then `extra`.
pub(crate) fn motion_graph(name: &str, labeled: &str, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = [
        "--labeled-frames",
        labeled,
        "--scales",
        &format!("{A}/scales.parquet"),
        "--nodes",
        &format!("out/{name}/n.parquet"),
        "--edges",
        &format!("out/{name}/e.parquet"),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// A window of 1 or beyond 10 000 frames is refused at `--check` (exit 2).
#[test]
fn motion_graph_window_is_bounded() {
    let p = Project::empty();
    for w in ["1", "20000"] {
        let args = motion_graph("w", "lf.parquet", &["--window", w, "--check"]);
        let out = p.stage("reprise-motion-graph", &strs(&args)).fails(exit::CONFIG);
        assert!(out.contains("need 2 <= --window <= 10000"), "{out}");
    }
}

/// A motion too long for the pair limit is refused before the distances are allocated,
/// naming the labeled frames and the row where it starts.
#[test]
fn motion_graph_refuses_a_motion_beyond_the_pair_limit() {
    let p = built();
    let args = motion_graph("limit", &format!("{A}/labeled_frames.parquet"), &["--max-pair-cells", "100"]);
    let out = p.stage("reprise-motion-graph", &strs(&args)).fails(exit::INPUT);
    assert!(
        out.contains("labeled_frames.parquet: row ") && out.contains("more than the limit --max-pair-cells 100"),
        "{out}"
    );
    assert!(!p.path("out/limit/n.parquet").exists());
}

/// Scales computed from other labeled frames (another labeling) are refused, naming both.
#[test]
fn motion_graph_refuses_scales_of_another_labeling() {
    let p = built();
    let labels =
        p.read("datasets/dragon-face/labels.toml") + "\n[[exclude]]\nclip = \"neutral_take01\"\nstart = 0\nend = 5\n";
    p.write("out/relabel/labels.toml", &labels);
    p.stage(
        "reprise-label",
        &[
            "--frames",
            &format!("{A}/frames.parquet"),
            "--labels",
            "out/relabel/labels.toml",
            "--segments",
            "out/relabel/segments.parquet",
            "--labeled-frames",
            "out/relabel/labeled_frames.parquet",
            "--min-segment-length",
            "12",
        ],
    )
    .ok();
    let args = motion_graph("relabel", "out/relabel/labeled_frames.parquet", &[]);
    let out = p.stage("reprise-motion-graph", &strs(&args)).fails(exit::INPUT);
    assert!(
        out.contains("scales.parquet: was made by `scale` from labeled_frames")
            && out.contains("given labeled_frames `out/relabel/labeled_frames.parquet`"),
        "{out}"
    );
}

/// The real graph passes every check transitions and evaluate are to make, and records
/// its window; the labeled frames of another labeling do not match its nodes.
#[test]
fn a_real_motion_graph_passes_its_checks() {
    let p = built();
    let g =
        motion_graph::read_graph(&p.path(&format!("{A}/mg_nodes.parquet")), &p.path(&format!("{A}/mg_edges.parquet")))
            .unwrap();
    assert_eq!(g.window, 12);
    assert!(g.edges.iter().any(|e| e.kind == motion_graph::TRANSITION));
    g.check_window(12, "--window").unwrap();
    let lf = LabeledFrames::read(&p.path(&format!("{A}/labeled_frames.parquet"))).unwrap();
    g.check_frames(&lf, &p.path("labeled_frames.parquet")).unwrap();
    let graph = reprise_transition_graph::Graph::from_edges(
        g.nodes.frame.len(),
        g.edges.iter().map(|e| (e.from, e.to, e.cost)),
    );
    assert!(graph.is_ok());
}

/// Absurd start counts are refused at `--check` (each start is an SCG run per candidate).
#[test]
fn bridges_start_counts_are_bounded() {
    let p = Project::empty();
    let args = [
        "--gplvm-models",
        "g",
        "--pca-models",
        "p",
        "--scales",
        "s",
        "--controls",
        "c",
        "--labeled-frames",
        "l",
        "--bridges",
        "b",
        "--random-starts",
        "100000",
        "--check",
    ];
    let out = p.stage("reprise-bridges", &args).fails(exit::CONFIG);
    assert!(out.contains("--random-starts may be at most 1000"), "{out}");
}
