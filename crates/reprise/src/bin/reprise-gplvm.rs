//! `reprise-gplvm`: see `reprise_gplvm` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_gplvm::Args::parse();
    reprise_stagekit::main("reprise-gplvm", reprise_stagekit::code_id!("REPRISE_CODE_ID_GPLVM"), || {
        if let Some(fits) = reprise_gplvm::run(&args)? {
            eprintln!(
                "{:<12} {:>6} {:>3} {:>11} {:>6} {:>13} {:>12} {:>10} {:>11} {:>8} {:>8} {:>14} {:>8}  held-out mesh RMS (GPLVM / PCA-q)",
                "label",
                "frames",
                "d",
                "iters",
                "evals",
                "objective",
                "NLL",
                "dynamics",
                "connect.",
                "rel.dec",
                "rel.grad",
                "stop",
                "seconds"
            );
            for f in &fits {
                let held = match (f.heldout_gplvm_mesh_rmse, f.heldout_pca_mesh_rmse) {
                    (Some(g), Some(p)) => format!("{g:.4} / {p:.4} ({} frames)", f.heldout_frames),
                    _ => "-".into(),
                };
                let stages = f.stage_iterations.iter().map(i64::to_string).collect::<Vec<_>>().join("+");
                let stop = if f.converged { f.stop_reason.clone() } else { format!("NOT {}", f.stop_reason) };
                eprintln!(
                    "{:<12} {:>6} {:>3} {:>11} {:>6} {:>13.3} {:>12.3} {:>10.3} {:>11.3} {:>8.1e} {:>8.1e} {:>14} {:>8.1}  {held}",
                    f.label,
                    f.frames,
                    f.d,
                    stages,
                    f.evaluations,
                    f.objective,
                    f.neg_log_likelihood,
                    f.dynamics,
                    f.connectivity,
                    f.rel_decrease,
                    f.rel_gradient,
                    stop,
                    f.seconds
                );
            }
        }
        Ok(())
    });
}
