//! `reprise-replay`: see `reprise_replay` for what it does (`reprise replay` runs it on a
//! pipeline, then `evaluate`).
use clap::Parser;

fn main() {
    let args = reprise_replay::Args::parse();
    reprise_stagekit::main("reprise-replay", reprise_stagekit::code_id!("REPRISE_CODE_ID_REPLAY"), || {
        if let Some(r) = reprise_replay::run(&args)? {
            eprintln!("replay: {} requests (one per TRANSITION command)", r.requests.len());
            for s in r.summaries() {
                eprintln!("{s}");
            }
        }
        Ok(())
    });
}
