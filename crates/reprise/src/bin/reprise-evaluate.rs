//! `reprise-evaluate`: see `reprise_evaluate` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_evaluate::Args::parse();
    reprise_stagekit::main("reprise-evaluate", reprise_stagekit::code_id!("REPRISE_CODE_ID_EVALUATE"), || {
        if let Some(m) = reprise_evaluate::run(&args)? {
            for row in m.iter().filter(|m| m.from == "all") {
                eprintln!(
                    "{:<9} {:<18} {:>10.4} [{:.4}, {:.4}] {}",
                    row.system,
                    row.metric,
                    row.value,
                    row.ci_low.unwrap_or(f64::NAN),
                    row.ci_high.unwrap_or(f64::NAN),
                    row.unit
                );
            }
            eprintln!("report: {}", args.io.report.display());
        }
        Ok(())
    });
}
