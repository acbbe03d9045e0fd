//! `reprise`: the pipeline runner. All logic lives in `reprise-runner`; this binary tells
//! it what each reprise stage reads and writes, so pipelines can leave the wiring out.

/// Every reprise stage's declaration ([`reprise_stagekit::wiring`]).
const STAGES: [reprise_stagekit::wiring::Wiring; 12] = [
    reprise_ingest::WIRING,
    reprise_label::WIRING,
    reprise_scale::WIRING,
    reprise_pca::WIRING,
    reprise_gplvm::WIRING,
    reprise_bridges::WIRING,
    reprise_synthesize::WIRING,
    reprise_export_gltf::WIRING,
    reprise_motion_graph::WIRING,
    reprise_transitions::WIRING,
    reprise_motion_match::WIRING,
    reprise_evaluate::WIRING,
];

fn main() {
    std::process::exit(reprise_runner::main_with_stages(std::env::args_os(), &STAGES));
}
