//! Aggregating measurements into metric rows, by request: every per-request measure is one
//! value per request (a request's frames are averaged first), means are request-weighted
//! and CIs resample requests; shares (answered, arrived, coverage, success) count every
//! request; paired differences compare two systems on the requests both answered.

use std::collections::HashSet;

use reprise_artifact::transitions::Request;
use reprise_benchmark::metrics::{self, FRAME_STEPS, MESH_STEPS};
use reprise_motion_metrics::bootstrap_mean_ci;

use crate::measure::{Measured, Phase, PlausibilityReference as Reference, Space};
use crate::systems::System;

pub use reprise_benchmark::Metric;

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
        Space::Scaled => FRAME_STEPS,
        Space::Mesh => MESH_STEPS,
    }
}

/// The liveliness metric of `measure` (`ratio` or `ks`) over `phase` (`None`: every frame
/// after the request).
pub fn liveliness_name(measure: &str, phase: Option<Phase>) -> String {
    match phase {
        None => format!("liveliness_{measure}"),
        Some(p) => format!("liveliness_{measure}_{}", p.name()),
    }
}

/// The liveliness ratio below which `liveliness_error` counts an answer as this still (so a
/// frozen answer scores $\lvert\ln 0.01\rvert \approx 4.6$, not infinity).
pub const LIVELINESS_FLOOR: f64 = 0.01;

/// Request `p`'s perceived latency censored at `horizon` (s): the restricted time to
/// arrival, `horizon` for an answer that arrives later or never (and, in
/// [`system_rows`], for an unanswered request).
pub fn censored_latency(p: Option<&Measured>, horizon: f64) -> f64 {
    p.and_then(|p| p.perceived_latency).map_or(horizon, |l| l.min(horizon))
}

/// Every per-request measure, by metric id, with its unit.
pub fn per_request() -> Vec<(String, &'static str)> {
    let unit = |id: &str| metrics::find(id).map_or("", |m| m.unit);
    let mut v: Vec<(String, &'static str)> = [
        "perceived_latency_arrived_s",
        "switch_latency_s",
        "latency_direct_s",
        "latency_routed_s",
        "routed",
        "discontinuity_accel",
        "discontinuity_jerk",
        "liveliness_error",
    ]
    .into_iter()
    .map(|id| (id.to_string(), unit(id)))
    .collect();
    for m in ["ratio", "ks"] {
        for phase in std::iter::once(None).chain(Phase::AFTER.into_iter().map(Some)) {
            let id = liveliness_name(m, phase);
            let u = if m == "ks" { unit("liveliness_ks") } else { unit("liveliness_ratio") };
            v.push((id, u));
        }
    }
    for r in Reference::ALL {
        for s in Space::ALL {
            for phase in std::iter::once(None).chain(Phase::AFTER.into_iter().map(Some)) {
                v.push((crate::measure::plausibility::metric_name(r, s, phase), plausibility_unit(s)));
            }
        }
    }
    v
}

/// One answered request's value of per-request measure `id` (`None`: the measure does not
/// apply to it — a latency of an answer that never arrived, a phase it does not have).
pub fn value(p: &Measured, id: &str) -> Option<f64> {
    let finite = |v: f64| Some(v).filter(|v| v.is_finite());
    let phase_of = |rest: &str| -> Option<Option<Phase>> {
        if rest.is_empty() {
            return Some(None);
        }
        Phase::AFTER.into_iter().find(|p| rest == format!("_{}", p.name())).map(Some)
    };
    match id {
        "perceived_latency_arrived_s" => p.perceived_latency,
        "liveliness_error" => finite(p.liveliness.all.0).map(|r| r.max(LIVELINESS_FLOOR).ln().abs()),
        "switch_latency_s" => Some(p.switch_latency),
        "latency_direct_s" => p.perceived_latency.filter(|_| !p.routed),
        "latency_routed_s" => p.perceived_latency.filter(|_| p.routed),
        "routed" => Some(f64::from(u8::from(p.routed))),
        "discontinuity_accel" => finite(p.discontinuity.accel),
        "discontinuity_jerk" => finite(p.discontinuity.jerk),
        _ => {
            for (m, pick) in [("ratio", 0usize), ("ks", 1)] {
                if let Some(rest) = id.strip_prefix(&format!("liveliness_{m}")) {
                    let pair = match phase_of(rest)? {
                        None => p.liveliness.all,
                        Some(ph) => p.liveliness.phases[Phase::AFTER.iter().position(|q| *q == ph)?],
                    };
                    return finite(if pick == 0 { pair.0 } else { pair.1 });
                }
            }
            for r in Reference::ALL {
                for s in Space::ALL {
                    if let Some(rest) = id.strip_prefix(&crate::measure::plausibility::metric_name(r, s, None)) {
                        if let Some(phase) = phase_of(rest) {
                            return finite(p.plausibility.phase_mean(r, s, phase));
                        }
                    }
                }
            }
            None
        }
    }
}

/// Whether a request meets a share's condition.
type Condition<'a> = dyn Fn(&Request) -> bool + 'a;

/// What `system_rows` needs besides the system and its measurements.
#[derive(Debug, Clone, Copy)]
pub struct Rules<'a> {
    /// The requests (every system is asked all of them).
    pub requests: &'a [Request],
    /// The ordered label pairs.
    pub pairs: &'a [(String, String)],
    /// Success: no peak vertex speed above this × the training p99.
    pub jump_ratio: f64,
    /// Coverage horizon (s).
    pub horizon: f64,
    /// Latency horizon τ (s): the censoring time of `perceived_latency_s`.
    pub latency_horizon: f64,
    /// The requests whose start frame is a bridge point of their pair.
    pub on_bridge: &'a HashSet<i64>,
}

/// One system's rows: each per-request measure over its answered requests (one value per
/// request), and over every request the shares `answered` (the system's own label
/// switch), `arrived` (a viewer sees B), `coverage` (arrived within the horizon) and
/// `success` (answered with no pose jump); and perceived latency split by whether the
/// request starts on a bridge point.
pub fn system_rows(system: &System, measured: &[Measured], rules: Rules<'_>) -> Vec<Metric> {
    let mut out = Vec::new();
    let measures = per_request();
    let by_id: std::collections::HashMap<i64, &Measured> = measured.iter().map(|p| (p.request, p)).collect();
    let share = |f: &dyn Fn(&Request) -> bool, g: &(String, String)| -> Vec<f64> {
        rules.requests.iter().filter(|r| in_group(&r.from, &r.to, g)).map(|r| f64::from(u8::from(f(r)))).collect()
    };
    let arrived_in = |r: &Request| by_id.get(&r.request).and_then(|p| p.perceived_latency);
    for (gi, g) in groups(rules.pairs).iter().enumerate() {
        let seed = gi as u64;
        let here: Vec<&Measured> = measured.iter().filter(|p| in_group(&p.from, &p.to, g)).collect();
        for (name, unit) in &measures {
            let v: Vec<f64> = here.iter().filter_map(|p| value(p, name)).collect();
            out.push(metric(&system.id, name, &g.0, &g.1, &v, unit, seed));
        }
        let shares: [(&str, &Condition<'_>); 4] = [
            ("answered", &|r| system.answered(r)),
            ("arrived", &|r| arrived_in(r).is_some()),
            ("coverage", &|r| arrived_in(r).is_some_and(|l| l <= rules.horizon + 1e-9)),
            ("success", &|r| by_id.get(&r.request).is_some_and(|p| p.jump <= rules.jump_ratio)),
        ];
        for (name, f) in shares {
            out.push(metric(&system.id, name, &g.0, &g.1, &share(f, g), "share", seed));
        }
        let censored: Vec<f64> = rules
            .requests
            .iter()
            .filter(|r| in_group(&r.from, &r.to, g))
            .map(|r| censored_latency(by_id.get(&r.request).copied(), rules.latency_horizon))
            .collect();
        out.push(metric(&system.id, "perceived_latency_s", &g.0, &g.1, &censored, "s", seed));
        for (name, on) in [("latency_bridge_start_s", true), ("latency_other_start_s", false)] {
            let v: Vec<f64> = here
                .iter()
                .filter(|p| rules.on_bridge.contains(&p.request) == on)
                .filter_map(|p| p.perceived_latency)
                .collect();
            out.push(metric(&system.id, name, &g.0, &g.1, &v, "s", seed));
        }
    }
    out
}

/// The share of requests whose start frame is a bridge point ([`System`]-independent):
/// `on_bridge` holds those requests' ids.
pub fn start_rows(requests: &[Request], pairs: &[(String, String)], on_bridge: &HashSet<i64>) -> Vec<Metric> {
    groups(pairs)
        .iter()
        .enumerate()
        .map(|(gi, g)| {
            let v: Vec<f64> = requests
                .iter()
                .filter(|r| in_group(&r.from, &r.to, g))
                .map(|r| f64::from(u8::from(on_bridge.contains(&r.request))))
                .collect();
            metric("requests", "start_on_bridge", &g.0, &g.1, &v, "share", gi as u64)
        })
        .collect()
}

/// The measures compared pairwise (perceived latency censored as in [`system_rows`]).
pub const PAIRED: [&str; 7] = [
    "perceived_latency_s",
    "discontinuity_accel",
    "discontinuity_jerk",
    "liveliness_error",
    "liveliness_ks",
    "plausibility_floor_mesh",
    "plausibility_floor_scaled",
];

/// Paired comparisons of system `a` with `b` on the requests both answered: per request,
/// a's value minus b's for each of [`PAIRED`] (perceived latency censored at
/// `latency_horizon`); the mean difference with its bootstrap CI, per ordered pair and
/// overall, as system `<a> vs <b>` and metric `paired_<measure>` (below 0, `a` is lower).
pub fn paired(
    a: (&str, &[Measured]),
    b: (&str, &[Measured]),
    pairs: &[(String, String)],
    latency_horizon: f64,
) -> Vec<Metric> {
    let by_id: std::collections::HashMap<i64, &Measured> = b.1.iter().map(|m| (m.request, m)).collect();
    let both: Vec<(&Measured, &Measured)> = a.1.iter().filter_map(|x| by_id.get(&x.request).map(|y| (x, *y))).collect();
    let system = format!("{} vs {}", a.0, b.0);
    let mut out = Vec::new();
    for (gi, g) in groups(pairs).iter().enumerate() {
        let here: Vec<&(&Measured, &Measured)> = both.iter().filter(|(x, _)| in_group(&x.from, &x.to, g)).collect();
        for name in PAIRED {
            let of = |p: &Measured| match name {
                "perceived_latency_s" => Some(censored_latency(Some(p), latency_horizon)),
                _ => value(p, name),
            };
            let d: Vec<f64> = here.iter().filter_map(|(x, y)| Some(of(x)? - of(y)?)).collect();
            let unit = metrics::find(name).map_or("", |m| m.unit);
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
        System::in_memory(id, Answers { system: id.into(), by_request }, Default::default())
    }

    fn measured(request: i64, to: &str, perceived: Option<f64>, accel: f64) -> Measured {
        Measured {
            request,
            from: if to == "b" { "a".into() } else { "b".into() },
            to: to.into(),
            jump: 0.0,
            discontinuity: crate::measure::motion::Discontinuity { accel, jerk: accel },
            switch_latency: perceived.unwrap_or(1.0) / 2.0,
            perceived_latency: perceived,
            routed: false,
            liveliness: Default::default(),
            plausibility: Default::default(),
            speed: vec![],
        }
    }

    /// Coverage is the share of a pair's requests that arrive (as a viewer sees it) within
    /// the horizon: a → b, the first system arrives in time on 3 of 4 (one too late, at
    /// 1.25 s > 1 s), the second on 2 (two unanswered); b → a the second wins, 2 of 2 against
    /// 0 (one too late, one answered but never arriving). `answered` counts every answer,
    /// `arrived` every arrival, in time or not.
    #[test]
    fn coverage_counts_the_requests_that_arrive_in_time() {
        let reqs: Vec<Request> =
            [(0, "a", "b"), (1, "a", "b"), (2, "a", "b"), (3, "a", "b"), (4, "b", "a"), (5, "b", "a")]
                .iter()
                .map(|&(i, f, t)| request(i, f, t))
                .collect();
        let ours =
            system("x", &[(0, Some(10)), (1, Some(24)), (2, Some(30)), (3, Some(1)), (4, Some(25)), (5, Some(3))]);
        let ours_m = [
            (0, "b", Some(0.4)),
            (1, "b", Some(1.0)),
            (2, "b", Some(1.25)),
            (3, "b", Some(0.1)),
            (4, "a", Some(1.1)),
            (5, "a", None),
        ]
        .map(|(r, to, l)| measured(r, to, l, 1.0));
        let theirs = system("y", &[(0, Some(5)), (1, None), (2, Some(20)), (3, None), (4, Some(3)), (5, Some(24))]);
        let theirs_m = [(0, "b", Some(0.2)), (2, "b", Some(0.9)), (4, "a", Some(0.2)), (5, "a", Some(1.0))]
            .map(|(r, to, l)| measured(r, to, l, 1.0));
        let pairs = vec![("a".to_string(), "b".to_string()), ("b".to_string(), "a".to_string())];
        let on_bridge: HashSet<i64> = [0, 4].into();
        let rules = Rules {
            requests: &reqs,
            pairs: &pairs,
            jump_ratio: 2.0,
            horizon: 1.0,
            latency_horizon: 4.0,
            on_bridge: &on_bridge,
        };
        let m: Vec<Metric> = [(&ours, &ours_m[..]), (&theirs, &theirs_m[..])]
            .iter()
            .flat_map(|(s, per)| system_rows(s, per, rules))
            .collect();
        assert_eq!(value_of(&m, "x", "coverage", "a", "b"), 0.75);
        assert_eq!(value_of(&m, "y", "coverage", "a", "b"), 0.5);
        assert_eq!(value_of(&m, "x", "coverage", "b", "a"), 0.0);
        assert_eq!(value_of(&m, "y", "coverage", "b", "a"), 1.0);
        assert!((value_of(&m, "x", "coverage", "all", "all") - 0.5).abs() < 1e-12);
        assert!((value_of(&m, "y", "coverage", "all", "all") - 4.0 / 6.0).abs() < 1e-12);
        assert_eq!(value_of(&m, "x", "answered", "all", "all"), 1.0);
        assert!((value_of(&m, "x", "arrived", "all", "all") - 5.0 / 6.0).abs() < 1e-12);
        // The ranked latency is over every request, a non-arrival counted as the 4 s horizon;
        // the arrived-only latency beside it, over the requests that arrived.
        let lat = m.iter().find(|r| r.system == "x" && r.metric == "perceived_latency_s" && r.from == "all").unwrap();
        assert_eq!(lat.n, 6);
        assert!((lat.value - (0.4 + 1.0 + 1.25 + 0.1 + 1.1 + 4.0) / 6.0).abs() < 1e-12);
        let own = m.iter().find(|r| r.system == "x" && r.metric == "perceived_latency_arrived_s" && r.from == "all");
        assert_eq!(own.unwrap().n, 5);
        // y left two requests unanswered: they count as the horizon too.
        assert!(
            (value_of(&m, "y", "perceived_latency_s", "all", "all") - (0.2 + 4.0 + 0.9 + 4.0 + 0.2 + 1.0) / 6.0).abs()
                < 1e-12
        );
        // Split by start: requests 0 and 4 start on bridge points.
        assert!((value_of(&m, "x", "latency_bridge_start_s", "all", "all") - (0.4 + 1.1) / 2.0).abs() < 1e-12);
        assert!((value_of(&m, "x", "latency_other_start_s", "all", "all") - (1.0 + 1.25 + 0.1) / 3.0).abs() < 1e-12);
        // Every measured answer is jump-free here; unanswered requests do not succeed.
        assert_eq!(value_of(&m, "y", "success", "all", "all"), 4.0 / 6.0);
    }

    pub(crate) fn value_of(m: &[Metric], system: &str, name: &str, from: &str, to: &str) -> f64 {
        m.iter()
            .find(|x| x.system == system && x.metric == name && x.from == from && x.to == to)
            .unwrap_or_else(|| panic!("no {system} {name} {from}→{to}"))
            .value
    }

    /// Paired differences use only the requests both answered, a minus b (a latency that
    /// never arrives counted as the horizon): here a is slower (it loses) and 1 lower in
    /// acceleration (it wins).
    #[test]
    fn paired_differences_on_common_requests() {
        let ours = vec![
            measured(0, "b", Some(1.0), 1.0),
            measured(1, "b", Some(2.0), 2.0),
            measured(2, "b", Some(9.0), 9.0),
            measured(4, "b", None, 1.0),
        ];
        let theirs = vec![
            measured(0, "b", Some(0.5), 2.0),
            measured(1, "b", Some(1.5), 3.0),
            measured(3, "b", Some(0.0), 0.0),
            measured(4, "b", Some(0.1), 2.0),
        ];
        let m = paired(("x", &ours), ("y", &theirs), &[("a".into(), "b".into())], 4.0);
        let lat = m.iter().find(|x| x.metric == "paired_perceived_latency_s" && x.from == "all").unwrap();
        // Requests 0, 1 (0.5 s slower each) and 4 (x never arrives: 4 − 0.1 = 3.9).
        assert_eq!((lat.system.as_str(), lat.n), ("x vs y", 3));
        assert!((lat.value - (0.5 + 0.5 + 3.9) / 3.0).abs() < 1e-12);
        assert!(lat.ci_low.unwrap() > 0.0, "x is slower on every common request");
        assert_eq!(value_of(&m, "x vs y", "paired_discontinuity_accel", "a", "b"), -1.0);
        // Without plausibility frames the paired plausibility has no observations.
        assert_eq!(m.iter().find(|x| x.metric == "paired_plausibility_floor_scaled").unwrap().n, 0);
    }

    /// Every per-request measure resolves to a value or to "does not apply", never to a
    /// misspelt id that silently measures nothing.
    #[test]
    fn every_per_request_measure_is_known() {
        let p = measured(0, "b", Some(1.0), 1.0);
        for (id, _) in per_request() {
            assert!(reprise_benchmark::metrics::find(&id).is_some(), "{id} is not in the catalogue");
            let known = value(&p, &id).is_some()
                || id.starts_with("plausibility_")
                || id.starts_with("liveliness_")
                || id == "latency_routed_s";
            assert!(known, "{id}");
        }
        assert_eq!(value(&p, "latency_direct_s"), Some(1.0));
        assert_eq!(value(&p, "no_such"), None);
    }
}
