//! Every stage's files are declared once (`reprise_stagekit::stage_io!`): its wiring, its
//! flags and the input roles its provenance records agree, for every stage.

use reprise_stagekit::wiring::{self, Need};

/// A command line giving every declared file (a repeated flag once), and the parameters a
/// stage needs to parse.
fn argv(w: &wiring::Wiring) -> Vec<String> {
    let mut v = vec![w.bin.to_string()];
    for role in w.inputs.iter().map(|i| i.role).chain(w.outputs.iter().map(|o| o.role)) {
        v.push(format!("--{}", role.replace('_', "-")));
        v.push(format!("{role}.file"));
    }
    v
}

#[test]
fn every_stage_declares_each_file_flag_once() {
    assert_eq!(reprise::STAGES.len(), 19, "a stage was added or lost: list it in crates/reprise/src/lib.rs");
    for w in reprise::STAGES {
        let command = reprise::command(w.stage).expect("every listed stage has a command line");
        assert_eq!(command.get_name(), w.bin, "{}: the binary's name", w.stage);
        let wrong = wiring::disagreements(w, &command);
        assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    }
}

#[test]
fn every_stage_records_its_declared_inputs_by_role() {
    for w in reprise::STAGES {
        let recorded =
            reprise::recorded_inputs(w.stage, &argv(w)).unwrap().unwrap_or_else(|e| panic!("{}: {e}", w.stage));
        let declared: Vec<&str> = w.inputs.iter().map(|i| i.role).collect();
        assert_eq!(recorded, declared, "{}: provenance roles against wiring", w.stage);
    }
}

/// Only required inputs and sources are required flags; optional ones may be left out.
#[test]
fn only_required_inputs_are_required_flags() {
    for w in reprise::STAGES {
        let command = reprise::command(w.stage).unwrap();
        for input in w.inputs {
            let arg = command.get_arguments().find(|a| a.get_id() == input.role).unwrap();
            let must = matches!(input.need, Need::Required | Need::Source);
            assert_eq!(arg.is_required_set(), must, "{}: --{}", w.stage, input.role);
        }
    }
}

/// Every stage takes `--check`, and the flags the runner passes for a partitioned run
/// exactly when its declaration allows one.
#[test]
fn partition_flags_follow_the_declaration() {
    use wiring::{Partition, PARTITION_FLAG, PARTITION_TO_FLAG};
    for w in reprise::STAGES {
        let command = reprise::command(w.stage).unwrap();
        let has = |id: &str| command.get_arguments().any(|a| a.get_id() == id);
        let (one, pair) = match w.partition {
            Partition::Whole => (false, false),
            Partition::Label { .. } => (true, false),
            Partition::LabelPair { .. } => (true, true),
        };
        assert!(has("check"), "{}: --check", w.stage);
        assert_eq!((has(PARTITION_FLAG), has(PARTITION_TO_FLAG)), (one, pair), "{}: partition flags", w.stage);
    }
}

/// The check itself finds each kind of disagreement.
#[test]
fn disagreements_are_found() {
    #[derive(clap::Parser)]
    struct Cli {
        #[arg(long, value_name = "FILE")]
        frames: std::path::PathBuf,
        #[arg(long, value_name = "FILE")]
        stray: Option<std::path::PathBuf>,
        #[arg(long = "other-name", value_name = "FILE")]
        renamed: std::path::PathBuf,
    }
    const W: wiring::Wiring = wiring::Wiring {
        stage: "toy",
        bin: "toy",
        inputs: &[wiring::required("frames", "frames.parquet"), wiring::required("missing", "m.parquet")],
        outputs: &[wiring::artifact("renamed", "r.parquet")],
        derived: &[],
        partition: wiring::Partition::Whole,
    };
    let found = wiring::disagreements(&W, &<Cli as clap::CommandFactory>::command());
    assert_eq!(
        found,
        [
            "toy: declared `missing` has no flag",
            "toy: `renamed` is not the flag --renamed",
            "toy: flag --stray takes a FILE but is not declared",
        ]
    );
}
