//! `reprise-motion-match`: see `reprise_motion_match` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_motion_match::Args::parse();
    reprise_stagekit::main("reprise-motion-match", reprise_stagekit::code_id!("REPRISE_CODE_ID_MOTION_MATCH"), || {
        if let Some(answers) = reprise_motion_match::run(&args)? {
            for (s, name) in ["motion-matching", "crossfade"].into_iter().enumerate() {
                eprintln!("{}", reprise_stagekit::AnswerSummary::new(name, answers.iter().map(|(_, a)| &a[s])));
            }
        }
        Ok(())
    });
}
