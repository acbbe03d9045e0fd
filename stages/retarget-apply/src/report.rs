//! The stage's Markdown report: what was mapped, how fast, how well the capture was
//! explained and, where the character's poses are known, the mesh error beside ridge and
//! GPR on the same labelled pairs.

use std::fmt::Write as _;

use reprise_artifact::retarget::Settings;
use reprise_motion_metrics::quantile;

use crate::{Args, Summary};

/// The report.
pub fn markdown(s: &Summary, settings: &Settings, args: &Args) -> String {
    let mut md = String::new();
    let (l, src, tgt) = s.rows;
    let f = &s.frames;
    let _ = writeln!(md, "# Retargeting: a capture onto the character's rig\n");
    let _ = writeln!(
        md,
        "A shared GPLVM (Bouaziz and Pauly) learned from **{l} labelled pairs**, {src} unlabelled capture \
         frames and {tgt} unlabelled character poses (q = {}, {} target-space components keeping {:.3} of the \
         scaled poses' variance, LLE prior {}). Its fit took {:.1} s ({} iterations, {}).\n",
        settings.q,
        s.components,
        settings.space.explained,
        if settings.lle_neighbours > 0 { format!("on, k = {}", settings.lle_neighbours) } else { "off".into() },
        s.fit_seconds,
        settings.fit.iterations,
        if settings.fit.converged { "converged" } else { "stopped at the iteration cap" },
    );
    let ms: Vec<f64> = f.iter().map(|r| r.ms).collect();
    let _ = writeln!(
        md,
        "**{} frames** of {} markers mapped{}; {} marker value(s) unseen on every frame (`--missing`). \
         σc = {:.3e}, σt = {:.3e} capture units.\n",
        f.len(),
        settings.points.len(),
        if args.temporal { ", each from the previous frame of its clip" } else { ", each alone (no temporal term)" },
        f.first().map_or(0, |r| r.missing),
        settings.capture_noise,
        settings.temporal_noise,
    );
    let _ = writeln!(md, "| per frame | p50 | p99 | mean |\n|---|---|---|---|");
    let row = |md: &mut String, name: &str, v: &[f64], fmt: &dyn Fn(f64) -> String| {
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {} |",
            fmt(quantile(v, 0.5)),
            fmt(quantile(v, 0.99)),
            fmt(crate::mean_where(v, |_| true))
        );
    };
    row(&mut md, "milliseconds (one core)", &ms, &|x| format!("{x:.2}"));
    let residual: Vec<f64> = f.iter().map(|r| r.residual).collect();
    row(&mut md, "capture residual (RMS, capture units)", &residual, &|x| format!("{x:.3e}"));
    let variance: Vec<f64> = f.iter().map(|r| r.variance).collect();
    row(&mut md, "predictive variance σp² (normalised)", &variance, &|x| format!("{x:.3e}"));
    let _ = writeln!(
        md,
        "\nA frame takes {:.2} ms at p99 against the {:.1} ms of a frame at the capture's {} fps (the paper reports \
         30–40 ms); \
         at p50 it is {:.1} × one evaluation of the character's rig ({:.3} ms, measured in the same run).\n",
        quantile(&ms, 0.99),
        1e3 / s.fps,
        s.fps,
        quantile(&ms, 0.5) / s.eval_ms.max(1e-9),
        s.eval_ms
    );
    let _ = writeln!(
        md,
        "The curves play in `retarget.html` (beside the known poses where they are given) and in \
         `retarget.glb`, baked to {} morph targets that leave an RMS vertex error of {:.2e} (the rig's length \
         unit).\n",
        s.baked.0, s.baked.1
    );
    if !s.posed.is_empty() {
        let _ = writeln!(
            md,
            "## Poses completed from fixed controls\n\nEach `--pose` fixes a few controls; the model fills in \
             the rest from its training poses (the paper's Fig. 8). They are the script `posed` of the curves.\n"
        );
        let _ = writeln!(md, "| pose | fixed controls | held within (mesh length) |\n|---|---|---|");
        for (i, (fixed, residual)) in s.posed.iter().enumerate() {
            let list: Vec<String> = fixed
                .iter()
                .map(|&(j, v)| format!("`{}` = {v}", settings.controls.get(j).map_or("?", |n| n)))
                .collect();
            let _ = writeln!(md, "| {i} | {} | {residual:.2e} |", list.join(", "));
        }
        let _ = writeln!(md);
    }
    let errors: Vec<f64> = f.iter().filter_map(|r| r.mesh_error).collect();
    if errors.len() == f.len() && !errors.is_empty() {
        let held_out = f.iter().filter(|r| !r.trained).count();
        let _ = writeln!(
            md,
            "## Against the known poses\n\nMean over frames of the RMS vertex distance to the known pose, the rig's \
             length unit; ridge regression and GPR are fitted on the same {l} labelled pairs (over the capture values \
             seen) and measured by the same code. This measures how well a known map is recovered, not artistic \
             quality. {held_out} of the {} frames were no row of the model (neither labelled nor an unlabelled \
             capture frame); at the capture's rate their neighbours are near copies of them, so the held-out \
             column is optimistic too: protocol A's blocked split is the held-out measurement. The first row is a \
             reference: the known poses projected onto the target space ({} components) and back.\n",
            f.len(),
            s.components
        );
        let _ =
            writeln!(md, "| method | all frames | × GPR | frames not in the model | × GPR |\n|---|---|---|---|---|");
        let gpr = s.baselines.iter().find(|b| b.0 == "GPR").map(|b| (b.1, b.2));
        let ratio = |e: f64, g: Option<f64>| {
            g.filter(|g| *g > 0.0 && e.is_finite()).map_or("–".into(), |g| format!("{:.2}", e / g))
        };
        let ours = (
            "shared GPLVM (this model)".to_string(),
            crate::mean_where(&errors, |_| true),
            crate::mean_where(&errors, |i| !f[i].trained),
        );
        let (floor, others): (Vec<_>, Vec<_>) = s.baselines.iter().partition(|b| b.0 == crate::FLOOR);
        for (name, all, unseen) in floor.into_iter().chain([&ours]).chain(others) {
            let _ = writeln!(
                md,
                "| {name} | {all:.4} | {} | {unseen:.4} | {} |",
                ratio(*all, gpr.map(|g| g.0)),
                ratio(*unseen, gpr.map(|g| g.1))
            );
        }
    }
    md
}

/// The player's caption.
pub fn player_caption(s: &Summary, tracks: &[String]) -> String {
    format!(
        "{} frames at the capture's rate, {} from a shared GPLVM learned from {} labelled pairs; {}. Baked to {} \
         morph targets (RMS vertex error {:.2e}).",
        s.frames.len(),
        tracks.join(" and "),
        s.rows.0,
        if tracks.len() > 1 {
            "the right-hand track is the known pose of each frame, which this measures recovery against (not artistic quality)"
        } else {
            "no known poses were given"
        },
        s.baked.0,
        s.baked.1
    )
}
