//! `reprise-transitions`: see `reprise_transitions` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_transitions::Args::parse();
    reprise_stagekit::main("reprise-transitions", reprise_stagekit::code_id!("REPRISE_CODE_ID_TRANSITIONS"), || {
        if let Some(answers) = reprise_transitions::run(&args)? {
            for summary in answers.summaries() {
                eprintln!("{summary}");
            }
        }
        Ok(())
    });
}
