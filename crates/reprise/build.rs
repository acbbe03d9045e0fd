//! Embeds each stage binary's code identity (see `reprise_codeid`): the stage's library
//! crate, everything it links, and the binary's own `main`.

use std::path::Path;

/// (binary, the stage crate under `stages/` that implements it).
const STAGES: [(&str, &str); 19] = [
    ("reprise-ingest", "ingest"),
    ("reprise-label", "label"),
    ("reprise-scale", "scale"),
    ("reprise-pca", "pca"),
    ("reprise-gplvm", "gplvm"),
    ("reprise-bridges", "bridges"),
    ("reprise-synthesize", "synthesize"),
    ("reprise-export-gltf", "export-gltf"),
    ("reprise-motion-graph", "motion-graph"),
    ("reprise-transitions", "transitions"),
    ("reprise-motion-match", "motion-match"),
    ("reprise-evaluate", "evaluate"),
    ("reprise-positions", "positions"),
    ("reprise-invrig-fit", "invrig-fit"),
    ("reprise-invrig-apply", "invrig-apply"),
    ("reprise-retarget-fit", "retarget-fit"),
    ("reprise-retarget-apply", "retarget-apply"),
    ("reprise-retarget-oracle", "retarget-oracle"),
    ("reprise-retarget-compare", "retarget-compare"),
];

fn main() {
    let stages = Path::new("../../stages");
    let stagekit = Path::new("../stagekit");
    for (bin, krate) in STAGES {
        let var = format!("REPRISE_CODE_ID_{}", bin.trim_start_matches("reprise-").replace('-', "_").to_uppercase());
        let main = format!("src/bin/{bin}.rs");
        reprise_codeid::emit(&var, &[&stages.join(krate), stagekit], &[Path::new(&main)]);
    }
    // `reprise-replay` is no pipeline stage, but runs as one (`reprise replay`).
    let replay = Path::new("../replay");
    reprise_codeid::emit("REPRISE_CODE_ID_REPLAY", &[replay, stagekit], &[Path::new("src/bin/reprise-replay.rs")]);
}
