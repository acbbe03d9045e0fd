//! `reprise-synthesize`: see `reprise_synthesize` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_synthesize::Args::parse();
    reprise_stagekit::main("reprise-synthesize", reprise_stagekit::code_id!("REPRISE_CODE_ID_SYNTHESIZE"), || {
        if let Some(s) = reprise_synthesize::run(&args)? {
            eprintln!("{:<20} {:>7} {:>9} {:>10}", "script", "frames", "switches", "µs/frame");
            for r in &s {
                eprintln!("{:<20} {:>7} {:>9} {:>10.1}", r.name, r.frames, r.switches, r.us_per_frame);
            }
        }
        Ok(())
    });
}
