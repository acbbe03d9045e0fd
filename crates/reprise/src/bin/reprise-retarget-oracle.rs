//! `reprise-retarget-oracle`: see `reprise_retarget_oracle` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_retarget_oracle::Args::parse();
    reprise_stagekit::main(
        "reprise-retarget-oracle",
        reprise_stagekit::code_id!("REPRISE_CODE_ID_RETARGET_ORACLE"),
        || {
            if let Some(s) = reprise_retarget_oracle::run(&args)? {
                eprintln!(
                    "retarget-oracle: {} frames posed through {} mapped controls; {} labelled pairs",
                    s.frames, s.mapped, s.labels
                );
            }
            Ok(())
        },
    );
}
