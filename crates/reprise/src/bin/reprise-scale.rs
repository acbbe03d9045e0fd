//! `reprise-scale`: see `reprise_scale` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_scale::Args::parse();
    reprise_stagekit::main("reprise-scale", reprise_stagekit::code_id!("REPRISE_CODE_ID_SCALE"), || {
        if let Some(s) = reprise_scale::run(&args)? {
            eprintln!("{:<14} {:>5} {:>9} {:>9}", "label", "used", "constant", "no-effect");
            for (label, used, constant, none) in &s.labels {
                eprintln!("{label:<14} {used:>5} {constant:>9} {none:>9}");
            }
            eprintln!(
                "{} rig evaluations in {:.2} s ({:.0}/s)",
                s.evaluations,
                s.seconds,
                s.evaluations as f64 / s.seconds
            );
        }
        Ok(())
    });
}
