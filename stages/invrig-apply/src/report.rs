//! The report: the paper's Table 1 on these positions, aggregated from the per-frame rows
//! ([`table`]) and rendered as Markdown ([`markdown`]).

use reprise_artifact::invrig::{FrameError, Mapping};
use reprise_invrig::mapping::Method;
use reprise_invrig::refine::RefineSettings;

use crate::{MethodRun, Summary};

/// One method's line of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The method.
    pub method: Method,
    /// Frames measured.
    pub frames: usize,
    /// Mean joint error (mean squared point distance), length unit².
    pub joint_error: f64,
    /// Mean point distance, length unit.
    pub joint_distance: f64,
    /// The largest frame's mean point distance, length unit: a pose out of the rig's reach
    /// shows here.
    pub worst_distance: f64,
    /// Mean ground-truth error over the frames whose curves are known, with their count.
    pub truth_error: Option<(f64, usize)>,
    /// Seconds of all frames' methods plus set-up.
    pub seconds: f64,
    /// Frames per second of one stream: frames / (sum of per-frame times + set-up).
    pub fps: f64,
    /// Mean refinement steps.
    pub iterations: f64,
    /// Mean rig evaluations per frame.
    pub evaluations: f64,
    /// Frames whose refinement stopped without progress (the pose out of the rig's reach
    /// from there).
    pub no_progress: usize,
}

/// The table's rows: every method that ran, in the order run, over the rows it wrote.
pub fn table(runs: &[MethodRun], errors: &[FrameError]) -> Vec<Row> {
    runs.iter()
        .filter(|r| r.skipped.is_none())
        .map(|run| {
            let rows: Vec<&FrameError> = errors.iter().filter(|e| e.method == run.method.name()).collect();
            let n = rows.len().max(1) as f64;
            let mean = |f: fn(&FrameError) -> f64| rows.iter().map(|e| f(e)).sum::<f64>() / n;
            let known: Vec<f64> = rows.iter().filter_map(|e| e.truth_error).collect();
            let seconds = rows.iter().map(|e| e.ms).sum::<f64>() / 1e3 + run.setup_seconds;
            Row {
                method: run.method,
                frames: rows.len(),
                joint_error: mean(|e| e.joint_error),
                joint_distance: mean(|e| e.joint_distance),
                worst_distance: rows.iter().map(|e| e.joint_distance).fold(0.0, f64::max),
                truth_error: (!known.is_empty()).then(|| (known.iter().sum::<f64>() / known.len() as f64, known.len())),
                seconds,
                fps: rows.len() as f64 / seconds.max(1e-12),
                iterations: mean(|e| e.iterations as f64),
                evaluations: mean(|e| e.evaluations as f64),
                no_progress: rows.iter().filter(|e| e.stop == "no-progress").count(),
            }
        })
        .collect()
}

/// The rest-pose start against the regression's, in words that follow the numbers: the
/// paper's Fig. 11 finding (the controls drift without the learned start) is stated only
/// where this table shows it.
fn rest_start_line(c: &Row, r: &Row) -> String {
    let joints =
        format!("joint error {} from the rest pose vs {} from the regression", sig(r.joint_error), sig(c.joint_error));
    match (c.truth_error, r.truth_error) {
        (Some((ct, _)), Some((rt, _))) if rt > ct => format!(
            "- Starting from the rest pose instead of the regression: {joints}; ground-truth error {} vs {}: without \
             the learned start the controls drift further from the animator's (the paper's Fig. 11).\n",
            sig(rt),
            sig(ct)
        ),
        (Some((ct, _)), Some((rt, _))) => format!(
            "- Starting from the rest pose instead of the regression: {joints}; ground-truth error {} vs {}: here the \
             learned start does **not** keep the controls closer to the animator's (unlike the paper's Fig. 11).\n",
            sig(rt),
            sig(ct)
        ),
        _ => format!("- Starting from the rest pose instead of the regression: {joints}.\n"),
    }
}

/// What the Markdown needs besides the summary.
pub struct Context<'a> {
    /// The stage's result.
    pub summary: &'a Summary,
    /// The mapping applied.
    pub mapping: &'a Mapping,
    /// Its training poses.
    pub samples: usize,
    /// Its controls.
    pub controls: usize,
    /// The method whose curves were written.
    pub written: Method,
    /// The refinement's settings.
    pub settings: &'a RefineSettings,
    /// The finite-difference step.
    pub step: f64,
}

/// `x` to four significant figures (scientific notation outside [1e-3, 1e5)).
pub fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{x:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
}

fn label(m: Method) -> &'static str {
    match m {
        Method::Nearest => "Nearest neighbour",
        Method::Gpr => "GPR",
        Method::GprLearnedJacobian => "GPR & learned Jacobian",
        Method::GprComputedJacobian => "GPR & computed Jacobian",
        Method::GprBroydenJacobian => "GPR & computed Jacobian, Broyden-updated",
        Method::RestComputedJacobian => "Rest pose & computed Jacobian",
    }
}

/// The report in Markdown.
pub fn markdown(ctx: &Context<'_>) -> String {
    let s = ctx.summary;
    let m = ctx.mapping;
    let rows = table(&s.runs, &s.errors);
    let free = m.free_controls.len();
    let mut md = String::new();
    md.push_str("# Inverse rig mapping\n\n");
    md.push_str(&format!(
        "{} frames of positions ({} points) mapped to {} controls ({free} free, the rest held) by a mapping fitted on \
         {} poses kept of {} training frames (θ₀ = {}, θ₁ = {:.1e}; held out of training: {}). The curves written \
         are **{}**'s{}.\n\n",
        s.frames,
        m.points.len(),
        ctx.controls,
        ctx.samples,
        m.training_frames,
        sig(m.theta0),
        m.theta1,
        if m.held_out_clips.is_empty() { "nothing".to_string() } else { m.held_out_clips.join(", ") },
        label(ctx.written),
        if s.carried > 0 { format!(", with {} clips of known curves carried over", s.carried) } else { String::new() },
    ));
    md.push_str(
        "Joint error: mean over points of the squared distance between the target and the rig at the controls \
         found (length unit²); distance: its unsquared mean. Ground-truth error: mean over controls of the squared \
         control error, where the curves are known. Worst frame: the largest mean distance of one frame (a pose \
         the rig cannot reach shows here, and in every frame's row of `invrig_errors`). Frames per second: one stream, the frames over the sum of the \
         per-frame times (set-up included). Every method is measured by the same code on the same frames.\n\n",
    );
    md.push_str("| method | joint error | mean distance | worst frame's distance | ground-truth error | total s | frames/s | iterations | rig evaluations/frame | no progress |\n");
    md.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for r in &rows {
        let truth = r.truth_error.map_or("—".to_string(), |(e, _)| sig(e));
        md.push_str(&format!(
            "| {} | {} | {} | {} | {truth} | {:.2} | {:.1} | {:.1} | {:.0} | {} |\n",
            label(r.method),
            sig(r.joint_error),
            sig(r.joint_distance),
            sig(r.worst_distance),
            r.seconds,
            r.fps,
            r.iterations,
            r.evaluations,
            r.no_progress
        ));
    }
    for run in s.runs.iter().filter(|r| r.skipped.is_some()) {
        md.push_str(&format!(
            "| {} | not run: {} | | | | | | | | |\n",
            label(run.method),
            run.skipped.as_deref().unwrap_or_default()
        ));
    }
    md.push('\n');
    let find = |m: Method| rows.iter().find(|r| r.method == m);
    if let (Some(g), Some(c)) = (find(Method::Gpr), find(Method::GprComputedJacobian)) {
        md.push_str(&format!(
            "- The computed-Jacobian refinement's joint error is {} × the regression's.\n",
            sig(c.joint_error / g.joint_error.max(f64::MIN_POSITIVE))
        ));
    }
    if let (Some(c), Some(r)) = (find(Method::GprComputedJacobian), find(Method::RestComputedJacobian)) {
        md.push_str(&rest_start_line(c, r));
    }
    md.push_str(&format!(
        "- A computed Jacobian costs {} rig evaluations ({free} free controls + 1) of {:.3} ms each here: {:.1} ms; \
         a step is damped by λ = {:.1e} (length unit per control unit), at most {} steps, tolerance {:.1e}, finite-difference step {:.1e}.\n",
        free + 1,
        s.eval_ms,
        (free + 1) as f64 * s.eval_ms,
        ctx.settings.lambda,
        ctx.settings.max_iters,
        ctx.settings.tolerance,
        ctx.step,
    ));
    for run in s.runs.iter().filter(|r| r.jacobian_poses > 0) {
        md.push_str(&format!(
            "- {}: learned from the finite-difference Jacobians at {} of the {} training poses{}, set-up {:.2} s.\n",
            label(run.method),
            run.jacobian_poses,
            ctx.samples,
            if run.jacobian_poses < ctx.samples {
                " (as many as fit in --max-jacobian-mib, spread by farthest points)"
            } else {
                ""
            },
            run.setup_seconds
        ));
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, je: f64, truth: Option<f64>, ms: f64, stop: &str) -> FrameError {
        FrameError {
            method: method.into(),
            clip: "c".into(),
            frame: 0,
            joint_error: je,
            joint_distance: je.sqrt(),
            truth_error: truth,
            iterations: 2,
            evaluations: 10,
            ms,
            stop: stop.into(),
        }
    }

    #[test]
    fn four_significant_figures() {
        assert_eq!(sig(0.012345), "0.01235");
        assert_eq!(sig(123.456), "123.5");
        assert_eq!(sig(2.0e-6), "2.000e-6");
        assert_eq!(sig(0.0), "0");
    }

    #[test]
    fn the_rest_start_sentence_follows_the_numbers() {
        let runs = vec![
            MethodRun { method: Method::GprComputedJacobian, setup_seconds: 0.0, jacobian_poses: 0, skipped: None },
            MethodRun { method: Method::RestComputedJacobian, setup_seconds: 0.0, jacobian_poses: 0, skipped: None },
        ];
        let line = |c: f64, r: f64| {
            let rows = [
                row("gpr-computed-jacobian", 0.1, Some(c), 1.0, ""),
                row("rest-computed-jacobian", 0.2, Some(r), 1.0, ""),
            ];
            let t = table(&runs, &rows);
            rest_start_line(&t[0], &t[1])
        };
        assert!(line(0.3, 0.5).contains("drift further"));
        let against = line(1.0, 0.5);
        assert!(against.contains("does **not**") && !against.contains("drift further"), "{against}");
    }

    #[test]
    fn the_table_averages_each_methods_own_rows() {
        let runs = vec![
            MethodRun { method: Method::Gpr, setup_seconds: 0.0, jacobian_poses: 0, skipped: None },
            MethodRun { method: Method::GprLearnedJacobian, setup_seconds: 1.0, jacobian_poses: 3, skipped: None },
            MethodRun {
                method: Method::Nearest,
                setup_seconds: 0.0,
                jacobian_poses: 0,
                skipped: Some("too big".into()),
            },
        ];
        let errors = vec![
            row("gpr", 4.0, Some(1.0), 1.0, ""),
            row("gpr", 2.0, None, 3.0, ""),
            row("gpr-learned-jacobian", 1.0, Some(0.5), 500.0, "no-progress"),
        ];
        let t = table(&runs, &errors);
        assert_eq!(t.len(), 2);
        assert_eq!((t[0].frames, t[0].joint_error, t[0].truth_error), (2, 3.0, Some((1.0, 1))));
        assert_eq!(t[0].worst_distance, 2.0);
        assert!((t[0].fps - 2.0 / 0.004).abs() < 1e-9);
        // Set-up counts in the learned Jacobian's time.
        assert!((t[1].seconds - 1.5).abs() < 1e-12 && t[1].no_progress == 1);
    }
}
