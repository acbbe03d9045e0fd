//! `reprise-invrig-fit`: see `reprise_invrig_fit` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_invrig_fit::Args::parse();
    reprise_stagekit::main("reprise-invrig-fit", reprise_stagekit::code_id!("REPRISE_CODE_ID_INVRIG_FIT"), || {
        if let Some(s) = reprise_invrig_fit::run(&args)? {
            summarize(&s);
        }
        Ok(())
    });
}

fn summarize(s: &reprise_invrig_fit::Summary) {
    eprintln!(
        "{} poses kept of {} training frames, {} points, {} of {} controls free",
        s.samples, s.training, s.points, s.free.0, s.free.1
    );
    eprintln!(
        "theta0 = {:.4} (validation error {:.4}); cross-validation {:.1} s, subsampling {:.1} s",
        s.theta0.0, s.theta0.1, s.seconds.0, s.seconds.1
    );
}
