//! The stage's summary on stderr: one line per fitted label, then (when the held-out check
//! ran) its errors per label.

use std::fmt;

use reprise_artifact::gplvm::FitSummary;

/// Each label's fit: frames, PCA dimension, iterations per optimiser stage, evaluations,
/// the objective and its parts, the convergence measures, why it stopped ("NOT …" when it
/// did not converge) and seconds; then the held-out table when any label has one.
pub struct Fits<'a>(pub &'a [FitSummary]);

impl fmt::Display for Fits<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<12} {:>6} {:>3} {:>7} {:>11} {:>6} {:>13} {:>12} {:>10} {:>11} {:>8} {:>8} {:>14} {:>8}",
            "label",
            "frames",
            "d",
            "GP",
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
        )?;
        for s in self.0 {
            let stages = s.stage_iterations.iter().map(i64::to_string).collect::<Vec<_>>().join("+");
            let stop = if s.converged { s.stop_reason.clone() } else { format!("NOT {}", s.stop_reason) };
            writeln!(
                f,
                "{:<12} {:>6} {:>3} {:>7} {:>11} {:>6} {:>13.3} {:>12.3} {:>10.3} {:>11.3} {:>8.1e} {:>8.1e} {:>14} {:>8.1}",
                s.label,
                s.frames,
                s.d,
                if s.inducing_points > 0 { format!("M={}", s.inducing_points) } else { "dense".into() },
                stages,
                s.evaluations,
                s.objective,
                s.neg_log_likelihood,
                s.dynamics,
                s.connectivity,
                s.rel_decrease,
                s.rel_gradient,
                stop,
                s.seconds
            )?;
        }
        if self.0.iter().any(|s| s.heldout_frames > 0) {
            write!(f, "{}", Heldout(self.0))?;
        }
        Ok(())
    }
}

/// The held-out and generative checks per label: RMS mesh error, mesh units ("-" where a
/// check did not run).
pub struct Heldout<'a>(pub &'a [FitSummary]);

impl fmt::Display for Heldout<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.4}"));
        writeln!(
            f,
            "held-out frames, basis fitted without them (mesh RMS); generative: held-out frames between two training frames"
        )?;
        writeln!(
            f,
            "{:<12} {:>3} {:>6} {:>8} {:>8} {:>8}  {:>6} {:>8} {:>8} {:>8}",
            "label", "d", "frames", "GPLVM", "PCA-q", "PCA-d", "frames", "GPLVM", "interp", "interp-d"
        )?;
        for s in self.0 {
            writeln!(
                f,
                "{:<12} {:>3} {:>6} {:>8} {:>8} {:>8}  {:>6} {:>8} {:>8} {:>8}",
                s.label,
                s.heldout_d,
                s.heldout_frames,
                v(s.heldout_gplvm_mesh_rmse),
                v(s.heldout_pca_q_mesh_rmse),
                v(s.heldout_pca_d_mesh_rmse),
                s.generative_frames,
                v(s.generative_gplvm_mesh_rmse),
                v(s.generative_interp_mesh_rmse),
                v(s.generative_interp_d_mesh_rmse)
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(label: &str, converged: bool, heldout_frames: i64) -> FitSummary {
        FitSummary {
            label: label.into(),
            frames: 120,
            d: 7,
            q: 3,
            inducing_points: 0,
            optimizer: "lbfgs".into(),
            connectivity_path: "exact".into(),
            stage_iterations: vec![40, 212],
            iterations: 252,
            evaluations: 270,
            initial_objective: 10.0,
            objective: -1234.5678,
            neg_log_likelihood: -1300.0,
            dynamics: 50.0,
            connectivity: 10.0,
            signal: 5.4,
            connectivity_exact: Some(10.0),
            grad_norm: 1e-6,
            rel_decrease: 1e-10,
            rel_gradient: 1e-6,
            jitter: 0.0,
            dynamics_jitter: 0.0,
            converged,
            stop_reason: "window".into(),
            seconds: 12.34,
            heldout_gplvm_mesh_rmse: (heldout_frames > 0).then_some(0.1917),
            heldout_pca_q_mesh_rmse: (heldout_frames > 0).then_some(0.2654),
            heldout_pca_d_mesh_rmse: (heldout_frames > 0).then_some(0.1916),
            heldout_d: 7,
            heldout_frames,
            generative_gplvm_mesh_rmse: None,
            generative_interp_mesh_rmse: None,
            generative_interp_d_mesh_rmse: None,
            generative_frames: 0,
        }
    }

    /// One line per label after the header; a fit that did not converge says NOT; the
    /// held-out table follows only when a label has held-out frames, "-" where a check
    /// did not run.
    #[test]
    fn the_fit_table_says_what_each_fit_did() {
        let text = Fits(&[fit("happy", true, 0), fit("roar", false, 0)]).to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert!(lines[1].starts_with("happy") && lines[1].contains("40+212") && lines[1].contains("-1234.568"));
        assert!(lines[1].contains(" window ") && lines[2].contains("NOT window"), "{text}");
        let text = Fits(&[fit("happy", true, 12)]).to_string();
        let held = text.lines().last().unwrap();
        assert!(held.starts_with("happy") && held.contains("0.1917") && held.contains("0.2654"), "{text}");
        assert!(held.trim_end().ends_with('-'), "{held}");
    }
}
