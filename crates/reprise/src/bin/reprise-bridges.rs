//! `reprise-bridges`: see `reprise_bridges` for what it does.
use std::io::Write as _;

use clap::Parser;

fn main() {
    let args = reprise_bridges::Args::parse();
    reprise_stagekit::main("reprise-bridges", reprise_stagekit::code_id!("REPRISE_CODE_ID_BRIDGES"), || {
        if let Some(out) = reprise_bridges::run(&args)? {
            // One write for the whole table: the runner may run several pairs side by side
            // on one stderr, and whole lines keep the log (and its readers) sane.
            let _ = std::io::stderr().write_all(out.to_string().as_bytes());
        }
        Ok(())
    });
}
