//! Aggregating measurements into metric rows: means with bootstrap CIs per label pair and
//! overall, shares (answered, success, coverage) from every request, and paired
//! differences between systems on the requests both answered.

use reprise_artifact::transitions::Request;
use reprise_motion_metrics::bootstrap_mean_ci;

use crate::measure::{Measured, Phase, PlausibilityReference as Reference, Space};
use crate::systems::System;

/// One metric row.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    /// A system id (`reprise`, `baseline`, …), a pair `<a> vs <b>` for paired
    /// differences, or a model variant (`gplvm`, `pca`, `scaled`, `unscaled`).
    pub system: String,
    /// Metric name.
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
    /// Observations.
    pub n: i64,
    /// Unit.
    pub unit: String,
}

/// Bootstrap resamples of every CI.
pub const RESAMPLES: usize = 1000;

/// The mean of `values` with its 95 % percentile-bootstrap CI (seeded).
pub fn metric(system: &str, name: &str, from: &str, to: &str, values: &[f64], unit: &str, seed: u64) -> Metric {
    let (m, lo, hi) = bootstrap_mean_ci(values, RESAMPLES, seed);
    Metric {
        system: system.into(),
        metric: name.into(),
        from: from.into(),
        to: to.into(),
        value: m,
        ci_low: Some(lo).filter(|v| v.is_finite()),
        ci_high: Some(hi).filter(|v| v.is_finite()),
        n: values.len() as i64,
        unit: unit.into(),
    }
}

/// A value without a CI (a count, or a figure of an earlier stage).
pub fn exact(system: &str, name: &str, from: &str, to: &str, value: f64, n: usize, unit: &str) -> Metric {
    Metric {
        system: system.into(),
        metric: name.into(),
        from: from.into(),
        to: to.into(),
        value,
        ci_low: None,
        ci_high: None,
        n: n as i64,
        unit: unit.into(),
    }
}

/// The groups every metric is reported over: all pairs, then each ordered pair.
pub fn groups(pairs: &[(String, String)]) -> Vec<(String, String)> {
    let mut g = vec![("all".to_string(), "all".to_string())];
    g.extend(pairs.iter().cloned());
    g
}

fn in_group(from: &str, to: &str, (gf, gt): &(String, String)) -> bool {
    (gf == "all" || gf == from) && (gt == "all" || gt == to)
}

/// Unit of the plausibility metrics in `space`.
pub fn plausibility_unit(space: Space) -> &'static str {
    match space {
        Space::Scaled => "× median frame step",
        Space::Mesh => "× median mesh motion per frame",
    }
}

/// A measure of one answered request with its name and unit, aggregated as a mean.
type PerRequest = (String, Box<dyn Fn(&Measured) -> Vec<f64> + Sync>, &'static str);

/// The per-request measures aggregated for every system.
fn per_request() -> Vec<PerRequest> {
    let mut m: Vec<PerRequest> = vec![
        ("latency_s".into(), Box::new(|p: &Measured| vec![p.latency]), "s"),
        ("peak_accel_ratio".into(), Box::new(|p: &Measured| vec![p.accel]), "× training p95"),
        ("peak_jerk_ratio".into(), Box::new(|p: &Measured| vec![p.jerk]), "× training p95"),
    ];
    for r in Reference::ALL {
        for s in Space::ALL {
            let phases = std::iter::once(None).chain(Phase::ALL.into_iter().map(Some));
            for phase in phases {
                let name = crate::measure::plausibility::metric_name(r, s, phase);
                m.push((name, Box::new(move |p: &Measured| p.plausibility.values(r, s, phase)), plausibility_unit(s)));
            }
        }
    }
    m
}

/// One system's rows: the per-request measures of its answered requests, and from every
/// request `answered`, `success` (answered with no pose jump above `jump_ratio` × the
/// training p99 of peak vertex speed) and simulated `coverage` (answered, reaching B within
/// `horizon` frames).
pub fn system_rows(
    system: &System,
    measured: &[Measured],
    reqs: &[Request],
    pairs: &[(String, String)],
    jump_ratio: f64,
    horizon: i64,
) -> Vec<Metric> {
    let mut out = Vec::new();
    let measures = per_request();
    let jumps: std::collections::HashMap<i64, f64> = measured.iter().map(|p| (p.request, p.jump)).collect();
    let share = |f: &dyn Fn(&Request) -> bool, g: &(String, String)| -> Vec<f64> {
        reqs.iter().filter(|r| in_group(&r.from, &r.to, g)).map(|r| f64::from(u8::from(f(r)))).collect()
    };
    for (gi, g) in groups(pairs).iter().enumerate() {
        let seed = gi as u64;
        let here: Vec<&Measured> = measured.iter().filter(|p| in_group(&p.from, &p.to, g)).collect();
        for (name, f, unit) in &measures {
            let v: Vec<f64> = here.iter().flat_map(|p| f(p)).collect();
            out.push(metric(&system.id, name, &g.0, &g.1, &v, unit, seed));
        }
        out.push(metric(&system.id, "answered", &g.0, &g.1, &share(&|r| system.answered(r), g), "share", seed));
        let success = |r: &Request| jumps.get(&r.request).is_some_and(|&j| j <= jump_ratio);
        out.push(metric(&system.id, "success", &g.0, &g.1, &share(&success, g), "share", seed));
        let reached = |r: &Request| system.answer(r).and_then(|a| a.latency).is_some_and(|l| l <= horizon);
        out.push(metric(&system.id, "coverage", &g.0, &g.1, &share(&reached, g), "share", 11));
    }
    out
}

/// The measures compared pairwise, with their units.
pub const PAIRED: [(&str, &str); 5] = [
    ("latency_s", "s"),
    ("peak_accel_ratio", "× training p95"),
    ("peak_jerk_ratio", "× training p95"),
    ("plausibility_raw_scaled", "× median frame step"),
    ("plausibility_floor_scaled", "× median frame step"),
];

fn paired_value(m: &Measured, name: &str) -> f64 {
    match name {
        "latency_s" => m.latency,
        "peak_accel_ratio" => m.accel,
        "peak_jerk_ratio" => m.jerk,
        "plausibility_raw_scaled" => m.plausibility.mean(Reference::Raw, Space::Scaled),
        _ => m.plausibility.mean(Reference::Floor, Space::Scaled),
    }
}

/// Paired comparisons of system `a` with `b` on the requests both answered: per request,
/// a's value minus b's for each of [`PAIRED`]; the mean difference with its bootstrap CI,
/// per ordered pair and overall, as system `<a> vs <b>` and metric `paired_<measure>`
/// (below 0, `a` is lower).
pub fn paired(a: (&str, &[Measured]), b: (&str, &[Measured]), pairs: &[(String, String)]) -> Vec<Metric> {
    let by_id: std::collections::HashMap<i64, &Measured> = b.1.iter().map(|m| (m.request, m)).collect();
    let both: Vec<(&Measured, &Measured)> = a.1.iter().filter_map(|x| by_id.get(&x.request).map(|y| (x, *y))).collect();
    let system = format!("{} vs {}", a.0, b.0);
    let mut out = Vec::new();
    for (gi, g) in groups(pairs).iter().enumerate() {
        let here: Vec<&(&Measured, &Measured)> = both.iter().filter(|(x, _)| in_group(&x.from, &x.to, g)).collect();
        for (name, unit) in PAIRED {
            let d: Vec<f64> = here
                .iter()
                .map(|(x, y)| paired_value(x, name) - paired_value(y, name))
                .filter(|d| d.is_finite())
                .collect();
            out.push(metric(&system, &format!("paired_{name}"), &g.0, &g.1, &d, unit, 100 + gi as u64));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_artifact::transitions::{Answer, Answers};

    fn request(id: i64, from: &str, to: &str) -> Request {
        Request { request: id, from: from.into(), to: to.into(), segment_id: 0, clip: "c".into(), frame: 0 }
    }

    fn system(id: &str, latencies: &[(i64, Option<i64>)]) -> System {
        let by_request = latencies
            .iter()
            .map(|&(r, l)| (r, l.map_or_else(|| Answer::failed("no"), |l| Answer::reached(0, l))))
            .collect();
        System {
            id: id.into(),
            shown: id.into(),
            answers: Answers { system: id.into(), by_request },
            played: Default::default(),
            reseeded_curves: None,
        }
    }

    pub(crate) fn value(m: &[Metric], system: &str, name: &str, from: &str, to: &str) -> f64 {
        m.iter()
            .find(|x| x.system == system && x.metric == name && x.from == from && x.to == to)
            .unwrap_or_else(|| panic!("no {system} {name} {from}→{to}"))
            .value
    }

    /// Coverage is the share of a pair's requests answered within the horizon: a → b, the
    /// first system reaches 3 of 4 in time (one too late, at 30 > 24 frames), the second 2
    /// (two unanswered); b → a the second wins, 2 of 2 against 0 (one too late, one
    /// unanswered). Answered counts every answer, in time or not.
    #[test]
    fn coverage_counts_the_requests_reached_in_time() {
        let reqs: Vec<Request> =
            [(0, "a", "b"), (1, "a", "b"), (2, "a", "b"), (3, "a", "b"), (4, "b", "a"), (5, "b", "a")]
                .iter()
                .map(|&(i, f, t)| request(i, f, t))
                .collect();
        let ours = system("x", &[(0, Some(10)), (1, Some(24)), (2, Some(30)), (3, Some(1)), (4, Some(25)), (5, None)]);
        let theirs = system("y", &[(0, Some(5)), (1, None), (2, Some(20)), (3, None), (4, Some(3)), (5, Some(24))]);
        let pairs = vec![("a".to_string(), "b".to_string()), ("b".to_string(), "a".to_string())];
        let m: Vec<Metric> =
            [&ours, &theirs].iter().flat_map(|s| system_rows(s, &[], &reqs, &pairs, 2.0, 24)).collect();
        assert_eq!(value(&m, "x", "coverage", "a", "b"), 0.75);
        assert_eq!(value(&m, "y", "coverage", "a", "b"), 0.5);
        assert_eq!(value(&m, "x", "coverage", "b", "a"), 0.0);
        assert_eq!(value(&m, "y", "coverage", "b", "a"), 1.0);
        assert!((value(&m, "x", "coverage", "all", "all") - 0.5).abs() < 1e-12);
        assert!((value(&m, "y", "coverage", "all", "all") - 4.0 / 6.0).abs() < 1e-12);
        assert!((value(&m, "x", "answered", "all", "all") - 5.0 / 6.0).abs() < 1e-12);
        // No measured answers: nothing succeeds (success needs a measured, jump-free answer).
        assert_eq!(value(&m, "x", "success", "all", "all"), 0.0);
    }

    fn measured(request: i64, latency: f64, accel: f64) -> Measured {
        Measured {
            request,
            from: "a".into(),
            to: "b".into(),
            jump: 0.0,
            accel,
            jerk: accel,
            latency,
            plausibility: Default::default(),
            speed: vec![],
        }
    }

    /// Paired differences use only the requests both answered, a minus b: here a is 0.5 s
    /// slower on each (it loses) and 1 lower in acceleration (it wins).
    #[test]
    fn paired_differences_on_common_requests() {
        let ours = vec![measured(0, 1.0, 1.0), measured(1, 2.0, 2.0), measured(2, 9.0, 9.0)];
        let theirs = vec![measured(0, 0.5, 2.0), measured(1, 1.5, 3.0), measured(3, 0.0, 0.0)];
        let m = paired(("x", &ours), ("y", &theirs), &[("a".into(), "b".into())]);
        let lat = m.iter().find(|x| x.metric == "paired_latency_s" && x.from == "all").unwrap();
        assert_eq!((lat.system.as_str(), lat.value, lat.n), ("x vs y", 0.5, 2));
        assert!(lat.ci_low.unwrap() > 0.0, "x is slower on every common request");
        assert_eq!(value(&m, "x vs y", "paired_peak_accel_ratio", "a", "b"), -1.0);
        // Without plausibility frames the paired plausibility has no observations.
        assert_eq!(m.iter().find(|x| x.metric == "paired_plausibility_floor_scaled").unwrap().n, 0);
    }
}
