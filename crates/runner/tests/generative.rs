//! Generative tests of the `pipeline.toml` reader: mutated copies of the repository's
//! pipeline and token soup either load — parse, cross-stage checks, output guards, DAG —
//! or fail with a typed [`reprise_runner::Error`] naming the file; never a panic or a hang.

use std::path::Path;

use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated_text, token_soup, within, LIMIT};
use reprise_runner::dag::Dag;
use reprise_runner::pipeline::Pipeline;
use reprise_stagekit::wiring::Wiring;

const PIPELINE: &str = include_str!("../../../pipeline.toml");

/// The shipped pipeline names its stages without `bin`; this crate does not link the stage
/// crates, so it knows them by name only (their inputs and outputs stay unwired: the
/// reader, the guards and the DAG are what these tests exercise).
const STAGES: &[Wiring] = &{
    const fn stage(stage: &'static str, bin: &'static str) -> Wiring {
        Wiring {
            stage,
            bin,
            inputs: &[],
            outputs: &[],
            derived: &[],
            partition: reprise_stagekit::wiring::Partition::Whole,
        }
    }
    [
        stage("ingest", "reprise-ingest"),
        stage("label", "reprise-label"),
        stage("scale", "reprise-scale"),
        stage("pca", "reprise-pca"),
        stage("gplvm", "reprise-gplvm"),
        stage("bridges", "reprise-bridges"),
        stage("synthesize", "reprise-synthesize"),
        stage("motion-graph", "reprise-motion-graph"),
        stage("transitions", "reprise-transitions"),
        stage("motion-match", "reprise-motion-match"),
        stage("evaluate", "reprise-evaluate"),
    ]
};

const TOKENS: &[&str] = &[
    "[pipeline]",
    "[stage.",
    "[stage.x]",
    "]",
    "name",
    "artifacts",
    "bin",
    "inputs",
    "outputs",
    "params",
    "after",
    "allow_overwrite",
    " = ",
    "\"../\"",
    "\"/\"",
    "\"pipeline.toml\"",
    "\"a/../../b\"",
    "\"\"",
    "true",
    "[[",
    "{",
    "}",
    "1e999",
    "nan",
];

/// Loads `text` as `/project/pipeline.toml`; an error must name that file.
fn check(text: String) {
    let result = within(LIMIT, move || {
        let load = |text: &str| -> Result<usize, Box<reprise_runner::Error>> {
            let p = Pipeline::parse_wired(text, "pipeline.toml", Path::new("/project"), STAGES)?;
            reprise_runner::guard::check_declared(&p)?;
            Ok(Dag::build(&p)?.order().len())
        };
        load(&text).map_err(|e| e.to_string())
    });
    if let Err(msg) = result {
        assert!(msg.contains("pipeline.toml") || msg.contains("stage"), "{msg}");
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn mutated_pipelines(text in mutated_text(PIPELINE, TOKENS)) {
        check(text);
    }

    #[test]
    fn token_soup_pipelines(text in token_soup(TOKENS)) {
        check(format!("[pipeline]\nname = \"p\"\n{text}"));
    }
}

/// The shipped pipeline loads.
#[test]
fn the_repository_pipeline_loads() {
    let p = Pipeline::parse_wired(PIPELINE, "pipeline.toml", Path::new("/project"), STAGES).unwrap();
    assert!(Dag::build(&p).unwrap().order().len() >= 8);
}
