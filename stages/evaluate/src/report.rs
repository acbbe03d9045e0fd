//! The Markdown report: conclusions, the overall table, latency, liveliness and
//! plausibility by phase, paired comparisons, the per-pair grids, model quality and the
//! definitions of every metric — the content of [`crate::model`], written as Markdown.

use std::fmt::Write as _;

use reprise_benchmark::metrics;
use reprise_benchmark::verdict::Verdict;

use crate::aggregate::Metric;
use crate::model::{self as page, Table};
pub use crate::model::{cell, overall_cell, Context};
pub use reprise_benchmark::verdict::find;

/// The report.
pub fn markdown(m: &[Metric], ctx: &Context<'_>) -> String {
    let mut s = String::new();
    let others: Vec<&str> = ctx.systems.iter().skip(1).map(|(_, n)| n.as_str()).collect();
    let _ = writeln!(s, "# {}: reprise against {}\n", ctx.name, others.join(", "));
    conclusions(&mut s, m, ctx);
    for t in page::metric_tables(m, ctx) {
        table(&mut s, &t);
    }
    paired_grids(&mut s, m, ctx);
    coverage(&mut s, m, ctx);
    table(&mut s, &page::quality(m, ctx));
    definitions(&mut s, ctx);
    s
}

/// A verdict in words, with `bold` around a name.
pub fn verdict_words(v: &Verdict, bold: impl Fn(&str) -> String) -> String {
    match v {
        Verdict::Best { system, clear: true } => format!("{} is best, clear of the runner-up's CI", bold(system)),
        Verdict::Best { system, clear: false } => {
            format!("{} is best, but its CI overlaps the runner-up's (not a clear win)", bold(system))
        }
        Verdict::Tie(t) => format!("{} tie exactly", bold(&t.join(", "))),
        Verdict::NotRanked(why) => format!("not ranked ({why})"),
    }
}

fn conclusions(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let _ = writeln!(s, "## Conclusions\n");
    for (shown, wins) in page::wins(ctx) {
        let list: Vec<String> =
            wins.iter().map(|(id, q)| if q.is_empty() { id.to_string() } else { format!("{id} ({q})") }).collect();
        let _ = writeln!(
            s,
            "- **{shown}** is best on: {}.",
            if list.is_empty() { "nothing ranked here".to_string() } else { list.join(", ") }
        );
    }
    let _ = writeln!(s);
    for sentence in page::sentences(m, ctx) {
        let values: Vec<String> = sentence.values.iter().map(|(n, v)| format!("{n} {v}")).collect();
        let _ = writeln!(
            s,
            "- `{}`: {} — {}.",
            sentence.metric,
            verdict_words(&sentence.verdict, |n| format!("**{n}**")),
            values.join("; ")
        );
    }
    for n in page::notes(m, ctx) {
        let _ = writeln!(s, "- {n}");
    }
    let _ = writeln!(s);
}

/// A table as Markdown, best cells in bold.
fn table(s: &mut String, t: &Table) {
    let _ = writeln!(s, "## {}\n", t.title);
    let _ = writeln!(s, "| {} |\n|{}", t.head.join(" | "), "---|".repeat(t.head.len()));
    for r in &t.rows {
        let cells: Vec<String> =
            r.iter().map(|c| if c.best { format!("**{}**", c.text) } else { c.text.clone() }).collect();
        let _ = writeln!(s, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(s);
}

fn paired_grids(s: &mut String, m: &[Metric], ctx: &Context<'_>) {
    let Some((ours, ours_shown)) = ctx.systems.first() else { return };
    for (id, shown) in ctx.systems.iter().skip(1) {
        let system = format!("{ours} vs {id}");
        let _ = writeln!(
            s,
            "### Paired perceived latency by label pair, {ours_shown} − {shown} (s; * where the CI excludes 0)\n"
        );
        grid(s, ctx.labels, |a, b| {
            find(m, &system, "paired_perceived_latency_s", a, b).filter(|d| d.n > 0).map(|d| {
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
        "## Coverage within {} s (share of the pair's requests arriving in B in time; {})\n",
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

fn definitions(s: &mut String, ctx: &Context<'_>) {
    let t = ctx.training;
    let _ = writeln!(
        s,
        "## Definitions\n\n\
         Every system answers the same seeded requests \"from this training frame of A, reach B, then go on as B\" \
         (after its label switch, each system plays its {k}-frame blend and then the same `hold` seconds in B by its own \
         native continuation: reprise by the paper's IDLE command, the others by playing B's clip on) and is measured by \
         the same code on meshes evaluated through the rig. Only the frames after the request are measured; they split \
         into **reach** (before the system's first frame labelled B), **blend** (its first {k} frames labelled B) and \
         **settle** (the rest). Every mean is over requests (a request's frames are averaged first) and every CI \
         resamples requests.\n",
        k = ctx.window
    );
    s.push_str(&metrics::reference_table());
    let _ = writeln!(
        s,
        "\nSettings and reference values: arrival needs h = {h} B-like frames in a row; the coverage horizon is T = {cs} s; \
         the latency horizon is τ = {tau} s; \
         the discontinuity window is W = {w} frames, centred on the label switch (moved inside the answer when the switch \
         is near an end); a pose jump is a peak vertex speed above {jr} × the training 99th percentile ({s99:.4} mesh \
         units/s); training 95th percentiles of peak vertex acceleration and jerk: {a95:.4} mesh units/s², {j95:.4} mesh \
         units/s³; plausibility is measured on {st} after the request, in scaled control space as a \
         multiple of the median distance between consecutive training frames ({step:.4}) and on the mesh as the RMS \
         vertex distance to the nearest of the {mc} nearest in scaled space, a multiple of the median RMS vertex motion \
         per frame ({ms:.4} mesh units). CIs: 95 % percentile bootstrap of the mean over requests, {res} resamples, \
         seeded. The Motion Graph keeps {kept} of {all} training frames after pruning to its largest strongly connected \
         component.",
        h = ctx.arrival_frames,
        tau = ctx.latency_horizon,
        w = ctx.discontinuity_window,
        jr = ctx.jump_ratio,
        s99 = t.speed99,
        cs = ctx.coverage_seconds,
        a95 = t.acc95,
        j95 = t.jerk95,
        st = if ctx.stride == 1 { "every frame".to_string() } else { format!("every {} frame", ordinal(ctx.stride)) },
        step = t.step,
        mc = crate::training::MESH_CANDIDATES,
        ms = t.mesh_step,
        res = crate::aggregate::RESAMPLES,
        kept = ctx.graph_kept.0,
        all = ctx.graph_kept.1,
    );
}

/// `n` as an English ordinal: 1st, 2nd, 3rd, 4th, …, 11th, 12th, 13th, 21st.
pub fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::aggregate::metric;
    use reprise_benchmark::Conclusions;

    pub(crate) fn systems() -> Vec<(String, String)> {
        reprise_benchmark::systems::SYSTEMS.iter().map(|d| (d.id.to_string(), d.shown.to_string())).collect()
    }

    /// `f` given a context over two labels `a`, `b`, the synthetic training reference,
    /// `systems` and the conclusions of `m`.
    pub(crate) fn with_ctx<T>(
        systems: &[(String, String)],
        m: &[Metric],
        deterministic: &[&str],
        f: impl FnOnce(&Context<'_>) -> T,
    ) -> T {
        let labels = vec!["a".to_string(), "b".to_string()];
        let training = crate::training::tests::training();
        let ids: Vec<&str> = systems.iter().map(|(id, _)| id.as_str()).collect();
        let conclusions = Conclusions::new(m, &ids);
        let ctx = Context {
            name: "synthetic",
            labels: &labels,
            systems,
            training: &training,
            conclusions: &conclusions,
            window: 12,
            coverage_seconds: 2.0,
            latency_horizon: 4.0,
            jump_ratio: 2.0,
            stride: 3,
            arrival_frames: 6,
            discontinuity_window: 24,
            graph_kept: (1, 2),
            deterministic: deterministic.iter().map(|d| d.to_string()).collect(),
            refusals: vec![],
            ablation: &[],
        };
        f(&ctx)
    }

    fn latencies(reprise: f64, graph: f64) -> Vec<Metric> {
        let row =
            |sys: &str, v: f64| metric(sys, "perceived_latency_s", "all", "all", &[v - 0.01, v, v + 0.01], "s", 1);
        vec![row("reprise", reprise), row("motion-graphs", graph), row("motion-matching", 0.1), row("crossfade", 0.04)]
    }

    /// A latency a system has by its design is ranked like any other: the crossfade's
    /// one-frame answer wins, and the report says so in both places.
    #[test]
    fn a_latency_set_by_design_is_ranked() {
        let sys = systems();
        let m = latencies(0.5, 2.0);
        with_ctx(&sys, &m, &["motion-matching", "crossfade"], |ctx| {
            let md = markdown(&m, ctx);
            assert!(md.contains("**Crossfade** is best on: perceived_latency_s."), "{md}");
            assert!(md.contains("- `perceived_latency_s`: **Crossfade** is best, clear of the runner-up's CI"), "{md}");
            assert!(!md.contains("by construction"), "{md}");
            assert!(md.contains("**reprise** is best on: nothing ranked here."), "{md}");
        });
    }

    /// The conclusions and the overall table say the same, whichever way the numbers fall.
    #[test]
    fn conclusions_agree_with_the_overall_table() {
        let sys = systems();
        for (ours, graph) in [(2.0, 0.5), (0.5, 2.0), (0.03, 2.0)] {
            let m = latencies(ours, graph);
            with_ctx(&sys, &m, &[], |ctx| {
                let t = page::overall(&m, ctx);
                let row = t.rows.iter().find(|r| r[0].text == "`perceived_latency_s`").unwrap();
                let bold: Vec<usize> = (1..=sys.len()).filter(|&i| row[i].best).collect();
                let ranking = ctx.conclusions.ranking("perceived_latency_s").unwrap();
                let Verdict::Best { system, .. } = &ranking.verdict else { panic!("{ranking:?}") };
                let at = sys.iter().position(|(id, _)| id == system).unwrap() + 1;
                assert_eq!(bold, vec![at]);
                // The best cell holds the lowest value.
                let lowest = m.iter().min_by(|a, b| a.value.total_cmp(&b.value)).unwrap();
                assert_eq!(&lowest.system, system);
                assert!(
                    markdown(&m, ctx).contains(&format!("**{}** is best on: perceived_latency_s", ctx.shown(system)))
                );
            });
        }
    }

    /// Overlapping CIs and exact ties are called so, and a deterministic system's variety
    /// is shown as such, not ranked.
    #[test]
    fn overlapping_cis_ties_and_variety() {
        let sys = systems();
        let m = vec![
            metric("reprise", "discontinuity_accel", "all", "all", &[0.4, 0.5, 0.6, 0.5], "ratio", 1),
            metric("motion-graphs", "discontinuity_accel", "all", "all", &[0.45, 0.55, 0.65, 0.55], "ratio", 1),
            metric("reprise", "success", "all", "all", &[1.0, 1.0], "share", 1),
            metric("motion-graphs", "success", "all", "all", &[1.0, 1.0], "share", 1),
        ];
        with_ctx(&sys, &m, &["crossfade"], |ctx| {
            let md = markdown(&m, ctx);
            assert!(md.contains("discontinuity_accel (CI overlaps the runner-up)"), "{md}");
            assert!(md.contains("**reprise, Motion Graphs** tie exactly"), "{md}");
            assert_eq!(overall_cell(&m, ctx, "crossfade", "variety"), "0 (deterministic)");
            assert!(md.contains("not ranked: it rewards noise"), "{md}");
        });
    }

    /// The ablation table: the paper's method, each improvement alone, then every one on
    /// (`reprise`), a row per ranked headline metric with the best marked; no table without
    /// the ablation's systems.
    #[test]
    fn the_ablation_table_brackets_each_improvement() {
        let sys = systems();
        let latency = |id: &str, v: f64| metric(id, "perceived_latency_s", "all", "all", &[v, v], "s", 1);
        let m = vec![
            latency("reprise-paper", 1.8),
            latency("reprise-paper-settle", 0.9),
            latency("reprise-paper-live-idle", 1.7),
            latency("reprise", 1.0),
        ];
        with_ctx(&sys, &m, &[], |ctx| assert!(crate::model::ablation(&m, ctx).is_none()));
        let ablation: Vec<(String, String)> = ["reprise-paper-live-idle", "reprise-paper-settle"]
            .iter()
            .map(|id| (id.to_string(), reprise_benchmark::systems::shown(id).to_string()))
            .collect();
        with_ctx(&sys, &m, &[], |ctx| {
            let ctx = Context { ablation: &ablation, ..ctx.clone() };
            let t = crate::model::ablation(&m, &ctx).expect("a table");
            assert_eq!(
                t.head,
                ["metric", "reprise (paper)", "paper + live-idle", "paper + settle", "reprise (all on)"]
            );
            let row = t.rows.iter().find(|r| r[0].text == "`perceived_latency_s`").expect("the latency row");
            let best: Vec<bool> = row[1..].iter().map(|c| c.best).collect();
            assert_eq!(best, [false, false, true, false], "settle alone is the fastest");
            assert!(row[1].text.starts_with("1.800"), "{}", row[1].text);
        });
    }

    /// A clear overall win that the paired table contradicts is stated beside the
    /// conclusions.
    #[test]
    fn a_contradicting_paired_row_is_reported() {
        let sys = systems();
        let mut m = latencies(0.5, 2.0);
        m.retain(|r| r.system == "reprise" || r.system == "motion-graphs");
        m.push(metric(
            "reprise vs motion-graphs",
            "paired_perceived_latency_s",
            "all",
            "all",
            &[0.1, 0.2, 0.3],
            "s",
            1,
        ));
        with_ctx(&sys, &m, &[], |ctx| {
            let md = markdown(&m, ctx);
            assert!(md.contains("on the requests both answered Motion Graphs is ahead"), "{md}");
        });
    }

    #[test]
    fn ordinals_read_as_english() {
        let got: Vec<String> = [1, 2, 3, 4, 11, 12, 13, 21, 22, 101, 111].into_iter().map(super::ordinal).collect();
        assert_eq!(got, ["1st", "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", "22nd", "101st", "111th"]);
    }
}
