//! The metric rows and the verdicts read off them: for each headline metric, every system
//! ordered by its overall value, the best named, and whether its CI clears the runner-up's.
//! Computed once ([`Conclusions::new`]); the Markdown and HTML reports only render them.

use crate::metrics::{self, Direction, MetricDef};

/// One row of the metrics table.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    /// A system id (`reprise`, `motion-graphs`, …), a pair `<a> vs <b>` for paired
    /// differences, or a model variant (`gplvm`, `pca`, `scaled`, `unscaled`).
    pub system: String,
    /// Metric id (see [`metrics::CATALOGUE`]).
    pub metric: String,
    /// Label A (or the label; `all` over pairs).
    pub from: String,
    /// Label B (`all` over pairs; empty for per-label metrics).
    pub to: String,
    /// Mean value.
    pub value: f64,
    /// 95 % CI low.
    pub ci_low: Option<f64>,
    /// 95 % CI high.
    pub ci_high: Option<f64>,
    /// Observations (requests, for the benchmark's metrics).
    pub n: i64,
    /// Unit.
    pub unit: String,
}

/// The row of `system`'s `metric` over `from` → `to`.
pub fn find<'a>(m: &'a [Metric], system: &str, metric: &str, from: &str, to: &str) -> Option<&'a Metric> {
    m.iter().find(|x| x.system == system && x.metric == metric && x.from == from && x.to == to)
}

/// Who is best on one metric.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// One system; `clear` when its CI does not overlap the runner-up's.
    Best {
        /// The system's id.
        system: String,
        /// Whether the CIs are apart.
        clear: bool,
    },
    /// Several systems share the best value exactly (ids).
    Tie(Vec<String>),
    /// Not ranked, and why.
    NotRanked(String),
}

/// One headline metric's ranking.
#[derive(Debug, Clone, PartialEq)]
pub struct Ranking {
    /// The metric.
    pub metric: &'static MetricDef,
    /// The measured systems' ids, best first.
    pub order: Vec<String>,
    /// The verdict.
    pub verdict: Verdict,
}

impl Ranking {
    /// Ranks `systems` (ids) on `metric` by their overall rows (`from = to = "all"`).
    /// Systems without a measured value (no row, NaN, or no observations) are left out.
    pub fn new(rows: &[Metric], systems: &[&str], metric: &'static MetricDef) -> Self {
        let not_ranked =
            |why: &str, order: Vec<String>| Ranking { metric, order, verdict: Verdict::NotRanked(why.into()) };
        let measured: Vec<(&str, &Metric)> = systems
            .iter()
            .filter_map(|id| find(rows, id, metric.id, "all", "all").map(|m| (*id, m)))
            .filter(|(_, m)| m.value.is_finite() && m.n > 0)
            .collect();
        let Some(_) = metric.direction.badness(0.0) else {
            let Direction::NotRanked(why) = metric.direction else { unreachable!("only NotRanked has no badness") };
            return not_ranked(why, measured.iter().map(|(id, _)| id.to_string()).collect());
        };
        let bad = |m: &Metric| metric.direction.badness(m.value).unwrap_or(f64::INFINITY);
        let mut v = measured;
        v.sort_by(|a, b| bad(a.1).total_cmp(&bad(b.1)));
        let order: Vec<String> = v.iter().map(|(id, _)| id.to_string()).collect();
        if v.len() < 2 {
            return not_ranked("fewer than two systems measured", order);
        }
        let top = bad(v[0].1);
        let tied: Vec<String> = v.iter().take_while(|(_, x)| bad(x) == top).map(|(id, _)| id.to_string()).collect();
        if tied.len() > 1 {
            return Ranking { metric, order, verdict: Verdict::Tie(tied) };
        }
        // A CI of one observation has no width: it cannot make a win clear.
        let interval = |m: &Metric| match (m.ci_low, m.ci_high) {
            (Some(lo), Some(hi)) if m.n >= 2 => metric.direction.badness_interval(lo, hi),
            _ => None,
        };
        let clear = match (interval(v[0].1), interval(v[1].1)) {
            (Some((_, a_hi)), Some((b_lo, _))) => a_hi < b_lo,
            _ => false,
        };
        Ranking { metric, order, verdict: Verdict::Best { system: v[0].0.to_string(), clear } }
    }

    /// Whether `system` is best or tied best.
    pub fn won_by(&self, system: &str) -> bool {
        match &self.verdict {
            Verdict::Best { system: s, .. } => s == system,
            Verdict::Tie(t) => t.iter().any(|s| s == system),
            Verdict::NotRanked(_) => false,
        }
    }
}

/// A clear overall verdict that the paired table contradicts: on the requests both
/// answered, the runner-up is ahead with a CI that excludes 0.
#[derive(Debug, Clone, PartialEq)]
pub struct Disagreement {
    /// The metric.
    pub metric: String,
    /// The overall winner.
    pub best: String,
    /// The system ahead of it on the common requests.
    pub other: String,
    /// The paired row (`<a> vs <b>`, `paired_<metric>`).
    pub paired: Metric,
}

/// Every headline metric's ranking.
#[derive(Debug, Clone, PartialEq)]
pub struct Conclusions {
    /// In catalogue order.
    pub rankings: Vec<Ranking>,
    /// Systems ranked (ids, report order).
    pub systems: Vec<String>,
}

impl Conclusions {
    /// Ranks `systems` (ids) on every headline metric.
    pub fn new(rows: &[Metric], systems: &[&str]) -> Self {
        Self {
            rankings: metrics::headlines().map(|m| Ranking::new(rows, systems, m)).collect(),
            systems: systems.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// The ranking of metric `id`.
    pub fn ranking(&self, id: &str) -> Option<&Ranking> {
        self.rankings.iter().find(|r| r.metric.id == id)
    }

    /// The headline metrics `system` is best or tied best on.
    pub fn wins(&self, system: &str) -> Vec<&Ranking> {
        self.rankings.iter().filter(|r| r.won_by(system)).collect()
    }

    /// Clear verdicts the paired rows contradict (see [`Disagreement`]). Paired rows are
    /// `<a> vs <b>` / `paired_<metric>`, a's value minus b's; a metric without paired rows
    /// is not checked.
    pub fn disagreements(&self, rows: &[Metric]) -> Vec<Disagreement> {
        let mut out = Vec::new();
        for r in &self.rankings {
            let Verdict::Best { system: best, clear: true } = &r.verdict else { continue };
            let paired = format!("paired_{}", r.metric.id);
            for other in self.systems.iter().filter(|s| *s != best) {
                // The row is (best vs other) or (other vs best); d > 0 means "first is higher".
                let (row, sign) = match find(rows, &format!("{best} vs {other}"), &paired, "all", "all") {
                    Some(x) => (x, 1.0),
                    None => match find(rows, &format!("{other} vs {best}"), &paired, "all", "all") {
                        Some(x) => (x, -1.0),
                        None => continue,
                    },
                };
                let (Some(lo), Some(hi)) = (row.ci_low, row.ci_high) else { continue };
                // best − other, as an interval.
                let (lo, hi) = if sign > 0.0 { (lo, hi) } else { (-hi, -lo) };
                let other_ahead = match r.metric.direction {
                    Direction::Lower => lo > 0.0,
                    Direction::Higher => hi < 0.0,
                    _ => false,
                };
                if other_ahead {
                    out.push(Disagreement {
                        metric: r.metric.id.into(),
                        best: best.clone(),
                        other: other.clone(),
                        paired: row.clone(),
                    });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(system: &str, metric: &str, value: f64, lo: f64, hi: f64) -> Metric {
        Metric {
            system: system.into(),
            metric: metric.into(),
            from: "all".into(),
            to: "all".into(),
            value,
            ci_low: Some(lo),
            ci_high: Some(hi),
            n: 10,
            unit: String::new(),
        }
    }

    fn def(id: &str) -> &'static MetricDef {
        metrics::find(id).unwrap()
    }

    const ALL: [&str; 4] = ["reprise", "motion-graphs", "motion-matching", "crossfade"];

    /// A ratio ranked toward 1 (the per-phase liveliness ratios' direction).
    static TOWARD_ONE: MetricDef = MetricDef {
        id: "liveliness_ratio",
        unit: "",
        direction: Direction::TowardOne,
        per: crate::metrics::Per::Answered,
        headline: false,
        family: false,
        definition: "",
    };

    /// A system whose latency is short by design is ranked like any other: the crossfade's
    /// 0.04 s wins clear of motion matching's 0.06 s.
    #[test]
    fn every_system_is_ranked_on_what_it_measures() {
        let m = vec![
            row("reprise", "perceived_latency_s", 0.5, 0.45, 0.55),
            row("motion-graphs", "perceived_latency_s", 2.0, 1.9, 2.1),
            row("motion-matching", "perceived_latency_s", 0.06, 0.055, 0.065),
            row("crossfade", "perceived_latency_s", 0.04, 0.035, 0.045),
        ];
        let r = Ranking::new(&m, &ALL, def("perceived_latency_s"));
        assert_eq!(r.order, ["crossfade", "motion-matching", "reprise", "motion-graphs"]);
        assert_eq!(r.verdict, Verdict::Best { system: "crossfade".into(), clear: true });
    }

    /// Higher-is-better shares, overlapping CIs, exact ties, and fewer than two measured.
    #[test]
    fn overlap_ties_and_missing_values() {
        let m = vec![row("reprise", "coverage", 0.9, 0.8, 0.95), row("motion-graphs", "coverage", 0.85, 0.75, 0.9)];
        let r = Ranking::new(&m, &ALL, def("coverage"));
        assert_eq!(r.verdict, Verdict::Best { system: "reprise".into(), clear: false });
        let m = vec![row("reprise", "answered", 1.0, 1.0, 1.0), row("crossfade", "answered", 1.0, 1.0, 1.0)];
        assert_eq!(
            Ranking::new(&m, &ALL, def("answered")).verdict,
            Verdict::Tie(vec!["reprise".into(), "crossfade".into()])
        );
        let m = vec![row("reprise", "answered", 1.0, 1.0, 1.0), row("crossfade", "answered", f64::NAN, 0.0, 0.0)];
        assert!(matches!(Ranking::new(&m, &ALL, def("answered")).verdict, Verdict::NotRanked(_)));
        // One observation's zero-width CI does not make a clear win.
        let mut lone = row("reprise", "discontinuity_accel", 0.2, 0.2, 0.2);
        lone.n = 1;
        let m = vec![lone, row("motion-graphs", "discontinuity_accel", 0.5, 0.45, 0.55)];
        let r = Ranking::new(&m, &ALL, def("discontinuity_accel"));
        assert_eq!(r.verdict, Verdict::Best { system: "reprise".into(), clear: false });
        let m = vec![row("reprise", "variety", 1.0, 0.9, 1.1), row("motion-graphs", "variety", 2.0, 1.9, 2.1)];
        assert!(matches!(Ranking::new(&m, &ALL, def("variety")).verdict, Verdict::NotRanked(_)));
    }

    /// Liveliness ranks by the distance of the ratio from 1, either side.
    #[test]
    fn liveliness_ratio_ranks_toward_one() {
        let m = vec![
            row("reprise", "liveliness_ratio", 0.2, 0.15, 0.25),
            row("motion-graphs", "liveliness_ratio", 1.1, 1.0, 1.2),
            row("crossfade", "liveliness_ratio", 3.0, 2.5, 3.5),
        ];
        let r = Ranking::new(&m, &ALL, &TOWARD_ONE);
        assert_eq!(r.order, ["motion-graphs", "crossfade", "reprise"]);
        assert_eq!(r.verdict, Verdict::Best { system: "motion-graphs".into(), clear: true });
    }

    /// A clear overall win the paired table contradicts is reported; one it agrees with is not.
    #[test]
    fn disagreements_with_the_paired_table_are_found() {
        let mut m = vec![
            row("reprise", "perceived_latency_s", 0.3, 0.25, 0.35),
            row("motion-graphs", "perceived_latency_s", 1.0, 0.9, 1.1),
            // On the requests both answered, reprise is 0.2 s slower.
            row("reprise vs motion-graphs", "paired_perceived_latency_s", 0.2, 0.1, 0.3),
        ];
        let c = Conclusions::new(&m, &["reprise", "motion-graphs"]);
        assert!(c.ranking("perceived_latency_s").unwrap().won_by("reprise"));
        let d = c.disagreements(&m);
        assert_eq!((d.len(), d[0].other.as_str()), (1, "motion-graphs"));
        m[2] = row("reprise vs motion-graphs", "paired_perceived_latency_s", -0.6, -0.7, -0.5);
        assert!(Conclusions::new(&m, &["reprise", "motion-graphs"]).disagreements(&m).is_empty());
        // The pair written the other way round is read with its sign flipped.
        m[2] = row("motion-graphs vs reprise", "paired_perceived_latency_s", -0.2, -0.3, -0.1);
        assert_eq!(Conclusions::new(&m, &["reprise", "motion-graphs"]).disagreements(&m).len(), 1);
    }
}
