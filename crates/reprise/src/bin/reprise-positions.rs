//! `reprise-positions`: see `reprise_positions` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_positions::Args::parse();
    reprise_stagekit::main("reprise-positions", reprise_stagekit::code_id!("REPRISE_CODE_ID_POSITIONS"), || {
        if let Some(s) = reprise_positions::run(&args)? {
            summarize(&s);
        }
        Ok(())
    });
}

fn summarize(s: &reprise_positions::Summary) {
    eprintln!("{} frames of {} clips, {} points each", s.frames, s.clips, s.points);
}
