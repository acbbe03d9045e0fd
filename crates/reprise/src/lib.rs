//! Every reprise stage in one place: what each reads and writes ([`STAGES`], for the runner's
//! wiring) and its command line ([`command`]), so that the `reprise` binary and the tests
//! that check the two agree read the same list.

use reprise_stagekit::wiring::Wiring;

macro_rules! stages {
    ($($krate:ident),* $(,)?) => {
        /// Every reprise stage's declaration ([`reprise_stagekit::stage_io!`]), in pipeline order.
        pub const STAGES: &[Wiring] = &[$($krate::WIRING),*];

        /// The command line of the stage named `stage` (as in `[stage.NAME]`).
        pub fn command(stage: &str) -> Option<clap::Command> {
            $(
                if stage == $krate::WIRING.stage {
                    return Some(<$krate::Args as clap::CommandFactory>::command());
                }
            )*
            None
        }

        /// The input roles the stage named `stage` records in its provenance when run with
        /// `argv` (the binary's name first): `None` for an unknown stage.
        pub fn recorded_inputs(stage: &str, argv: &[String]) -> Option<Result<Vec<String>, clap::Error>> {
            $(
                if stage == $krate::WIRING.stage {
                    let parsed = <$krate::Args as clap::Parser>::try_parse_from(argv);
                    return Some(parsed.map(|a| a.io.inputs().into_iter().map(|(role, _)| role).collect()));
                }
            )*
            None
        }
    };
}

stages![
    reprise_ingest,
    reprise_label,
    reprise_scale,
    reprise_pca,
    reprise_gplvm,
    reprise_bridges,
    reprise_synthesize,
    reprise_export_gltf,
    reprise_motion_graph,
    reprise_transitions,
    reprise_motion_match,
    reprise_evaluate,
    reprise_positions,
    reprise_invrig_fit,
    reprise_invrig_apply,
    reprise_retarget_fit,
    reprise_retarget_apply,
    reprise_retarget_oracle,
    reprise_retarget_compare,
];
