//! `reprise-invrig-apply`: see `reprise_invrig_apply` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_invrig_apply::Args::parse();
    reprise_stagekit::main("reprise-invrig-apply", reprise_stagekit::code_id!("REPRISE_CODE_ID_INVRIG_APPLY"), || {
        if let Some(s) = reprise_invrig_apply::run(&args)? {
            summarize(&s);
        }
        Ok(())
    });
}

fn summarize(s: &reprise_invrig_apply::Summary) {
    eprintln!("{:<30} {:>12} {:>10} {:>12} {:>9}", "method", "joint error", "distance", "truth error", "frames/s");
    for r in reprise_invrig_apply::report::table(&s.runs, &s.errors) {
        let truth = r.truth_error.map_or("-".to_string(), |(e, _)| format!("{e:.4}"));
        eprintln!(
            "{:<30} {:>12.5} {:>10.4} {:>12} {:>9.1}",
            r.method.name(),
            r.joint_error,
            r.joint_distance,
            truth,
            r.fps
        );
    }
    for r in s.runs.iter().filter(|r| r.skipped.is_some()) {
        eprintln!("{:<30} not run: {}", r.method.name(), r.skipped.as_deref().unwrap_or_default());
    }
}
