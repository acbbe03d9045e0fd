//! `reprise-label`: see `reprise_label` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_label::Args::parse();
    reprise_stagekit::main("reprise-label", reprise_stagekit::code_id!("REPRISE_CODE_ID_LABEL"), || {
        if let Some(summary) = reprise_label::run(&args)? {
            eprintln!("{summary}");
        }
        Ok(())
    });
}
