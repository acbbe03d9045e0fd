//! `reprise-retarget-apply`: see `reprise_retarget_apply` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_retarget_apply::Args::parse();
    reprise_stagekit::main(
        "reprise-retarget-apply",
        reprise_stagekit::code_id!("REPRISE_CODE_ID_RETARGET_APPLY"),
        || {
            if let Some(s) = reprise_retarget_apply::run(&args)? {
                summarize(&s);
            }
            Ok(())
        },
    );
}

fn summarize(s: &reprise_retarget_apply::Summary) {
    let ms: Vec<f64> = s.frames.iter().map(|f| f.ms).collect();
    eprintln!(
        "retarget-apply: {} frames, {:.2} ms per frame at p50 ({:.2} at p99)",
        s.frames.len(),
        reprise_motion_metrics::quantile(&ms, 0.5),
        reprise_motion_metrics::quantile(&ms, 0.99)
    );
    let known: Vec<f64> = s.frames.iter().filter_map(|f| f.mesh_error).collect();
    if !known.is_empty() {
        eprintln!("  mesh error: this model {:.4}", known.iter().sum::<f64>() / known.len() as f64);
        for (name, e, _) in &s.baselines {
            eprintln!("  mesh error: {name} {e:.4}");
        }
    }
}
