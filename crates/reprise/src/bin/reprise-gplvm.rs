//! `reprise-gplvm`: see `reprise_gplvm` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_gplvm::Args::parse();
    reprise_stagekit::main("reprise-gplvm", reprise_stagekit::code_id!("REPRISE_CODE_ID_GPLVM"), || {
        if let Some(fits) = reprise_gplvm::run(&args)? {
            eprintln!(
                "{:<12} {:>6} {:>3} {:>11} {:>6} {:>13} {:>12} {:>10} {:>11} {:>8} {:>8} {:>14} {:>8}",
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
                let stages = f.stage_iterations.iter().map(i64::to_string).collect::<Vec<_>>().join("+");
                let stop = if f.converged { f.stop_reason.clone() } else { format!("NOT {}", f.stop_reason) };
                eprintln!(
                    "{:<12} {:>6} {:>3} {:>11} {:>6} {:>13.3} {:>12.3} {:>10.3} {:>11.3} {:>8.1e} {:>8.1e} {:>14} {:>8.1}",
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
            if fits.iter().any(|f| f.heldout_frames > 0) {
                heldout_table(&fits);
            }
        }
        Ok(())
    });
}

/// The held-out and generative checks per label: RMS mesh error, mesh units.
fn heldout_table(fits: &[reprise_artifact::gplvm::FitSummary]) {
    let v = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.4}"));
    eprintln!(
        "held-out frames, basis fitted without them (mesh RMS); generative: held-out frames between two training frames"
    );
    eprintln!(
        "{:<12} {:>3} {:>6} {:>8} {:>8} {:>8}  {:>6} {:>8} {:>8} {:>8}",
        "label", "d", "frames", "GPLVM", "PCA-q", "PCA-d", "frames", "GPLVM", "interp", "interp-d"
    );
    for f in fits {
        eprintln!(
            "{:<12} {:>3} {:>6} {:>8} {:>8} {:>8}  {:>6} {:>8} {:>8} {:>8}",
            f.label,
            f.heldout_d,
            f.heldout_frames,
            v(f.heldout_gplvm_mesh_rmse),
            v(f.heldout_pca_q_mesh_rmse),
            v(f.heldout_pca_d_mesh_rmse),
            f.generative_frames,
            v(f.generative_gplvm_mesh_rmse),
            v(f.generative_interp_mesh_rmse),
            v(f.generative_interp_d_mesh_rmse)
        );
    }
}
