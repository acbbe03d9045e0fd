//! `reprise-ingest`: see `reprise_ingest` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_ingest::Args::parse();
    reprise_stagekit::main("reprise-ingest", reprise_stagekit::code_id!("REPRISE_CODE_ID_INGEST"), || {
        if let Some(s) = reprise_ingest::run(&args)? {
            eprintln!("ingest: {} frames, {} controls, {} clips", s.frames, s.controls, s.clips);
        }
        Ok(())
    });
}
