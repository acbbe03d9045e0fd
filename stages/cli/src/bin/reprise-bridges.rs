//! `reprise-bridges`: see `reprise_bridges` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_bridges::Args::parse();
    reprise_stagekit::main("reprise-bridges", || {
        if let Some(counts) = reprise_bridges::run(&args)? {
            eprintln!("{:<12} {:<12} {:>10} {:>5} {:>12}", "from", "to", "candidates", "kept", "best rig dist");
            for c in &counts {
                eprintln!("{:<12} {:<12} {:>10} {:>5} {:>12.4}", c.from, c.to, c.candidates, c.kept, c.best);
            }
        }
        Ok(())
    });
}
