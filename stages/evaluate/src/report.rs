//! The Markdown report: conclusions, the overall table, plausibility by phase, paired
//! comparisons, coverage, model quality and the definitions of every metric.

use std::fmt::Write as _;

use crate::aggregate::{Metric, PAIRED};
use crate::measure::{Phase, PlausibilityReference as Reference, Space};
use crate::training::Training;

/// What the report needs besides the metric rows.
pub struct Context<'a> {
    /// The pipeline's name.
    pub name: &'a str,
    /// Label order.
    pub labels: &'a [String],
    /// Systems compared: (id, shown name).
    pub systems: &'a [(String, String)],
    /// The training reference.
    pub training: &'a Training,
    /// Blend length (frames).
    pub window: usize,
    /// Coverage horizon (s).
    pub coverage_seconds: f64,
    /// Pose-jump threshold (× training p99 of peak vertex speed).
    pub jump_ratio: f64,
    /// Plausibility stride.
    pub stride: usize,
    /// Motion graph: frames kept by pruning, of all.
    pub graph_kept: (usize, usize),
    /// Systems answering the same under every seed (variety 0 by construction).
    pub deterministic: Vec<String>,
}

/// Whether a lower value of `metric` is better (`None`: not ranked).
pub fn lower_is_better(metric: &str) -> Option<bool> {
    match metric {
        "answered" | "success" | "coverage" => Some(false),
        "variety" => None,
        m if m == "latency_s" || m.starts_with("peak_") || m.starts_with("plausibility") => Some(true),
        _ => None,
    }
}

/// The overall metrics, in report order.
pub const OVERALL: [&str; 9] = [
    "answered",
    "success",
    "coverage",
    "latency_s",
    "peak_accel_ratio",
    "peak_jerk_ratio",
    "plausibility_raw_scaled",
    "plausibility_floor_scaled",
    "variety",
];

/// The row of `system`'s `metric` over `from` → `to`.
pub fn find<'a>(m: &'a [Metric], system: &str, metric: &str, from: &str, to: &str) -> Option<&'a Metric> {
    m.iter().find(|x| x.system == system && x.metric == metric && x.from == from && x.to == to)
}

/// `value [ci_low, ci_high]` to 3 decimals (`–` where not measured).
pub fn cell(m: Option<&Metric>) -> String {
    match m {
        Some(m) if m.n == 0 => "–".into(),
        Some(m) => match (m.ci_low, m.ci_high) {
            (Some(lo), Some(hi)) => format!("{:.3} [{lo:.3}, {hi:.3}]", m.value),
            _ => format!("{:.3}", m.value),
        },
        None => "–".into(),
    }
}

/// `system`'s overall `metric` as a cell: measured values with their CI, values that follow
/// from construction marked so (a deterministic system's variety is 0, shown, not measured).
pub fn overall_cell(m: &[Metric], ctx: &Context<'_>, system: &str, metric: &str) -> String {
    if metric == "variety" && ctx.deterministic.iter().any(|d| d == system) {
        return "0 (deterministic)".into();
    }
    let v = cell(find(m, system, metric, "all", "all"));
    if v != "–" && crate::systems::constructed(system, metric).is_some() {
        format!("{v} (by construction)")
    } else {
        v
    }
}

/// The systems whose overall `metric` follows from construction, with why: `shown: why`.
pub fn constructed_notes(ctx: &Context<'_>, metric: &str) -> Vec<String> {
    ctx.systems
        .iter()
        .filter_map(|(id, shown)| crate::systems::constructed(id, metric).map(|why| format!("{shown}: {why}")))
        .collect()
}

/// Who is best on `metric` overall.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict<'a> {
    /// One system, and whether its CI overlaps the runner-up's.
    Best(&'a str, bool),
    /// Several systems share the best value exactly.
    Tie(Vec<&'a str>),
}

/// The best system on `metric` overall (`None`: not ranked, or fewer than two measured).
/// Only measured values compete: a value that follows from a system's construction
/// ([`crate::systems::constructed`]) is left out of the ranking.
pub fn best<'a>(m: &[Metric], ctx: &'a Context<'_>, metric: &str) -> Option<Verdict<'a>> {
    let lower = lower_is_better(metric)?;
    let mut v: Vec<(&str, &Metric)> = ctx
        .systems
        .iter()
        .filter(|(id, _)| crate::systems::constructed(id, metric).is_none())
        .filter_map(|(id, shown)| find(m, id, metric, "all", "all").map(|x| (shown.as_str(), x)))
        .filter(|(_, x)| x.value.is_finite() && x.n > 0)
        .collect();
    if v.len() < 2 {
        return None;
    }
    v.sort_by(|a, b| if lower { a.1.value.total_cmp(&b.1.value) } else { b.1.value.total_cmp(&a.1.value) });
    let top = v[0].1.value;
    let tied: Vec<&str> = v.iter().take_while(|(_, x)| x.value == top).map(|(s, _)| *s).collect();
    if tied.len() > 1 {
        return Some(Verdict::Tie(tied));
    }
    let (a, b) = (v[0].1, v[1].1);
    let overlap = match (a.ci_low, a.ci_high, b.ci_low, b.ci_high) {
        (Some(al), Some(ah), Some(bl), Some(bh)) => al <= bh && bl <= ah,
        _ => false,
    };
    Some(Verdict::Best(v[0].0, overlap))
}

/// The report.
pub fn markdown(m: &[Metric], ctx: &Context<'_>) -> String {
    let mut s = String::new();
    let others: Vec<&str> = ctx.systems.iter().skip(1).map(|(_, n)| n.as_str()).collect();
    let _ = writeln!(s, "# {}: reprise against {}\n", ctx.name, others.join(", "));
    conclusions(&mut s, m, ctx);
    overall(&mut s, m, ctx);
    plausibility(&mut s, m, ctx);
    paired(&mut s, m, ctx);
    coverage(&mut s, m, ctx);
    quality(&mut s, m, ctx);
    definitions(&mut s, ctx);
    s
}

fn conclusions(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let _ = writeln!(s, "## Conclusions\n");
    for (_, shown) in ctx.systems {
        let wins: Vec<String> = OVERALL
            .iter()
            .filter_map(|name| match best(m, ctx, name) {
                Some(Verdict::Best(b, overlap)) if b == shown => {
                    Some(if overlap { format!("{name} (CI overlaps the runner-up)") } else { name.to_string() })
                }
                Some(Verdict::Tie(t)) if t.contains(&shown.as_str()) => Some(format!("{name} (tied)")),
                _ => None,
            })
            .collect();
        let _ = writeln!(
            s,
            "- **{shown}** is best on: {}.",
            if wins.is_empty() { "nothing measured here".to_string() } else { wins.join(", ") }
        );
    }
    for name in OVERALL {
        let notes = constructed_notes(ctx, name);
        if !notes.is_empty() {
            let _ = writeln!(s, "- `{name}` follows from construction, so is not ranked, for {}.", notes.join("; "));
        }
    }
    let _ = writeln!(
        s,
        "- Systems that replay training frames have a raw plausibility floor of 0 away from their blends; reprise's poses \
         live in each label's PCA subspace, so compare `plausibility_floor_*` (0 for a training frame and for its PCA \
         projection alike) for like with like.\n"
    );
}

fn overall(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let _ = writeln!(s, "## Overall (all label pairs; mean [95 % bootstrap CI])\n");
    let names: Vec<&str> = ctx.systems.iter().map(|(_, n)| n.as_str()).collect();
    let _ = writeln!(s, "| metric | {} | best |\n|---|{}---|", names.join(" | "), "---|".repeat(names.len()));
    for name in OVERALL {
        let cells: Vec<String> = ctx.systems.iter().map(|(id, _)| overall_cell(m, ctx, id, name)).collect();
        let verdict = match best(m, ctx, name) {
            _ if name == "variety" => "not ranked (read beside plausibility)".to_string(),
            Some(Verdict::Best(b, true)) => format!("{b} (CIs overlap)"),
            Some(Verdict::Best(b, false)) => b.to_string(),
            Some(Verdict::Tie(t)) => format!("tie: {}", t.join(", ")),
            None => "–".into(),
        };
        let _ = writeln!(s, "| `{name}` | {} | {verdict} |", cells.join(" | "));
    }
    let pts = |sys: &str| {
        m.iter().filter(|x| x.system == sys && x.metric == "transition_points").map(|x| x.value).sum::<f64>()
    };
    let _ = writeln!(
        s,
        "\nTransition points (not ranked): {:.0} bridges (reprise), {:.0} transition edges (Motion Graphs). The Motion Graph \
         keeps {} of {} training frames after pruning to its largest strongly connected component.\n",
        pts("reprise"),
        pts("baseline"),
        ctx.graph_kept.0,
        ctx.graph_kept.1
    );
}

fn plausibility(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let _ = writeln!(s, "## Plausibility by phase (all pairs; mean [95 % CI]; lower is closer to training poses)\n");
    let names: Vec<&str> = ctx.systems.iter().map(|(_, n)| n.as_str()).collect();
    let _ = writeln!(
        s,
        "| reference | space | phase | {} |\n|---|---|---|{}",
        names.join(" | "),
        "---|".repeat(names.len())
    );
    for r in Reference::ALL {
        for sp in Space::ALL {
            let phases = Phase::ALL.into_iter().map(Some).chain(std::iter::once(None));
            for phase in phases {
                let name = crate::measure::plausibility::metric_name(r, sp, phase);
                let cells: Vec<String> =
                    ctx.systems.iter().map(|(id, _)| cell(find(m, id, &name, "all", "all"))).collect();
                let shown = phase.map_or("answer", Phase::name);
                let _ = writeln!(s, "| {} | {} | {shown} | {} |", r.name(), sp.name(), cells.join(" | "));
            }
        }
    }
    let _ = writeln!(s);
}

fn paired(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let Some((ours, ours_shown)) = ctx.systems.first() else { return };
    let _ = writeln!(s, "## Paired, on the requests both systems answered ({ours_shown} − other; mean [95 % CI])\n");
    let _ = writeln!(s, "| against | metric | difference | n | lower is |\n|---|---|---|---|---|");
    for (id, shown) in ctx.systems.iter().skip(1) {
        let system = format!("{ours} vs {id}");
        for (name, _) in PAIRED {
            if let Some(d) = find(m, &system, &format!("paired_{name}"), "all", "all") {
                let side = match (d.ci_low, d.ci_high) {
                    (_, Some(hi)) if hi < 0.0 => format!("{ours_shown} (CI below 0)"),
                    (Some(lo), _) if lo > 0.0 => format!("{shown} (CI above 0)"),
                    _ => "neither (CI spans 0)".into(),
                };
                let _ = writeln!(s, "| {shown} | `{name}` | {} | {} | {side} |", cell(Some(d)), d.n);
            }
        }
    }
    for (id, shown) in ctx.systems.iter().skip(1) {
        let system = format!("{ours} vs {id}");
        let _ =
            writeln!(s, "\n### Paired latency by label pair, {ours_shown} − {shown} (s; * where the CI excludes 0)\n");
        grid(s, ctx.labels, |a, b| {
            find(m, &system, "paired_latency_s", a, b).filter(|d| d.n > 0).map(|d| {
                let sig = matches!((d.ci_low, d.ci_high), (Some(lo), Some(hi)) if lo > 0.0 || hi < 0.0);
                format!("{:+.2}{}", d.value, if sig { "*" } else { "" })
            })
        });
    }
    let _ = writeln!(s);
}

/// A label × label table; `cell(a, b)` for a ≠ b.
fn grid(s: &mut String, labels: &[String], cell: impl Fn(&str, &str) -> Option<String>) {
    let _ = write!(s, "| from \\ to |");
    for l in labels {
        let _ = write!(s, " {l} |");
    }
    let _ = writeln!(s, "\n|---|{}", "---|".repeat(labels.len()));
    for a in labels {
        let _ = write!(s, "| {a} |");
        for b in labels {
            let v = if a == b { "–".to_string() } else { cell(a, b).unwrap_or_else(|| "–".into()) };
            let _ = write!(s, " {v} |");
        }
        let _ = writeln!(s);
    }
}

fn coverage(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let names: Vec<&str> = ctx.systems.iter().map(|(_, n)| n.as_str()).collect();
    let _ = writeln!(
        s,
        "## Coverage within {} s (share of the pair's requests reaching B in time; {})\n",
        ctx.coverage_seconds,
        names.join(" / ")
    );
    grid(s, ctx.labels, |a, b| {
        let v: Vec<String> = ctx
            .systems
            .iter()
            .map(|(id, _)| find(m, id, "coverage", a, b).map_or("–".to_string(), |x| format!("{:.2}", x.value)))
            .collect();
        Some(v.join(" / "))
    });
    let _ = writeln!(s);
}

fn quality(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let _ = writeln!(
        s,
        "## Model quality\n\n| label | held-out GPLVM | held-out PCA (q) | PCA d = 3 scaled | unscaled |\n|---|---|---|---|---|"
    );
    for l in ctx.labels {
        let v = |sys, name| find(m, sys, name, l, "").map_or("–".to_string(), |x| format!("{:.4}", x.value));
        let _ = writeln!(
            s,
            "| {l} | {} | {} | {} | {} |",
            v("gplvm", "heldout_mesh_rmse"),
            v("pca", "heldout_mesh_rmse"),
            v("scaled", "ablation_mesh_rmse"),
            v("unscaled", "ablation_mesh_rmse")
        );
    }
    let _ = writeln!(s);
}

fn definitions(s: &mut String, ctx: &Context<'_>) {
    let t = ctx.training;
    let _ = writeln!(
        s,
        "## Definitions\n\n\
         Every system answers the same seeded requests \"from this training frame of A, reach B\" and is measured by the \
         same code on meshes evaluated through the rig. An answer's frames split into phases: **hold** (up to the request), \
         **reach** (after the request, before the first frame of B), **blend** (the first {k} frames of B) and **settle** \
         (the rest).\n\n\
         - `answered`: share of requests answered (reaching B); an unanswered request records why.\n\
         - `success`: share of requests answered with no frame after the request whose peak vertex speed exceeds {jr} × the \
         training data's 99th percentile ({s99:.4} mesh units/s) — one criterion for every system.\n\
         - `coverage`: simulated — the share of the benchmark's requests from A (seeded start frames, the same for every \
         system) answered with the first frame of B within {cs} s of the request.\n\
         - `latency_s`: seconds from the request to the first frame of B (a blended frame counts as B's); any hold before \
         the request counts for no one.\n\
         - `peak_accel_ratio`, `peak_jerk_ratio`: per answered request, the largest per-frame peak vertex acceleration (jerk) \
         — max over vertices of the central second (third) difference of positions × fps² (fps³) — from the request to the \
         end of the blend, divided by the training data's 95th percentile of the same quantity ({a95:.4} mesh units/s², \
         {j95:.4} mesh units/s³).\n\
         - `plausibility_<reference>_<space>[_<phase>]`: per played frame (every {st}-th), the distance to the nearest \
         reference pose. Reference `raw`: the training frames; `floor` (floor-matched): the nearer of a training frame \
         and that frame projected through its own label's PCA, so a replayed frame and a PCA-reproduced one both score 0 \
         and neither representation is charged for its own floor. Space `scaled`: Euclidean in scaled control space, divided by the median distance between consecutive \
         training frames ({step:.4}); `mesh`: RMS vertex distance to the nearest of the {mc} nearest in scaled space, \
         divided by the median RMS vertex motion between consecutive training frames ({ms:.4} mesh units). Without a \
         phase: reach, blend and settle together.\n\
         - `variety`: per request, the mean over frames of the RMS vertex distance between the system's answer and its \
         answer under another seed (reprise: the random force; Motion Graphs: another near-shortest path). A system \
         without a seed answers the same every time: its variety is 0 by construction and is shown, not measured. Never \
         ranked: it rewards noise as much as real alternatives, so read it beside plausibility.\n\
         - `paired_*`: per request answered by both systems, the first system's value minus the other's; mean and CI.\n\
         - `transition_points`: bridges A → B (reprise); transition edges from A to B in the pruned graph (Motion Graphs).\n\
         - `heldout_mesh_rmse`: RMS vertex error of held-out frames (GPLVM through its best latent point; PCA with q \
         components of the same training frames); `ablation_mesh_rmse`: RMS vertex error of 3-component PCA, scaled against \
         unscaled controls.\n\
         - CIs: 95 % percentile bootstrap of the mean, {res} resamples, seeded. \"CIs overlap\" marks a best value whose CI \
         overlaps the runner-up's.",
        k = ctx.window,
        jr = ctx.jump_ratio,
        s99 = t.speed99,
        cs = ctx.coverage_seconds,
        a95 = t.acc95,
        j95 = t.jerk95,
        st = ctx.stride,
        step = t.step,
        mc = crate::training::MESH_CANDIDATES,
        ms = t.mesh_step,
        res = crate::aggregate::RESAMPLES,
    );
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::aggregate::metric;

    fn systems() -> Vec<(String, String)> {
        crate::systems::KNOWN.iter().map(|(id, shown)| (id.to_string(), shown.to_string())).collect()
    }

    /// `f` given a context over two labels `a`, `b`, the synthetic training reference and
    /// `systems`, with `deterministic` systems.
    pub(crate) fn with_ctx<T>(
        systems: &[(String, String)],
        deterministic: &[&str],
        f: impl FnOnce(&Context<'_>) -> T,
    ) -> T {
        let labels = vec!["a".to_string(), "b".to_string()];
        let training = crate::training::tests::training();
        let ctx = Context {
            name: "synthetic",
            labels: &labels,
            systems,
            training: &training,
            window: 12,
            coverage_seconds: 2.0,
            jump_ratio: 2.0,
            stride: 3,
            graph_kept: (1, 2),
            deterministic: deterministic.iter().map(|d| d.to_string()).collect(),
        };
        f(&ctx)
    }

    fn latencies(reprise: f64, graph: f64) -> Vec<Metric> {
        let row = |sys: &str, v: f64| metric(sys, "latency_s", "all", "all", &[v - 0.01, v, v + 0.01], "s", 1);
        vec![row("reprise", reprise), row("baseline", graph), row("motion-matching", 0.06), row("crossfade", 0.04)]
    }

    #[test]
    fn a_latency_set_by_a_schedule_is_shown_but_not_ranked() {
        let sys = systems();
        with_ctx(&sys, &["motion-matching", "crossfade"], |ctx| {
            // The crossfade's one-frame latency is the lowest, but follows from construction.
            let m = latencies(0.5, 2.0);
            assert_eq!(best(&m, ctx, "latency_s"), Some(Verdict::Best("reprise", false)));
            assert_eq!(
                overall_cell(&m, ctx, "crossfade", "latency_s"),
                format!("{} (by construction)", cell(m.get(3)))
            );
            assert_eq!(overall_cell(&m, ctx, "reprise", "latency_s"), cell(m.first()));
            let md = markdown(&m, ctx);
            assert!(md.contains("`latency_s` follows from construction"), "{md}");
            assert!(md.contains("**Crossfade** is best on: nothing measured here."), "{md}");
        });
    }

    #[test]
    fn reprise_loses_latency_when_the_graph_is_faster() {
        let sys = systems();
        with_ctx(&sys, &["motion-matching", "crossfade"], |ctx| {
            let m = latencies(2.0, 0.5);
            assert_eq!(best(&m, ctx, "latency_s"), Some(Verdict::Best("Motion Graphs", false)));
            assert!(markdown(&m, ctx).contains("**Motion Graphs** is best on: latency_s."));
        });
    }

    #[test]
    fn fewer_than_two_measured_values_rank_no_one() {
        let sys = systems();
        with_ctx(&sys, &["motion-matching", "crossfade"], |ctx| {
            let m: Vec<Metric> = latencies(0.5, 2.0).into_iter().filter(|x| x.system != "baseline").collect();
            assert_eq!(best(&m, ctx, "latency_s"), None);
            assert_eq!(overall_cell(&m, ctx, "baseline", "latency_s"), "–");
            assert_eq!(overall_cell(&m, ctx, "crossfade", "variety"), "0 (deterministic)");
        });
    }

    #[test]
    fn overlapping_cis_and_exact_ties_are_called_so() {
        let sys = systems();
        with_ctx(&sys, &["motion-matching", "crossfade"], |ctx| {
            let close = vec![
                metric("reprise", "peak_accel_ratio", "all", "all", &[0.4, 0.5, 0.6, 0.5], "ratio", 1),
                metric("baseline", "peak_accel_ratio", "all", "all", &[0.45, 0.55, 0.65, 0.55], "ratio", 1),
            ];
            assert!(matches!(best(&close, ctx, "peak_accel_ratio"), Some(Verdict::Best("reprise", true))));
            let tied = vec![
                metric("reprise", "success", "all", "all", &[1.0, 1.0], "share", 1),
                metric("baseline", "success", "all", "all", &[1.0, 1.0], "share", 1),
            ];
            assert_eq!(best(&tied, ctx, "success"), Some(Verdict::Tie(vec!["reprise", "Motion Graphs"])));
        });
    }
}
