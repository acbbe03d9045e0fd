//! Every metric the transition benchmark reports, declared once: id, unit, which way is
//! better, what it is averaged over, and what it measures. The report's tables, its
//! conclusions and its definitions are all read from [`CATALOGUE`].
//!
//! Vocabulary of the definitions. A request asks a system, playing a frame of label A, to
//! reach label B. An answer's frames after the request split into **reach** (before the
//! system's first frame labelled B), **blend** (its first `k` frames labelled B) and
//! **settle** (the rest). The **label switch** is the first frame the system labels B;
//! **arrival** is what a viewer sees: the first frame of the first run of `h` frames in a
//! row whose nearest training pose on the mesh (a training frame or its projection through
//! its own label's PCA) belongs to B.

/// Which way a metric is better.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Lower is better.
    Lower,
    /// Higher is better.
    Higher,
    /// Closer to 1 is better (a ratio to the training data): ranked by $\lvert\ln v\rvert$.
    TowardOne,
    /// Not ranked, and why.
    NotRanked(&'static str),
}

/// What a metric's value is a mean over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Per {
    /// Every request: each counts 1 if it meets the condition, else 0 (a share).
    Request,
    /// Every answered request, one value each (request-weighted; CIs resample requests).
    Answered,
    /// Every request that arrived, one value each.
    Arrived,
    /// A count or a figure of an earlier stage, per label or label pair (no CI).
    Count,
}

/// One metric of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricDef {
    /// Id in `metrics.metric`; for a family (`family`), the prefix of its members' ids.
    pub id: &'static str,
    /// Unit of the value.
    pub unit: &'static str,
    /// Which way is better.
    pub direction: Direction,
    /// What the value is a mean over.
    pub per: Per,
    /// Whether it is one of the headline metrics every system is ranked on (the overall
    /// table and the conclusions, in catalogue order).
    pub headline: bool,
    /// Whether `id` is a prefix naming a family (per phase, per space, …).
    pub family: bool,
    /// What it measures, one sentence (the report adds the reference values).
    pub definition: &'static str,
}

/// A metric of its own (not a family), not a headline.
const fn row(
    id: &'static str,
    unit: &'static str,
    direction: Direction,
    per: Per,
    definition: &'static str,
) -> MetricDef {
    MetricDef { id, unit, direction, per, headline: false, family: false, definition }
}

/// A headline metric: [`row`], ranked in the overall table and the conclusions.
const fn headline(
    id: &'static str,
    unit: &'static str,
    direction: Direction,
    per: Per,
    definition: &'static str,
) -> MetricDef {
    MetricDef { headline: true, ..row(id, unit, direction, per, definition) }
}

/// A family of metrics named `<id>…`, one value per answered request.
const fn family(id: &'static str, unit: &'static str, direction: Direction, definition: &'static str) -> MetricDef {
    MetricDef { id, unit, direction, per: Per::Answered, headline: false, family: true, definition }
}

/// Unit of distances in scaled control space.
pub const FRAME_STEPS: &str = "× median frame step";
/// Unit of RMS vertex distances.
pub const MESH_STEPS: &str = "× median mesh motion per frame";

/// Every metric, headline metrics in the order the report ranks them.
pub const CATALOGUE: &[MetricDef] = &[
    headline(
        "answered",
        "share",
        Direction::Higher,
        Per::Request,
        "share of requests the system answered: it switched its own label to B (a refusal records why)",
    ),
    headline(
        "arrived",
        "share",
        Direction::Higher,
        Per::Request,
        "share of requests whose answer arrives in B as a viewer sees it (the pose held B-like for h frames) \
         before the answer ends",
    ),
    headline(
        "coverage",
        "share",
        Direction::Higher,
        Per::Request,
        "share of requests that arrive within the coverage horizon T of the request",
    ),
    headline(
        "perceived_latency_s",
        "s",
        Direction::Lower,
        Per::Request,
        "restricted mean time to arrival: per request, the seconds from the request to arrival (the first frame of \
         the B-like run), counted as the latency horizon τ when it comes later, never comes, or the request is not \
         answered — every request, the same τ for every system, so no system is averaged over its own subset",
    ),
    headline(
        "success",
        "share",
        Direction::Higher,
        Per::Request,
        "share of requests answered with no pose jump: no frame after the request whose peak vertex speed exceeds \
         the jump ratio × the training data's 99th percentile",
    ),
    headline(
        "discontinuity_accel",
        "× training p95",
        Direction::Lower,
        Per::Answered,
        "the largest per-frame peak vertex acceleration in a window of the same W frames for every system, centred \
         on the label switch, divided by the training data's 95th percentile",
    ),
    headline(
        "discontinuity_jerk",
        "× training p95",
        Direction::Lower,
        Per::Answered,
        "as discontinuity_accel, for the peak vertex jerk",
    ),
    headline(
        "liveliness_error",
        "abs. ln ratio",
        Direction::Lower,
        Per::Answered,
        "per request, the absolute natural log of its liveliness ratio r (r floored at 0.01): 0 when the answer moves as much as B's \
         training frames, the same for twice as fast as for half as fast, and a frozen answer and a jittering one \
         cannot average out",
    ),
    headline(
        "liveliness_ks",
        "KS distance",
        Direction::Lower,
        Per::Answered,
        "Kolmogorov–Smirnov distance between the per-frame RMS vertex speeds after the request and those of B's \
         training frames (0: the same distribution; 1: disjoint)",
    ),
    headline(
        "plausibility_floor_mesh",
        MESH_STEPS,
        Direction::Lower,
        Per::Answered,
        "per answered request, the mean over its frames after the request of the RMS vertex distance to the nearer of \
         a training frame and its projection through its own label's PCA (so neither representation is charged for \
         its own floor)",
    ),
    headline(
        "plausibility_floor_scaled",
        FRAME_STEPS,
        Direction::Lower,
        Per::Answered,
        "as plausibility_floor_mesh, in scaled control space",
    ),
    headline(
        "variety",
        "mesh units",
        Direction::NotRanked("it rewards noise as much as real alternatives; read it beside plausibility"),
        Per::Answered,
        "per request, the mean over frames of the RMS vertex distance between the answer and the answer under \
         another seed (0 for a system without a seed)",
    ),
    row(
        "liveliness_ratio",
        "× B's training mean",
        Direction::NotRanked("its mean lets frozen and jittering answers cancel; liveliness_error ranks them"),
        Per::Answered,
        "mean per-frame RMS vertex speed after the request, divided by the mean over B's training frames (1: as \
         lively as B; a frozen character scores near 0, a jittering one above 1)",
    ),
    row(
        "perceived_latency_arrived_s",
        "s",
        Direction::NotRanked("a subset of the requests that differs by system; perceived_latency_s ranks them all"),
        Per::Arrived,
        "seconds from the request to arrival, over the requests that arrived (not censored)",
    ),
    row(
        "switch_latency_s",
        "s",
        Direction::NotRanked(
            "the system's own label, shown beside the perceived latency, which is ranked: a blended frame is labelled \
             B while it still looks like A",
        ),
        Per::Answered,
        "seconds from the request to the system's label switch",
    ),
    row(
        "latency_direct_s",
        "s",
        Direction::NotRanked("a subset of the requests that differs by system; perceived_latency_s ranks them all"),
        Per::Arrived,
        "perceived latency of the answers that pass through no third label",
    ),
    row(
        "latency_routed_s",
        "s",
        Direction::NotRanked("a subset of the requests that differs by system; perceived_latency_s ranks them all"),
        Per::Arrived,
        "perceived latency of the answers routed through a third label",
    ),
    row(
        "latency_bridge_start_s",
        "s",
        Direction::NotRanked("a subset of the requests; perceived_latency_s ranks them all"),
        Per::Arrived,
        "perceived latency of the requests whose start frame is a bridge point of their pair (see start_on_bridge)",
    ),
    row(
        "latency_other_start_s",
        "s",
        Direction::NotRanked("a subset of the requests; perceived_latency_s ranks them all"),
        Per::Arrived,
        "perceived latency of the requests whose start frame is not a bridge point of their pair",
    ),
    row(
        "routed",
        "share",
        Direction::NotRanked("how a system gets there, not how well"),
        Per::Answered,
        "share of answered requests whose frames before the label switch play a third label",
    ),
    row(
        "start_on_bridge",
        "share",
        Direction::NotRanked("a property of the requests, the same for every system"),
        Per::Request,
        "share of requests whose start frame is itself the start of a bridge from A to B (reprise can answer those \
         with no travel)",
    ),
    row(
        "transition_points",
        "count",
        Direction::NotRanked("a count of a system's table, not a measurement of its answers"),
        Per::Count,
        "bridges A → B (reprise); transition edges from A to B in the pruned graph (Motion Graphs)",
    ),
    family(
        "plausibility_",
        FRAME_STEPS,
        Direction::Lower,
        "plausibility_<reference>_<space>[_<phase>]: reference raw (the training frames) or floor (the nearer of a \
         training frame and its PCA projection), space scaled or mesh, one phase or the whole answer after the request",
    ),
    family(
        "liveliness_",
        "× B's training mean",
        Direction::TowardOne,
        "liveliness_ratio_<phase> and liveliness_ks_<phase>: the liveliness measures over one phase",
    ),
    family(
        "paired_",
        "difference",
        Direction::NotRanked("a difference between two systems"),
        "paired_<metric>: on the requests both systems answered (arrived, for perceived latency), the first system's \
         value minus the other's",
    ),
    MetricDef {
        id: "heldout_",
        unit: "mesh units",
        direction: Direction::Lower,
        per: Per::Count,
        headline: false,
        family: true,
        definition: "per label, RMS vertex error of every K-th frame, left out of the PCA basis and of the fit: the \
                     GPLVM (through the held-out frame's best latent point), PCA with q and with d components (systems \
                     gplvm, pca-q, pca-d)",
    },
    row(
        "generative_mesh_rmse",
        "mesh units",
        Direction::Lower,
        Per::Count,
        "per label, RMS vertex error of held-out frames whose neighbours were fitted: the GPLVM at the midpoint of the \
         neighbours' latents (gplvm) against the midpoint of their poses (interpolation) and of their coordinates in \
         the PCA-d basis the GPLVM models (interpolation-d: the same floor as the GPLVM's)",
    ),
    MetricDef {
        id: "ablation_mesh_rmse",
        unit: "mesh units",
        direction: Direction::Lower,
        per: Per::Count,
        headline: false,
        family: false,
        definition: "RMS vertex error of 3-component PCA, scaled against unscaled controls",
    },
];

/// The definition of metric `id`: its own row, else the family whose prefix it has.
pub fn find(id: &str) -> Option<&'static MetricDef> {
    CATALOGUE
        .iter()
        .find(|m| !m.family && m.id == id)
        .or_else(|| CATALOGUE.iter().find(|m| m.family && id.starts_with(m.id)))
}

/// The headline metrics, in ranking order.
pub fn headlines() -> impl Iterator<Item = &'static MetricDef> {
    CATALOGUE.iter().filter(|m| m.headline)
}

/// Direction of metric `id` (`NotRanked` for one the catalogue does not know).
pub fn direction(id: &str) -> Direction {
    find(id).map_or(Direction::NotRanked("not in the catalogue"), |m| m.direction)
}

/// The liveliness family's members are ratios (toward 1) or distances (lower); the family
/// row states the ratio's direction.
pub fn direction_of(id: &str) -> Direction {
    if id.starts_with("liveliness_ks") {
        Direction::Lower
    } else {
        direction(id)
    }
}

/// The catalogue as a Markdown table (id, unit, over what, better, definition): the
/// metrics reference in `docs/metrics.md` and the report's definitions are this text.
pub fn reference_table() -> String {
    let mut s = String::from("| metric | unit | mean over | better | definition |\n|---|---|---|---|---|\n");
    for d in CATALOGUE {
        let name = if d.family { format!("`{}…`", d.id) } else { format!("`{}`", d.id) };
        let per = match d.per {
            Per::Request => "every request",
            Per::Answered => "answered requests",
            Per::Arrived => "requests that arrived",
            Per::Count => "label or label pair",
        };
        let better = match d.direction {
            Direction::NotRanked(why) => format!("not ranked: {why}"),
            other => other.phrase().to_string(),
        };
        let headline = if d.headline { " **(headline)**" } else { "" };
        s += &format!("| {name}{headline} | {} | {per} | {better} | {} |\n", d.unit, d.definition);
    }
    s
}

impl Direction {
    /// How far `v` is from the best value, for ordering: lower is better (`None`: not ranked).
    pub fn badness(self, v: f64) -> Option<f64> {
        match self {
            Direction::Lower => Some(v),
            Direction::Higher => Some(-v),
            Direction::TowardOne => Some(if v > 0.0 { v.ln().abs() } else { f64::INFINITY }),
            Direction::NotRanked(_) => None,
        }
    }

    /// The interval of badness a CI `[lo, hi]` maps to.
    pub fn badness_interval(self, lo: f64, hi: f64) -> Option<(f64, f64)> {
        let (a, b) = (self.badness(lo)?, self.badness(hi)?);
        Some(match self {
            Direction::TowardOne if lo <= 1.0 && 1.0 <= hi => (0.0, a.max(b)),
            _ => (a.min(b), a.max(b)),
        })
    }

    /// "lower is better" and the like.
    pub fn phrase(self) -> &'static str {
        match self {
            Direction::Lower => "lower is better",
            Direction::Higher => "higher is better",
            Direction::TowardOne => "closer to 1 is better",
            Direction::NotRanked(_) => "not ranked",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_unique_and_families_resolve() {
        for (i, a) in CATALOGUE.iter().enumerate() {
            assert!(CATALOGUE[i + 1..].iter().all(|b| b.id != a.id), "{} twice", a.id);
            // A pipe would split a cell of the reference table.
            assert!(![a.id, a.unit, a.definition].iter().any(|t| t.contains('|')), "{}: a `|`", a.id);
        }
        assert_eq!(find("perceived_latency_s").unwrap().per, Per::Request);
        assert_eq!(find("perceived_latency_arrived_s").unwrap().per, Per::Arrived);
        assert_eq!(find("plausibility_raw_mesh_settle").unwrap().id, "plausibility_");
        // A headline member of a family is found as itself, not as the family.
        assert!(find("plausibility_floor_mesh").unwrap().headline);
        assert_eq!(direction_of("liveliness_ks_settle"), Direction::Lower);
        assert_eq!(direction_of("liveliness_ratio_settle"), Direction::TowardOne);
        assert!(matches!(direction("no_such_metric"), Direction::NotRanked(_)));
    }

    /// The headline metrics the issue asks every system be ranked on are ranked.
    #[test]
    fn every_headline_but_variety_is_ranked() {
        let unranked: Vec<&str> =
            headlines().filter(|m| matches!(m.direction, Direction::NotRanked(_))).map(|m| m.id).collect();
        assert_eq!(unranked, ["variety"]);
        for id in
            ["perceived_latency_s", "answered", "coverage", "discontinuity_accel", "liveliness_ks", "liveliness_error"]
        {
            assert!(find(id).unwrap().headline, "{id}");
        }
    }

    /// `docs/metrics.md` holds the catalogue as [`reference_table`] renders it; set
    /// `REPRISE_BLESS=1` to rewrite it after changing the catalogue.
    #[test]
    fn the_metrics_reference_is_the_catalogue() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/metrics.md");
        let doc = std::fs::read_to_string(&path).unwrap_or_default();
        let (start, end) = ("<!-- catalogue: generated -->\n", "<!-- end of catalogue -->");
        let table = reference_table();
        let fresh = match (doc.find(start), doc.find(end)) {
            (Some(a), Some(b)) if a < b => format!("{}{start}{table}{}", &doc[..a], &doc[b..]),
            _ => doc.clone(),
        };
        if std::env::var_os("REPRISE_BLESS").is_some() {
            std::fs::write(&path, &fresh).unwrap();
        } else {
            assert!(
                doc.contains(&table),
                "{} is stale: run REPRISE_BLESS=1 cargo test -p reprise-benchmark",
                path.display()
            );
        }
    }

    /// Toward one: 0.5 and 2 are equally far; a CI spanning 1 reaches 0.
    #[test]
    fn toward_one_ranks_by_log_distance() {
        let d = Direction::TowardOne;
        assert!((d.badness(0.5).unwrap() - d.badness(2.0).unwrap()).abs() < 1e-12);
        assert!(d.badness(0.9).unwrap() < d.badness(1.3).unwrap());
        assert_eq!(d.badness_interval(0.8, 1.1).unwrap().0, 0.0);
        assert_eq!(Direction::Higher.badness_interval(0.2, 0.6), Some((-0.6, -0.2)));
        assert_eq!(d.badness(0.0), Some(f64::INFINITY));
    }
}
