//! `reprise-retarget-fit`: see `reprise_retarget_fit` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_retarget_fit::Args::parse();
    reprise_stagekit::main("reprise-retarget-fit", reprise_stagekit::code_id!("REPRISE_CODE_ID_RETARGET_FIT"), || {
        if let Some(s) = reprise_retarget_fit::run(&args)? {
            summarize(&s);
        }
        Ok(())
    });
}

fn summarize(s: &reprise_retarget_fit::Summary) {
    let (l, src, tgt) = s.rows;
    eprintln!(
        "retarget-fit: {l} labelled pairs, {src} capture frames, {tgt} character poses; q = {}, {} target components \
         ({:.3} of the variance); {} iterations in {:.1} s{}",
        s.q,
        s.components.0,
        s.components.1,
        s.fit.iterations,
        s.fit.seconds,
        if s.fit.converged { "" } else { " (stopped at the cap)" }
    );
}
