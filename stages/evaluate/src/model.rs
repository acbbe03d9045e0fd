//! The report's content, built once from the metric rows and the conclusions, below both
//! renderers: [`crate::report`] writes it as Markdown, `html` as HTML. Cells hold
//! plain text; each renderer marks up the best cells and the names in its own way.

use reprise_benchmark::metrics::{self, Direction};
use reprise_benchmark::verdict::{find, Conclusions, Verdict};
use reprise_benchmark::Metric;

use crate::measure::{Phase, PlausibilityReference as Reference, Space};
use crate::training::Training;

/// What the report needs besides the metric rows.
#[derive(Clone)]
pub struct Context<'a> {
    /// The pipeline's name.
    pub name: &'a str,
    /// Label order.
    pub labels: &'a [String],
    /// Systems compared: (id, shown name), the method under test first.
    pub systems: &'a [(String, String)],
    /// The training reference.
    pub training: &'a Training,
    /// The verdicts, computed once from the rows.
    pub conclusions: &'a Conclusions,
    /// Blend length (frames).
    pub window: usize,
    /// Coverage horizon (s).
    pub coverage_seconds: f64,
    /// Latency horizon τ (s).
    pub latency_horizon: f64,
    /// Pose-jump threshold (× training p99 of peak vertex speed).
    pub jump_ratio: f64,
    /// Plausibility stride.
    pub stride: usize,
    /// Frames in a row that make an arrival.
    pub arrival_frames: usize,
    /// Frames of the discontinuity window.
    pub discontinuity_window: usize,
    /// Motion graph: frames kept by pruning, of all.
    pub graph_kept: (usize, usize),
    /// Systems answering the same under every seed (variety 0 by construction).
    pub deterministic: Vec<String>,
    /// Each system's unanswered requests and the reasons it gave.
    pub refusals: Vec<crate::systems::Refusals>,
    /// The ablation's systems measured: (id, shown name), the paper with one improvement
    /// on each (`reprise_benchmark::systems::ABLATION`).
    pub ablation: &'a [(String, String)],
}

impl Context<'_> {
    /// The shown name of system `id`.
    pub fn shown<'b>(&'b self, id: &'b str) -> &'b str {
        self.systems.iter().find(|(i, _)| i == id).map_or(id, |(_, s)| s.as_str())
    }
}

/// One table cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Plain text.
    pub text: String,
    /// The best value of its row.
    pub best: bool,
    /// A number (right-aligned).
    pub numeric: bool,
}

impl Cell {
    /// A text cell.
    pub fn text(s: impl Into<String>) -> Self {
        Self { text: s.into(), best: false, numeric: false }
    }

    /// A numeric cell.
    pub fn num(s: impl Into<String>) -> Self {
        Self { text: s.into(), best: false, numeric: true }
    }
}

/// A table of the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Anchor id.
    pub id: &'static str,
    /// Heading.
    pub title: String,
    /// Header cells.
    pub head: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<Cell>>,
}

/// `value [ci_low, ci_high]` to 3 decimals (`–` where not measured).
pub fn cell(m: Option<&Metric>) -> String {
    match m {
        Some(m) if m.n == 0 || !m.value.is_finite() => "–".into(),
        Some(m) => match (m.ci_low, m.ci_high) {
            (Some(lo), Some(hi)) => format!("{:.3} [{lo:.3}, {hi:.3}]", m.value),
            _ => format!("{:.3}", m.value),
        },
        None => "–".into(),
    }
}

/// `system`'s overall `metric` as a cell (a deterministic system's variety is 0 by
/// construction: shown so, not measured).
pub fn overall_cell(m: &[Metric], ctx: &Context<'_>, system: &str, metric: &str) -> String {
    if metric == "variety" && ctx.deterministic.iter().any(|d| d == system) {
        return "0 (deterministic)".into();
    }
    cell(find(m, system, metric, "all", "all"))
}

/// One conclusion: a headline metric's verdict in words (names are shown names).
#[derive(Debug, Clone, PartialEq)]
pub struct Sentence {
    /// The metric id.
    pub metric: &'static str,
    /// What it measures and which way is better.
    pub what: String,
    /// The verdict.
    pub verdict: Verdict,
    /// Every system's value, best first: (shown name, cell).
    pub values: Vec<(String, String)>,
}

/// The conclusions in words: one sentence per headline metric.
pub fn sentences(m: &[Metric], ctx: &Context<'_>) -> Vec<Sentence> {
    ctx.conclusions
        .rankings
        .iter()
        .map(|r| {
            let shown = |id: &str| ctx.shown(id).to_string();
            let verdict = match &r.verdict {
                Verdict::Best { system, clear } => Verdict::Best { system: shown(system), clear: *clear },
                Verdict::Tie(t) => Verdict::Tie(t.iter().map(|s| shown(s)).collect()),
                v => v.clone(),
            };
            let mut order: Vec<&str> = r.order.iter().map(String::as_str).collect();
            order.extend(ctx.systems.iter().map(|(id, _)| id.as_str()).filter(|id| !r.order.iter().any(|o| o == id)));
            Sentence {
                metric: r.metric.id,
                what: match r.metric.direction {
                    Direction::NotRanked(_) => r.metric.definition.to_string(),
                    d => format!("{}; {}", r.metric.definition, d.phrase()),
                },
                verdict,
                values: order.iter().map(|id| (shown(id), overall_cell(m, ctx, id, r.metric.id))).collect(),
            }
        })
        .collect()
}

/// Per system (shown name), the headline metrics it is best or tied best on: (metric id,
/// qualifier — empty, "tied" or "CI overlaps the runner-up").
pub fn wins(ctx: &Context<'_>) -> Vec<(String, Vec<(&'static str, &'static str)>)> {
    ctx.systems
        .iter()
        .map(|(id, shown)| {
            let w = ctx
                .conclusions
                .wins(id)
                .into_iter()
                .map(|r| {
                    let q = match r.verdict {
                        Verdict::Tie(_) => "tied",
                        Verdict::Best { clear: false, .. } => "CI overlaps the runner-up",
                        _ => "",
                    };
                    (r.metric.id, q)
                })
                .collect();
            (shown.clone(), w)
        })
        .collect()
}

/// Notes that qualify the conclusions: where the paired table disagrees with a clear
/// verdict, the share of starts on bridge points, and how often each system routes.
pub fn notes(m: &[Metric], ctx: &Context<'_>) -> Vec<String> {
    let mut out = Vec::new();
    for d in ctx.conclusions.disagreements(m) {
        out.push(format!(
            "`{}`: {} is best over all its answers, but on the requests both answered {} is ahead ({} − {} = {}).",
            d.metric,
            ctx.shown(&d.best),
            ctx.shown(&d.other),
            ctx.shown(d.paired.system.split(" vs ").next().unwrap_or("")),
            ctx.shown(d.paired.system.split(" vs ").nth(1).unwrap_or("")),
            cell(Some(&d.paired))
        ));
    }
    if let Some(s) = find(m, "requests", "start_on_bridge", "all", "all").filter(|s| s.n > 0) {
        out.push(format!(
            "{:.0} % of the requests start on a bridge point of their pair (reprise can leave there with no travel); every \
             system is asked the same requests.",
            100.0 * s.value
        ));
    }
    let routed: Vec<String> = ctx
        .systems
        .iter()
        .filter_map(|(id, shown)| {
            let r = find(m, id, "routed", "all", "all").filter(|r| r.n > 0)?;
            let lat = |name| cell(find(m, id, name, "all", "all"));
            Some(format!(
                "{shown} {:.0} % (perceived latency direct {}, routed {})",
                100.0 * r.value,
                lat("latency_direct_s"),
                lat("latency_routed_s")
            ))
        })
        .collect();
    if !routed.is_empty() {
        out.push(format!("Answers routed through a third label: {}.", routed.join("; ")));
    }
    out.extend(ctx.refusals.iter().filter(|r| r.refused > 0).map(refusal_note));
    out
}

/// The most reasons a refusal note names.
const REASONS_NAMED: usize = 3;

/// Why a system left requests unanswered, in its own words: the most frequent reasons with
/// their counts, the rest counted.
fn refusal_note(r: &crate::systems::Refusals) -> String {
    let named: Vec<String> = r.reasons.iter().take(REASONS_NAMED).map(|(why, n)| format!("{n} × {why}")).collect();
    let rest: usize = r.reasons.iter().skip(REASONS_NAMED).map(|(_, n)| n).sum();
    let more = match r.reasons.len().saturating_sub(REASONS_NAMED) {
        0 => String::new(),
        k => format!("; {rest} more for {k} other reason{}", if k == 1 { "" } else { "s" }),
    };
    format!(
        "{} did not answer {} of {} requests (counted against it in `answered`, `arrived`, `coverage` and the latency): {}{more}.",
        r.system,
        r.refused,
        r.asked,
        named.join("; ")
    )
}

fn system_head(first: &[&str], ctx: &Context<'_>) -> Vec<String> {
    let mut h: Vec<String> = first.iter().map(|s| s.to_string()).collect();
    h.extend(ctx.systems.iter().map(|(_, n)| n.clone()));
    h
}

/// The systems `reprise-paper` and `reprise` bracket the ablation with: the paper's method,
/// and every improvement on.
const ABLATION_ENDS: [&str; 2] = ["reprise-paper", "reprise"];

/// The metric tables both report forms show, in their order: overall, the ablation (when
/// its systems were given), latency, liveliness, plausibility and the paired comparisons.
pub fn metric_tables(m: &[Metric], ctx: &Context<'_>) -> Vec<Table> {
    [
        Some(overall(m, ctx)),
        ablation(m, ctx),
        Some(latency(m, ctx)),
        Some(liveliness(m, ctx)),
        Some(plausibility(m, ctx)),
        Some(paired(m, ctx)),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The ablation: every ranked headline metric for the paper's method, the paper with each
/// improvement alone, and every improvement on (`reprise`), on the same requests; the best
/// of each row marked. `None` without the ablation's systems.
pub fn ablation(m: &[Metric], ctx: &Context<'_>) -> Option<Table> {
    if ctx.ablation.is_empty() {
        return None;
    }
    let ends: Vec<(String, String)> =
        ABLATION_ENDS.iter().filter_map(|id| ctx.systems.iter().find(|(i, _)| i == id).cloned()).collect();
    let [paper, tuned] = ends.as_slice() else { return None };
    let columns: Vec<(&str, &str)> = std::iter::once(paper)
        .chain(ctx.ablation)
        .chain(std::iter::once(tuned))
        .map(|(id, shown)| (id.as_str(), shown.as_str()))
        .collect();
    let mut head = vec!["metric".to_string()];
    head.extend(columns.iter().map(|(id, shown)| match *id {
        "reprise" => format!("{shown} (all on)"),
        _ => shown.to_string(),
    }));
    let rows = reprise_benchmark::metrics::headlines()
        .filter_map(|def| {
            let badness = |v: f64| def.direction.badness(v);
            badness(0.0)?;
            let found: Vec<Option<&Metric>> =
                columns.iter().map(|(id, _)| find(m, id, def.id, "all", "all").filter(|r| r.n > 0)).collect();
            let best = found
                .iter()
                .flatten()
                .filter_map(|r| badness(r.value))
                .filter(|b| b.is_finite())
                .fold(f64::INFINITY, f64::min);
            let mut row = vec![Cell::text(format!("`{}`", def.id))];
            row.extend(
                found
                    .iter()
                    .map(|r| Cell { best: r.and_then(|r| badness(r.value)) == Some(best), ..Cell::num(cell(*r)) }),
            );
            Some(row)
        })
        .collect();
    Some(Table {
        id: "ablation",
        title: "Ablation: the paper's method, each improvement alone, and all together (same requests)".into(),
        head,
        rows,
    })
}

/// The overall table: every headline metric, every system, the best marked.
pub fn overall(m: &[Metric], ctx: &Context<'_>) -> Table {
    let mut head = system_head(&["metric"], ctx);
    head.push("best".into());
    let rows = ctx
        .conclusions
        .rankings
        .iter()
        .map(|r| {
            let mut row = vec![Cell::text(format!("`{}`", r.metric.id))];
            for (id, _) in ctx.systems {
                let best = r.won_by(id) && !matches!(r.verdict, Verdict::NotRanked(_));
                row.push(Cell { best, ..Cell::num(overall_cell(m, ctx, id, r.metric.id)) });
            }
            row.push(Cell::text(match &r.verdict {
                Verdict::Best { system, clear: true } => ctx.shown(system).to_string(),
                Verdict::Best { system, clear: false } => format!("{} (CIs overlap)", ctx.shown(system)),
                Verdict::Tie(t) => format!("tie: {}", t.iter().map(|s| ctx.shown(s)).collect::<Vec<_>>().join(", ")),
                Verdict::NotRanked(why) => format!("not ranked: {why}"),
            }));
            row
        })
        .collect();
    Table {
        id: "overall",
        title: "Overall (all label pairs; mean [95 % bootstrap CI] over requests)".into(),
        head,
        rows,
    }
}

/// Latency as the system labels it and as a viewer sees it, and split by route.
pub fn latency(m: &[Metric], ctx: &Context<'_>) -> Table {
    let head = system_head(&["metric", "over"], ctx);
    let rows = [
        "perceived_latency_s",
        "perceived_latency_arrived_s",
        "switch_latency_s",
        "latency_direct_s",
        "latency_routed_s",
        "routed",
        "latency_bridge_start_s",
        "latency_other_start_s",
    ]
    .iter()
    .map(|id| {
        let over = match metrics::find(id).map(|d| d.per) {
            Some(metrics::Per::Arrived) => "requests that arrived",
            Some(metrics::Per::Request) => "every request (censored at τ)",
            _ => "answered requests",
        };
        let mut row = vec![Cell::text(format!("`{id}`")), Cell::text(over)];
        row.extend(ctx.systems.iter().map(|(s, _)| Cell::num(cell(find(m, s, id, "all", "all")))));
        row
    })
    .collect();
    Table {
        id: "latency",
        title: "Latency: perceived, by label switch, and by route (s; mean [95 % CI])".into(),
        head,
        rows,
    }
}

/// A family of per-phase metrics: one row per (name, phase) with every system's value; the
/// best of each row marked by `direction`.
fn phase_rows(m: &[Metric], ctx: &Context<'_>, names: &[(String, Vec<String>)]) -> Vec<Vec<Cell>> {
    let mut rows = Vec::new();
    for (id, labels) in names {
        let direction = metrics::direction_of(id);
        let vals: Vec<Option<&Metric>> =
            ctx.systems.iter().map(|(s, _)| find(m, s, id, "all", "all").filter(|x| x.n > 0)).collect();
        let finite: Vec<f64> =
            vals.iter().filter_map(|v| direction.badness(v.as_ref()?.value)).filter(|b| b.is_finite()).collect();
        // As the rankings: a best cell only among two or more measured values.
        let best = if finite.len() >= 2 { finite.iter().copied().fold(f64::INFINITY, f64::min) } else { f64::NAN };
        let mut row: Vec<Cell> = labels.iter().map(Cell::text).collect();
        for v in vals {
            let is_best = v.and_then(|x| direction.badness(x.value)).is_some_and(|b| b == best);
            row.push(Cell { best: is_best && !matches!(direction, Direction::NotRanked(_)), ..Cell::num(cell(v)) });
        }
        rows.push(row);
    }
    rows
}

/// Liveliness by phase.
pub fn liveliness(m: &[Metric], ctx: &Context<'_>) -> Table {
    let mut names = Vec::new();
    for measure in ["ratio", "ks"] {
        for phase in Phase::AFTER.into_iter().map(Some).chain(std::iter::once(None)) {
            let id = crate::aggregate::liveliness_name(measure, phase);
            names.push((id, vec![measure.to_string(), phase.map_or("after the request", Phase::name).to_string()]));
        }
    }
    names.push(("liveliness_error".into(), vec!["error (abs. ln ratio)".into(), "after the request".into()]));
    Table {
        id: "liveliness",
        title: "Liveliness by phase (ratio: closer to 1 is better; KS: lower is better)".into(),
        head: system_head(&["measure", "phase"], ctx),
        rows: phase_rows(m, ctx, &names),
    }
}

/// Plausibility by phase.
pub fn plausibility(m: &[Metric], ctx: &Context<'_>) -> Table {
    let mut names = Vec::new();
    for r in Reference::ALL {
        for sp in Space::ALL {
            for phase in Phase::AFTER.into_iter().map(Some).chain(std::iter::once(None)) {
                let id = crate::measure::plausibility::metric_name(r, sp, phase);
                let labels =
                    vec![r.name().into(), sp.name().into(), phase.map_or("after the request", Phase::name).into()];
                names.push((id, labels));
            }
        }
    }
    Table {
        id: "phases",
        title: "Plausibility by phase (lower is closer to training poses; mean [95 % CI] over requests)".into(),
        head: system_head(&["reference", "space", "phase"], ctx),
        rows: phase_rows(m, ctx, &names),
    }
}

/// Paired differences of the method under test against every other system.
pub fn paired(m: &[Metric], ctx: &Context<'_>) -> Table {
    let head = ["against", "metric", "difference [95 % CI]", "n", "favours"].map(String::from).to_vec();
    let mut rows = Vec::new();
    if let Some((ours, ours_shown)) = ctx.systems.first() {
        for (id, shown) in ctx.systems.iter().skip(1) {
            for name in crate::aggregate::PAIRED {
                let Some(d) = find(m, &format!("{ours} vs {id}"), &format!("paired_{name}"), "all", "all") else {
                    continue;
                };
                let lower_better = !matches!(metrics::direction_of(name), Direction::Higher);
                let side = match (d.ci_low, d.ci_high) {
                    (_, Some(hi)) if hi < 0.0 => if lower_better { ours_shown } else { shown }.to_string(),
                    (Some(lo), _) if lo > 0.0 => if lower_better { shown } else { ours_shown }.to_string(),
                    _ => "neither (CI spans 0)".into(),
                };
                rows.push(vec![
                    Cell::text(shown),
                    Cell::text(format!("`{name}` ({})", d.unit)),
                    Cell::num(cell(Some(d))),
                    Cell::num(d.n.to_string()),
                    Cell::text(side),
                ]);
            }
        }
    }
    let title = format!(
        "Paired, on the requests both systems answered ({} − other; mean [95 % CI])",
        ctx.systems.first().map_or("", |s| s.1.as_str())
    );
    Table { id: "paired", title, head, rows }
}

/// Held-out model quality and the scaling ablation, per label.
pub fn quality(m: &[Metric], ctx: &Context<'_>) -> Table {
    let cols: [(&str, &str, &str); 8] = [
        ("held-out GPLVM", "gplvm", "heldout_mesh_rmse"),
        ("held-out PCA-q", "pca-q", "heldout_mesh_rmse"),
        ("held-out PCA-d", "pca-d", "heldout_mesh_rmse"),
        ("generative GPLVM", "gplvm", "generative_mesh_rmse"),
        ("generative interpolation", "interpolation", "generative_mesh_rmse"),
        ("generative interpolation in PCA-d", "interpolation-d", "generative_mesh_rmse"),
        ("PCA d = 3, scaled", "scaled", "ablation_mesh_rmse"),
        ("PCA d = 3, unscaled", "unscaled", "ablation_mesh_rmse"),
    ];
    let mut head = vec!["label".to_string()];
    head.extend(cols.iter().map(|c| c.0.to_string()));
    let rows = ctx
        .labels
        .iter()
        .map(|l| {
            let mut row = vec![Cell::text(l)];
            row.extend(cols.iter().map(|&(_, sys, name)| {
                Cell::num(find(m, sys, name, l, "").map_or("–".to_string(), |x| format!("{:.4}", x.value)))
            }));
            row
        })
        .collect();
    let mut title = "Model quality (RMS vertex error, mesh units): held-out frames, every basis fitted without them; \
                     the generative check; the scaling ablation"
        .to_string();
    let flat = no_better_than_pca(m, ctx.labels);
    if !flat.is_empty() {
        title += &format!(
            ". On held-out frames the GPLVM is no better than PCA with as many dimensions (within {:.0} %) for {}: there \
             its latent space adds nothing over a linear one",
            100.0 * (1.0 - NO_BETTER),
            flat.join(", ")
        );
    }
    Table { id: "quality", title, head, rows }
}

/// The GPLVM is "no better than PCA" on a label when its held-out error is at least this
/// share of PCA-q's.
pub const NO_BETTER: f64 = 0.99;

/// The labels whose held-out GPLVM error is at least [`NO_BETTER`] × that of PCA with q
/// dimensions (labels without both are left out).
pub fn no_better_than_pca<'a>(m: &[Metric], labels: &'a [String]) -> Vec<&'a str> {
    labels
        .iter()
        .filter(|l| {
            let at = |sys: &str| find(m, sys, "heldout_mesh_rmse", l, "").map(|x| x.value).filter(|v| v.is_finite());
            matches!((at("gplvm"), at("pca-q")), (Some(g), Some(p)) if g >= NO_BETTER * p)
        })
        .map(String::as_str)
        .collect()
}

/// The stage's log: one line per system and metric over all pairs (`from = all`), its
/// value and 95 % CI; a metric without observations (or not finite) reads "not measured"
/// rather than `NaN`, and a value without a CI has none shown.
pub struct OverallLines<'a>(pub &'a [Metric]);

impl std::fmt::Display for OverallLines<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for row in self.0.iter().filter(|m| m.from == "all") {
            write!(f, "{:<9} {:<18} ", row.system, row.metric)?;
            if row.n == 0 || !row.value.is_finite() {
                writeln!(f, "not measured (no observations)")?;
                continue;
            }
            write!(f, "{:>10.4}", row.value)?;
            if let (Some(lo), Some(hi)) = (row.ci_low.filter(|v| v.is_finite()), row.ci_high.filter(|v| v.is_finite()))
            {
                write!(f, " [{lo:.4}, {hi:.4}]")?;
            }
            writeln!(f, " {}", row.unit)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod quality_tests {
    use super::{no_better_than_pca, Metric};

    fn heldout(system: &str, label: &str, value: f64) -> Metric {
        Metric {
            system: system.into(),
            metric: "heldout_mesh_rmse".into(),
            from: label.into(),
            to: String::new(),
            value,
            ci_low: None,
            ci_high: None,
            n: 10,
            unit: "mesh units".into(),
        }
    }

    /// A label whose GPLVM matches PCA-q on held-out frames (a long mocap take: 0.0139
    /// and 0.0139) is named; a clearly better GPLVM, or a label without both, is not.
    #[test]
    fn a_gplvm_no_better_than_pca_is_named() {
        let m = [
            heldout("gplvm", "take", 0.0139),
            heldout("pca-q", "take", 0.0139),
            heldout("gplvm", "face", 0.010),
            heldout("pca-q", "face", 0.020),
            heldout("gplvm", "lone", 0.5),
        ];
        let labels = ["take", "face", "lone"].map(String::from);
        assert_eq!(no_better_than_pca(&m, &labels), ["take"]);
    }
}

#[cfg(test)]
mod overall_lines_tests {
    use super::{Metric, OverallLines};

    fn row(system: &str, from: &str, value: f64, ci: Option<(f64, f64)>, n: i64) -> Metric {
        Metric {
            system: system.into(),
            metric: "latency".into(),
            from: from.into(),
            to: "all".into(),
            value,
            ci_low: ci.map(|c| c.0),
            ci_high: ci.map(|c| c.1),
            n,
            unit: "frames".into(),
        }
    }

    /// Only rows over all pairs; a CI where there is one; no `NaN` where nothing was
    /// measured (a system that answered nothing).
    #[test]
    fn the_log_says_not_measured_instead_of_nan() {
        let rows = [
            row("reprise", "all", 9.5, Some((8.0, 11.0)), 20),
            row("reprise", "a", 3.0, None, 5),
            row("crossfade", "all", 12.0, None, 1),
            row("motion-graphs", "all", f64::NAN, None, 0),
        ];
        let text = OverallLines(&rows).to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert_eq!(lines[0], "reprise   latency                9.5000 [8.0000, 11.0000] frames");
        assert_eq!(lines[1], "crossfade latency               12.0000 frames");
        assert_eq!(lines[2], "motion-graphs latency            not measured (no observations)");
        assert!(!text.contains("NaN"));
    }
}

#[cfg(test)]
mod refusal_tests {
    use crate::systems::{Played, System};
    use reprise_artifact::transitions::{Answer, Answers, Request};
    use std::collections::BTreeMap;

    fn request(id: i64, to: &str) -> Request {
        Request { request: id, from: "a".into(), to: to.into(), segment_id: 0, clip: "c".into(), frame: 0 }
    }

    /// A system that cannot serve a short label says so by label name, every request
    /// counted; a system that answered everything has nothing to say.
    #[test]
    fn a_system_says_why_it_did_not_answer_by_label() {
        let reqs: Vec<Request> = (0..10).map(|i| request(i, if i < 6 { "short" } else { "long" })).collect();
        let short = "label `short` has no frame to jump to: a frame needs 12 frames of continuation in its segment";
        let mut by_request = std::collections::HashMap::new();
        for r in &reqs {
            let a = match r.request {
                0..=5 => Answer::failed(short),
                6 => Answer::failed("did not reach `long` within the time-out"),
                7 => Answer::failed(""),
                _ => Answer::reached(0, 3),
            };
            by_request.insert(r.request, a);
        }
        let s = System::in_memory("mm", Answers { system: "mm".into(), by_request }, BTreeMap::<i64, Played>::new());
        let r = s.refusals(&reqs);
        assert_eq!((r.refused, r.asked), (8, 10));
        assert_eq!(r.reasons[0], (short.to_string(), 6));
        let note = super::refusal_note(&r);
        assert!(note.starts_with("mm did not answer 8 of 10 requests"), "{note}");
        assert!(note.contains(&format!("6 × {short}")) && note.contains("1 × no reason given"), "{note}");
        assert!(!note.contains("other reason"), "three reasons are all named: {note}");

        let all = System::in_memory(
            "x",
            Answers {
                system: "x".into(),
                by_request: reqs.iter().map(|r| (r.request, Answer::reached(0, 1))).collect(),
            },
            BTreeMap::new(),
        );
        assert_eq!(all.refusals(&reqs).refused, 0);
    }

    /// Past three reasons the rest are counted, not listed.
    #[test]
    fn many_reasons_are_counted_past_three() {
        let r = crate::systems::Refusals {
            system: "s".into(),
            refused: 10,
            asked: 20,
            reasons: (0..5).map(|i| (format!("why {i}"), 2)).collect(),
        };
        let note = super::refusal_note(&r);
        assert!(note.contains("2 × why 2") && !note.contains("why 3"), "{note}");
        assert!(note.ends_with("; 4 more for 2 other reasons."), "{note}");
    }
}
