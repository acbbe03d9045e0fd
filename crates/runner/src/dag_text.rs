//! `reprise dag`: the stage graph as text (run order, each stage's inputs with where they
//! come from, and its outputs) or as a Mermaid `flowchart LR` whose edges are labelled
//! with the artifact they carry and whose source files are nodes of their own.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::cli::DagFormat;
use crate::dag::{Dag, Edge};
use crate::pipeline::Pipeline;

/// The graph in the requested format.
#[must_use]
pub fn render(pipeline: &Pipeline, dag: &Dag, format: DagFormat) -> String {
    match format {
        DagFormat::Text => text(pipeline, dag),
        DagFormat::Mermaid => mermaid(pipeline, dag),
    }
}

fn text(pipeline: &Pipeline, dag: &Dag) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "pipeline `{}`: {} stages, in run order", pipeline.name, pipeline.stages.len());
    for &i in dag.order() {
        let stage = &pipeline.stages[i];
        let _ = writeln!(out, "\n{} ({})", stage.name, stage.bin.declared());
        for (input, path) in &stage.inputs {
            let from = dag.incoming(i).iter().find_map(|(a, e)| match e {
                Edge::Artifact { input: name, .. } if name == input => Some(*a),
                _ => None,
            });
            let from =
                from.map_or_else(|| "source file".to_string(), |a| format!("from `{}`", pipeline.stages[a].name));
            let _ = writeln!(out, "  <- {input}: {} ({from})", path.rel);
        }
        for after in &stage.after {
            let _ = writeln!(out, "  after `{after}`");
        }
        for (output, path) in &stage.outputs {
            let _ = writeln!(out, "  -> {output}: {}", path.rel);
        }
    }
    out
}

fn mermaid(pipeline: &Pipeline, dag: &Dag) -> String {
    let mut out = String::from("flowchart LR\n");
    for &i in dag.order() {
        let _ = writeln!(out, "  s{i}[\"{}\"]", escape(&pipeline.stages[i].name));
    }
    // Source files (inputs no stage produces), one node per path.
    let mut sources: BTreeMap<&str, usize> = BTreeMap::new();
    let mut edges = String::new();
    for &b in dag.order() {
        let stage = &pipeline.stages[b];
        for (a, edge) in dag.incoming(b) {
            match edge {
                Edge::Artifact { path, .. } => {
                    let _ = writeln!(edges, "  s{a} -->|\"{}\"| s{b}", escape(file_name(path)));
                }
                Edge::After => {
                    let _ = writeln!(edges, "  s{a} -.->|after| s{b}");
                }
            }
        }
        let produced = dag.produced_inputs(b);
        for (input, path) in stage.inputs.iter().filter(|(name, _)| !produced.contains(name.as_str())) {
            let next = sources.len();
            let id = *sources.entry(path.rel.as_str()).or_insert(next);
            if id == next {
                let _ = writeln!(out, "  f{id}[/\"{}\"/]", escape(&path.rel));
            }
            let _ = writeln!(edges, "  f{id} -->|\"{}\"| s{b}", escape(input));
        }
    }
    // Final artifacts: outputs no stage reads.
    let mut finals = 0;
    for &a in dag.order() {
        for (_, path) in &pipeline.stages[a].outputs {
            let read = pipeline.stages.iter().any(|s| s.inputs.iter().any(|(_, p)| p.abs == path.abs));
            if !read {
                let _ = writeln!(out, "  o{finals}([\"{}\"])", escape(&path.rel));
                let _ = writeln!(edges, "  s{a} --> o{finals}");
                finals += 1;
            }
        }
    }
    out + &edges
}

fn file_name(path: &str) -> &str {
    path.rsplit('/').next().unwrap_or(path)
}

/// Mermaid labels are quoted; a quote inside one is written as an entity.
fn escape(label: &str) -> String {
    label.replace('"', "#quot;")
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const PIPELINE: &str = r#"
        [pipeline]
        name = "dragon-face"
        [stage.ingest]
        bin = "reprise-ingest"
        outputs.frames = "artifacts/frames.parquet"
        [stage.label]
        bin = "reprise-label"
        inputs.frames = "artifacts/frames.parquet"
        inputs.labels = "datasets/labels.toml"
        outputs.segments = "artifacts/segments.parquet"
        [stage.report]
        bin = "reprise-report"
        inputs.labels = "datasets/labels.toml"
        after = ["label"]
    "#;

    fn graph() -> (Pipeline, Dag) {
        let p = Pipeline::parse(PIPELINE, "pipeline.toml", Path::new("/p")).unwrap();
        let d = Dag::build(&p).unwrap();
        (p, d)
    }

    #[test]
    fn mermaid_flowchart() {
        let (p, d) = graph();
        assert_eq!(
            render(&p, &d, DagFormat::Mermaid),
            "flowchart LR\n  s0[\"ingest\"]\n  s1[\"label\"]\n  s2[\"report\"]\n  f0[/\"datasets/labels.toml\"/]\n  \
             o0([\"artifacts/segments.parquet\"])\n  s0 -->|\"frames.parquet\"| s1\n  f0 -->|\"labels\"| s1\n  \
             s1 -.->|after| s2\n  f0 -->|\"labels\"| s2\n  s1 --> o0\n"
        );
    }

    #[test]
    fn text_lists_provenance_of_inputs() {
        let (p, d) = graph();
        let text = render(&p, &d, DagFormat::Text);
        assert!(text.contains("label (reprise-label)\n  <- frames: artifacts/frames.parquet (from `ingest`)\n  <- labels: datasets/labels.toml (source file)\n  -> segments: artifacts/segments.parquet\n"), "{text}");
        assert!(
            text.contains(
                "report (reprise-report)\n  <- labels: datasets/labels.toml (source file)\n  after `label`\n"
            ),
            "{text}"
        );
    }
}
