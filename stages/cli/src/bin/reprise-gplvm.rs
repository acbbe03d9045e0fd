//! `reprise-gplvm`: see `reprise_gplvm` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_gplvm::Args::parse();
    reprise_stagekit::main("reprise-gplvm", || {
        if let Some(fits) = reprise_gplvm::run(&args)? {
            eprintln!(
                "{:<12} {:>6} {:>3} {:>6} {:>14} {:>12} {:>9} {:>10} {:>8}  held-out mesh RMS (GPLVM / PCA-q)",
                "label", "frames", "d", "iters", "objective", "NLL", "|grad|", "stop", "seconds"
            );
            for f in &fits {
                let held = match (f.heldout_gplvm_mesh_rmse, f.heldout_pca_mesh_rmse) {
                    (Some(g), Some(p)) => format!("{g:.4} / {p:.4} ({} frames)", f.heldout_frames),
                    _ => "-".into(),
                };
                eprintln!(
                    "{:<12} {:>6} {:>3} {:>6} {:>14.3} {:>12.3} {:>9.2e} {:>10} {:>8.1}  {held}",
                    f.label,
                    f.frames,
                    f.d,
                    f.iterations,
                    f.objective,
                    f.neg_log_likelihood,
                    f.grad_norm,
                    f.stop_reason,
                    f.seconds
                );
            }
        }
        Ok(())
    });
}
