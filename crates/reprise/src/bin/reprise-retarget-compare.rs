//! `reprise-retarget-compare`: see `reprise_retarget_compare` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_retarget_compare::Args::parse();
    reprise_stagekit::main(
        "reprise-retarget-compare",
        reprise_stagekit::code_id!("REPRISE_CODE_ID_RETARGET_COMPARE"),
        || {
            if let Some(s) = reprise_retarget_compare::run(&args)? {
                eprintln!("{:<48} {:>7} {:>9} {:>9}", "method", "labels", "RMS", "sd");
                for r in &s.rows {
                    eprintln!("{:<48} {:>7} {:>9.4} {:>9.4}", r.method, r.labels, r.rms, r.sd);
                }
            }
            Ok(())
        },
    );
}
