//! `reprise-evaluate`: see `reprise_evaluate` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_evaluate::Args::parse();
    reprise_stagekit::main("reprise-evaluate", reprise_stagekit::code_id!("REPRISE_CODE_ID_EVALUATE"), || {
        if let Some(m) = reprise_evaluate::run(&args)? {
            eprint!("{}", reprise_evaluate::model::OverallLines(&m));
            eprintln!("report: {}", args.io.report.display());
        }
        Ok(())
    });
}
