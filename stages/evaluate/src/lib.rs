//! The evaluate stage: reprise against the Motion Graphs baseline on the transition
//! benchmark, measured on meshes evaluated through the rig, plus the model-quality
//! measurements of the earlier stages. Writes `metrics.parquet` (one row per system,
//! metric and label pair) and `report.md`, which defines every metric.
//!
//! Metrics (the report's definitions section says the same):
//! - `peak_accel_ratio`, `peak_jerk_ratio`: per answered request, the largest per-frame
//!   peak vertex acceleration (jerk) within the transition window — from $k/2$ frames
//!   before the first frame of the target label to $k + k/2$ after it — divided by the 95th
//!   percentile of the same per-frame quantity over the training segments.
//! - `plausibility`: per synthesized frame (every `plausibility_stride`-th), the distance
//!   in scaled control space ($z = \bar w\,p$, mesh length) to the nearest training frame,
//!   divided by the median distance between consecutive training frames.
//! - `answered`: the share of requests answered; `latency_s`: seconds from the request to
//!   the first frame of the target label.
//! - `coverage`: simulated, the share of the benchmark's requests from A (seeded start
//!   frames, the same for every system) that reach B within `coverage_seconds` of the
//!   request — each system's answers run and timed, not inferred from its tables.
//! - `transition_points`: bridges A → B (reprise); transition edges from A to B in the
//!   pruned graph (baseline).
//! - `heldout_mesh_rmse`: GPLVM against PCA with q components on held-out frames (from
//!   `gplvm_fits`); `ablation_mesh_rmse`: scaled against unscaled PCA at d = 3 (from
//!   `pca_errors`).
//!
//! Confidence intervals: 95 % percentile bootstrap of the mean (1000 resamples, seeded).

mod html;
mod render;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Parser;
use rayon::prelude::*;
use reprise_artifact::controls::Controls;
use reprise_artifact::curves::{self, Curves};
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::transitions::{self, Answer, Request};
use reprise_artifact::{bridges, motion_graph, scales, Columns, Kind, Table};
use reprise_metrics::{bootstrap_mean_ci, nearest_distance, peak_speeds, peaks, quantile};
use reprise_stagekit::rig::{meshes, open_rig};
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

/// Kind of the metrics table.
pub const METRICS: Kind = Kind { name: "metrics", version: 1 };

/// Which answer of a request a system gave: (frame of the request, latency) in its curves.
type Pick = fn(&Request) -> Option<(i64, i64)>;

/// `reprise-evaluate`: metrics and the report.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-evaluate", version, about)]
pub struct Args {
    /// Input: the labeled frames.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub labeled_frames: PathBuf,
    /// Input: the controls table (the rig).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub controls: PathBuf,
    /// Input: the scales.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub scales: PathBuf,
    /// Input: the transition requests.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub requests: PathBuf,
    /// Input: reprise's transition curves.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub reprise_curves: PathBuf,
    /// Input: reprise's transition curves under other seeds.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub reprise_reseeded: PathBuf,
    /// Input: the baseline's transition curves.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub baseline_curves: PathBuf,
    /// Input: the bridges.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub bridges: PathBuf,
    /// Input: the motion graph's nodes.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub mg_nodes: PathBuf,
    /// Input: the motion graph's edges.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub mg_edges: PathBuf,
    /// Input: the GPLVM fit summaries (held-out errors).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub gplvm_fits: PathBuf,
    /// Input: the PCA errors (the scaling ablation).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub pca_errors: PathBuf,
    /// Input: the GPLVM latents (the latent-space figures).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub latents: PathBuf,
    /// Input: the GPLVM models (bridge poses).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub gplvm_models: PathBuf,
    /// Input: the PCA models (bridge poses).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub pca_models: PathBuf,
    /// Input: synthesized curves (the filmstrip shows their first script).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub curves: PathBuf,
    /// Output: the HTML report (self-contained).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub html: PathBuf,
    /// The runner's lock file, read (if present) for per-stage times in the provenance.
    #[arg(long, value_name = "FILE")]
    pub lock: Option<PathBuf>,
    /// Output: the metrics table.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub metrics: PathBuf,
    /// Output: the Markdown report.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub report: PathBuf,
    /// The report's title (the pipeline's name).
    #[arg(long, default_value = "reprise")]
    pub name: String,
    /// The blend length k (frames).
    #[arg(long, default_value_t = 12)]
    pub window: usize,
    /// Coverage horizon T, seconds.
    #[arg(long, default_value_t = 2.0)]
    pub coverage_seconds: f64,
    /// Measure plausibility on every n-th synthesized frame.
    #[arg(long, default_value_t = 3)]
    pub plausibility_stride: usize,
    /// Success: no frame of the answer with a peak vertex speed above this many times the
    /// training data's 99th percentile (a pose jump).
    #[arg(long, default_value_t = 2.0)]
    pub jump_ratio: f64,
    /// Only validate the flags and exit.
    #[arg(long)]
    #[serde(skip)]
    pub check: bool,
}

/// One metric row.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    /// `reprise`, `baseline`, or a variant (`gplvm`, `pca`, `scaled`, `unscaled`).
    pub system: String,
    /// Metric name.
    pub metric: String,
    /// Label A (or the label).
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

fn metric(system: &str, name: &str, from: &str, to: &str, values: &[f64], unit: &str, seed: u64) -> Metric {
    let (m, lo, hi) = bootstrap_mean_ci(values, 1000, seed);
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

/// Paired comparisons on the requests both systems answered: per request, reprise's value
/// minus the baseline's, for latency, peak acceleration and jerk and mean plausibility;
/// the mean difference with its bootstrap CI, per ordered pair and over all (system
/// `reprise-baseline`; below 0, reprise is lower).
fn paired(ours: &[Measured], theirs: &[Measured], pairs: &[(String, String)]) -> Vec<Metric> {
    let by_id: std::collections::HashMap<i64, &Measured> = theirs.iter().map(|m| (m.request, m)).collect();
    let both: Vec<(&Measured, &Measured)> =
        ours.iter().filter_map(|a| by_id.get(&a.request).map(|b| (a, *b))).collect();
    fn mean(v: &[f64]) -> f64 {
        v.iter().sum::<f64>() / v.len().max(1) as f64
    }
    let measures: [(&str, fn(&Measured) -> f64, &str); 4] = [
        ("paired_latency_s", |m| m.latency, "s"),
        ("paired_peak_accel_ratio", |m| m.accel, "× training p95"),
        ("paired_peak_jerk_ratio", |m| m.jerk, "× training p95"),
        ("paired_plausibility", |m| mean(&m.plausibility), "× median frame step"),
    ];
    let mut groups: Vec<(String, String)> = vec![("all".into(), "all".into())];
    groups.extend(pairs.iter().cloned());
    let mut out = Vec::new();
    for (gi, (from, to)) in groups.iter().enumerate() {
        let here: Vec<&(&Measured, &Measured)> =
            both.iter().filter(|(a, _)| (from == "all" || &a.from == from) && (to == "all" || &a.to == to)).collect();
        for (name, f, unit) in measures {
            let d: Vec<f64> = here.iter().map(|(a, b)| f(a) - f(b)).collect();
            out.push(metric("reprise-baseline", name, from, to, &d, unit, 100 + gi as u64));
        }
    }
    out
}

/// Simulated coverage, per ordered pair and over all: the share of the pair's requests (start
/// frames of A drawn by the benchmark, the same for both systems) that the system answered,
/// reaching B within `horizon` frames of the request — run, not inferred.
fn coverage(reqs: &[Request], pairs: &[(String, String)], horizon: i64) -> Vec<Metric> {
    let mut out = Vec::new();
    for (system, answer) in SYSTEMS {
        let reached = |r: &Request| f64::from(u8::from(answer(r).latency.is_some_and(|l| l <= horizon)));
        for (a, b) in pairs {
            let v: Vec<f64> = reqs.iter().filter(|r| &r.from == a && &r.to == b).map(reached).collect();
            out.push(metric(system, "coverage", a, b, &v, "share", 11));
        }
        let all: Vec<f64> = reqs.iter().map(reached).collect();
        out.push(metric(system, "coverage", "all", "all", &all, "share", 11));
    }
    out
}

/// The systems compared, with how each answered a request.
const SYSTEMS: [(&str, fn(&Request) -> &Answer); 2] = [("reprise", |r| &r.reprise), ("baseline", |r| &r.baseline)];

fn exact(system: &str, name: &str, from: &str, to: &str, value: f64, n: usize, unit: &str) -> Metric {
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

/// What one answered request measured.
struct Measured {
    request: i64,
    from: String,
    to: String,
    /// Largest peak vertex speed from the request on / the training p99 (a pose jump).
    jump: f64,
    /// Peak acceleration in the transition window / the training p95.
    accel: f64,
    /// Peak jerk likewise.
    jerk: f64,
    /// Seconds to the first frame of the target label.
    latency: f64,
    /// Plausibility distances of its (strided) frames.
    plausibility: Vec<f64>,
    /// Peak vertex speed at offsets `-SPEED_BEFORE..=SPEED_AFTER` from the first target
    /// frame (NaN outside the answer).
    speed: Vec<f64>,
}

/// Frames before and after the first target frame in the velocity figure.
const SPEED_BEFORE: i64 = 12;
const SPEED_AFTER: i64 = 30;

/// Per request of one system: (request, frames of controls as table rows).
fn by_script(c: &Curves) -> BTreeMap<i64, Vec<Vec<f64>>> {
    let n = c.controls.len();
    let mut out: BTreeMap<i64, Vec<Vec<f64>>> = BTreeMap::new();
    for r in 0..c.script.len() {
        let id: i64 = c.script[r].trim_start_matches('r').parse().unwrap_or(-1);
        out.entry(id).or_default().push(c.values[r * n..(r + 1) * n].to_vec());
    }
    out
}

/// Runs the stage; returns the metric rows.
pub fn run(args: &Args) -> StageResult<Option<Vec<Metric>>> {
    if args.window < 2 || args.coverage_seconds.is_nan() || args.coverage_seconds < 0.0 || args.plausibility_stride == 0
    {
        return Err(StageError::Config(
            "need --window >= 2, --coverage-seconds >= 0, --plausibility-stride >= 1".into(),
        ));
    }
    if args.check {
        return Ok(None);
    }
    let mut provenance = reprise_stagekit::provenance("evaluate", env!("CARGO_PKG_VERSION"), args);
    for (role, p) in [
        ("labeled_frames", &args.labeled_frames),
        ("controls", &args.controls),
        ("scales", &args.scales),
        ("requests", &args.requests),
        ("reprise_curves", &args.reprise_curves),
        ("baseline_curves", &args.baseline_curves),
        ("reprise_reseeded", &args.reprise_reseeded),
        ("bridges", &args.bridges),
        ("mg_nodes", &args.mg_nodes),
        ("mg_edges", &args.mg_edges),
        ("gplvm_fits", &args.gplvm_fits),
        ("pca_errors", &args.pca_errors),
        ("latents", &args.latents),
        ("gplvm_models", &args.gplvm_models),
        ("pca_models", &args.pca_models),
        ("curves", &args.curves),
    ] {
        provenance = provenance.with_input(role, p)?;
    }
    let labeled = LabeledFrames::read(&args.labeled_frames)?;
    let rig = open_rig(&Controls::read(&args.controls)?, &labeled.frames.controls)?;
    let reqs = transitions::read(&args.requests)?;
    let (ours, theirs) = (curves::read(&args.reprise_curves)?, curves::read(&args.baseline_curves)?);
    for c in [&ours, &theirs] {
        if c.controls != labeled.frames.controls {
            return Err(StageError::Input(
                "the transition curves and the labeled frames list different controls".into(),
            ));
        }
    }
    let fps = labeled.frames.fps;
    let k = args.window;
    let n = labeled.frames.rows();
    let rows: Vec<Vec<f64>> = (0..n).map(|r| labeled.frames.row(r).to_vec()).collect();
    // Training reference: per-frame peaks within each segment, and consecutive distances.
    let seg_runs = labeled.segment_runs();
    // Training meshes one segment at a time (all of them at once would be N × 3V values).
    let camera_mesh = meshes(&rig, &rows[..1])?;
    let dim = camera_mesh.len();
    type Peaks = (Vec<f64>, Vec<f64>, Vec<f64>);
    let per_segment: Vec<StageResult<Peaks>> = seg_runs
        .par_iter()
        .map(|&(s, e)| {
            let m = meshes(&rig, &rows[s..e])?;
            let (a, j) = peaks(&m, dim, fps);
            let v = peak_speeds(&m, dim, fps);
            Ok((
                a[1..a.len().saturating_sub(1)].to_vec(),
                j[1..j.len().saturating_sub(2).max(1)].to_vec(),
                v.get(1..).unwrap_or_default().to_vec(),
            ))
        })
        .collect();
    let (mut tr_acc, mut tr_jerk, mut tr_speed) = (Vec::new(), Vec::new(), Vec::new());
    for r in per_segment {
        let (a, j, v) = r?;
        tr_acc.extend(a);
        tr_jerk.extend(j);
        tr_speed.extend(v);
    }
    let (acc95, jerk95) = (quantile(&tr_acc, 0.95), quantile(&tr_jerk, 0.95));
    let speed99 = quantile(&tr_speed, 0.99).max(1e-12);
    // Scaled control space for plausibility (the motion graph's metric).
    let scale_rows = scales::read(&args.scales)?;
    let weight = scales::mean_weights(&scale_rows, &labeled.frames.controls);
    let c = weight.len();
    let z = |p: &[f64]| -> Vec<f64> { p.iter().zip(&weight).map(|(a, w)| a * w).collect() };
    let ztrain: Vec<f64> = rows.iter().flat_map(|r| z(r)).collect();
    let mut steps = Vec::new();
    for &(s, e) in &seg_runs {
        for r in s + 1..e {
            steps.push(
                ztrain[r * c..(r + 1) * c]
                    .iter()
                    .zip(&ztrain[(r - 1) * c..r * c])
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt(),
            );
        }
    }
    let step = quantile(&steps, 0.5).max(1e-12);

    let mut out: Vec<Metric> = Vec::new();
    let mut measured: Vec<Vec<Measured>> = Vec::new();
    let mut speed_traces = Vec::new();
    let pairs: Vec<(String, String)> = {
        let mut p: Vec<(String, String)> = reqs.iter().map(|r| (r.from.clone(), r.to.clone())).collect();
        p.dedup();
        p
    };
    for (system, curves, pick) in [
        ("reprise", &ours, (|r: &Request| r.reprise.latency.map(|l| (r.reprise.asked, l))) as Pick),
        ("baseline", &theirs, |r: &Request| r.baseline.latency.map(|l| (r.baseline.asked, l))),
    ] {
        let frames = by_script(curves);
        let per: Vec<StageResult<Measured>> = reqs
            .par_iter()
            .filter_map(|r| pick(r).map(|l| (r, l)))
            .filter_map(|(r, l)| frames.get(&r.request).map(|f| (r, l, f)))
            .map(|(r, (asked, latency), f)| {
                let m = meshes(&rig, f)?;
                let (a, j) = peaks(&m, dim, fps);
                // The whole answer: from the request to the end of the blend into B.
                let l = asked + latency;
                let lo = (asked.max(0) as usize).min(f.len());
                let hi = (l as usize + k).min(f.len());
                let pa = a[lo..hi.max(lo)].iter().copied().fold(0.0, f64::max);
                let pj = j[lo..hi.max(lo)].iter().copied().fold(0.0, f64::max);
                let plaus: Vec<f64> = f
                    .iter()
                    .step_by(args.plausibility_stride)
                    .map(|p| nearest_distance(&z(p), &ztrain, c) / step)
                    .collect();
                let speed = (-SPEED_BEFORE..=SPEED_AFTER)
                    .map(|o| {
                        let t = l + o;
                        if t < 1 || t as usize >= f.len() {
                            return f64::NAN;
                        }
                        let t = t as usize;
                        (0..dim / 3)
                            .map(|v| {
                                (0..3)
                                    .map(|a| (m[t * dim + 3 * v + a] - m[(t - 1) * dim + 3 * v + a]).powi(2))
                                    .sum::<f64>()
                                    .sqrt()
                            })
                            .fold(0.0, f64::max)
                            * fps
                    })
                    .collect();
                let jump =
                    peak_speeds(&m, dim, fps)[(lo + 1).min(f.len())..].iter().copied().fold(0.0, f64::max) / speed99;
                Ok(Measured {
                    request: r.request,
                    jump,
                    speed,
                    from: r.from.clone(),
                    to: r.to.clone(),
                    accel: pa / acc95,
                    jerk: pj / jerk95,
                    latency: latency as f64 / fps,
                    plausibility: plaus,
                })
            })
            .collect();
        let per: Vec<_> = per.into_iter().collect::<StageResult<_>>()?;
        let all = |pick: &dyn Fn(&Measured) -> Vec<f64>, from: &str, to: &str| -> Vec<f64> {
            per.iter()
                .filter(|p| (from == "all" || p.from == from) && (to == "all" || p.to == to))
                .flat_map(pick)
                .collect()
        };
        let offsets: Vec<i64> = (-SPEED_BEFORE..=SPEED_AFTER).collect();
        let mean_speed: Vec<f64> = (0..offsets.len())
            .map(|i| {
                let v: Vec<f64> = per.iter().map(|p| p.speed[i]).filter(|v| v.is_finite()).collect();
                if v.is_empty() {
                    f64::NAN
                } else {
                    v.iter().sum::<f64>() / v.len() as f64
                }
            })
            .collect();
        let shown = if system == "reprise" { "reprise" } else { "Motion Graphs" };
        speed_traces.push((shown.to_string(), offsets, mean_speed));
        let mut groups: Vec<(String, String)> = vec![("all".into(), "all".into())];
        groups.extend(pairs.iter().cloned());
        for (gi, (from, to)) in groups.iter().enumerate() {
            let seed = gi as u64;
            out.push(metric(
                system,
                "peak_accel_ratio",
                from,
                to,
                &all(&|p| vec![p.accel], from, to),
                "× training p95",
                seed,
            ));
            out.push(metric(
                system,
                "peak_jerk_ratio",
                from,
                to,
                &all(&|p| vec![p.jerk], from, to),
                "× training p95",
                seed,
            ));
            out.push(metric(system, "latency_s", from, to, &all(&|p| vec![p.latency], from, to), "s", seed));
            out.push(metric(
                system,
                "plausibility",
                from,
                to,
                &all(&|p| p.plausibility.clone(), from, to),
                "× median frame step",
                seed,
            ));
            let asked: Vec<&Request> =
                reqs.iter().filter(|r| (from == "all" || &r.from == from) && (to == "all" || &r.to == to)).collect();
            let answered: Vec<f64> = asked.iter().map(|r| f64::from(u8::from(pick(r).is_some()))).collect();
            out.push(metric(system, "answered", from, to, &answered, "share", seed));
            let jumps: std::collections::HashMap<i64, f64> = per.iter().map(|p| (p.request, p.jump)).collect();
            let success: Vec<f64> = asked
                .iter()
                .map(|r| f64::from(u8::from(jumps.get(&r.request).is_some_and(|&j| j <= args.jump_ratio))))
                .collect();
            out.push(metric(system, "success", from, to, &success, "share", seed));
        }
        measured.push(per);
    }
    out.extend(paired(&measured[0], &measured[1], &pairs));

    // Variety: reprise against itself under another seed, per request, on meshes; the
    // baseline's graph search is deterministic, so its repeated answers are identical.
    let (first, second) = (by_script(&ours), by_script(&curves::read(&args.reprise_reseeded)?));
    let var: Vec<StageResult<f64>> = first
        .par_iter()
        .filter_map(|(id, a)| second.get(id).map(|b| (a, b)))
        .map(|(a, b)| {
            let (ma, mb) = (meshes(&rig, a)?, meshes(&rig, b)?);
            let frames = ma.len().min(mb.len()) / dim;
            let rms: f64 = (0..frames)
                .map(|t| reprise_stagekit::rig::mesh_rmse(&ma[t * dim..(t + 1) * dim], &mb[t * dim..(t + 1) * dim]))
                .sum::<f64>()
                / frames.max(1) as f64;
            Ok(rms)
        })
        .collect();
    let var: Vec<f64> = var.into_iter().collect::<StageResult<_>>()?;
    out.push(metric("reprise", "variety", "all", "all", &var, "mesh units", 7));
    let answered_baseline = reqs.iter().filter(|r| r.baseline.latency.is_some()).count();
    out.push(exact("baseline", "variety", "all", "all", 0.0, answered_baseline, "mesh units"));
    // Transition points and coverage.
    let links = bridges::read(&args.bridges)?;
    let nodes = motion_graph::read_nodes(&args.mg_nodes)?;
    let edges = motion_graph::read_edges(&args.mg_edges)?;
    let horizon = (args.coverage_seconds * fps).round() as u32;
    let labels: Vec<String> = {
        let mut l: Vec<String> = Vec::new();
        for x in &labeled.label {
            if !l.contains(x) {
                l.push(x.clone());
            }
        }
        l
    };
    for (ai, a) in labels.iter().enumerate() {
        for (bi, b) in labels.iter().enumerate() {
            if ai == bi {
                continue;
            }
            let bridges_ab = links.iter().filter(|l| &l.from == a && &l.to == b).count();
            let mg_ab = edges
                .iter()
                .filter(|e| {
                    e.kind == "transition"
                        && e.in_scc
                        && &nodes.label[e.from as usize] == a
                        && &nodes.label[e.to as usize] == b
                })
                .count();
            out.push(exact("reprise", "transition_points", a, b, bridges_ab as f64, 1, "count"));
            out.push(exact("baseline", "transition_points", a, b, mg_ab as f64, 1, "count"));
        }
    }
    out.extend(coverage(&reqs, &pairs, i64::from(horizon)));
    // Model quality from earlier stages.
    let fits = Table::read(&args.gplvm_fits, reprise_artifact::gplvm::GPLVM_FITS)?;
    let (fl, fg, fp) =
        (fits.strings("label")?, fits.f64_opt("heldout_gplvm_mesh_rmse")?, fits.f64_opt("heldout_pca_mesh_rmse")?);
    let held = fits.i64("heldout_frames")?;
    for r in 0..fits.rows() {
        if let (Some(g), Some(p)) = (fg[r], fp[r]) {
            out.push(exact("gplvm", "heldout_mesh_rmse", &fl[r], "", g, held[r] as usize, "mesh units"));
            out.push(exact("pca", "heldout_mesh_rmse", &fl[r], "", p, held[r] as usize, "mesh units"));
        }
    }
    let errs = Table::read(&args.pca_errors, reprise_artifact::pca::PCA_ERRORS)?;
    let (el, ev, ed, em) =
        (errs.strings("label")?, errs.strings("variant")?, errs.i64("d")?, errs.f64_opt("mesh_rmse")?);
    for r in 0..errs.rows() {
        if let (3, Some(m)) = (ed[r], em[r]) {
            out.push(exact(&ev[r], "ablation_mesh_rmse", &el[r], "", m, 1, "mesh units"));
        }
    }
    let md = report(
        &out,
        &labels,
        TrainingRefs { acc95, jerk95, speed99, step },
        args,
        nodes.in_scc.iter().filter(|v| **v).count(),
        nodes.frame.len(),
    );
    let page = figures(args, &rig, &links, &labels, &camera_mesh, &md, speed_traces, &provenance)?;
    let html = html::page(&page, &out);
    write_metrics(&args.metrics, &out, &provenance)?;
    for (path, text) in [(&args.report, md.as_str()), (&args.html, html.as_str())] {
        reprise_artifact::table::write_atomic(path, |f| {
            use std::io::Write as _;
            f.write_all(text.as_bytes()).map_err(|e| reprise_artifact::ArtifactError::io(path, e))
        })?;
    }
    Ok(Some(out))
}

fn write_metrics(path: &std::path::Path, m: &[Metric], provenance: &reprise_artifact::Provenance) -> StageResult<()> {
    let s = |f: fn(&Metric) -> &str| m.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .str("system", &s(|m| m.system.as_str()))
        .str("metric", &s(|m| m.metric.as_str()))
        .str("from", &s(|m| m.from.as_str()))
        .str("to", &s(|m| m.to.as_str()))
        .f64("value", m.iter().map(|m| m.value).collect())
        .f64_opt("ci_low", m.iter().map(|m| m.ci_low).collect())
        .f64_opt("ci_high", m.iter().map(|m| m.ci_high).collect())
        .i64("n", m.iter().map(|m| m.n).collect())
        .str("unit", &s(|m| m.unit.as_str()));
    reprise_artifact::table::write(path, METRICS, cols, provenance, &[])?;
    Ok(())
}

fn find<'a>(m: &'a [Metric], system: &str, metric: &str, from: &str, to: &str) -> Option<&'a Metric> {
    m.iter().find(|x| x.system == system && x.metric == metric && x.from == from && x.to == to)
}

fn cell(m: Option<&Metric>) -> String {
    match m {
        Some(m) => match (m.ci_low, m.ci_high) {
            (Some(lo), Some(hi)) => format!("{:.3} [{lo:.3}, {hi:.3}]", m.value),
            _ => format!("{:.3}", m.value),
        },
        None => "–".into(),
    }
}

/// The training data's reference values the metrics are divided by.
struct TrainingRefs {
    /// 95th percentile of per-frame peak vertex acceleration (mesh units/s²).
    acc95: f64,
    /// 95th percentile of per-frame peak vertex jerk (mesh units/s³).
    jerk95: f64,
    /// 99th percentile of per-frame peak vertex speed (mesh units/s).
    speed99: f64,
    /// Median distance between consecutive training frames in scaled control space.
    step: f64,
}

fn report(m: &[Metric], labels: &[String], refs: TrainingRefs, args: &Args, scc: usize, frames: usize) -> String {
    let TrainingRefs { acc95, jerk95, speed99: s99, step } = refs;
    let mut s = String::new();
    let _ = writeln!(s, "# reprise against Motion Graphs\n");
    let _ = writeln!(s, "## Overall (all label pairs; mean [95 % bootstrap CI])\n");
    let _ = writeln!(s, "| metric | reprise | Motion Graphs | better |\n|---|---|---|---|");
    let lower_better = ["peak_accel_ratio", "peak_jerk_ratio", "latency_s", "plausibility"];
    let mut wins = (Vec::new(), Vec::new());
    for name in [
        "answered",
        "success",
        "coverage",
        "latency_s",
        "peak_accel_ratio",
        "peak_jerk_ratio",
        "plausibility",
        "variety",
    ] {
        let (a, b) = (find(m, "reprise", name, "all", "all"), find(m, "baseline", name, "all", "all"));
        let better = match (a, b) {
            // Variety rewards random-force noise as much as real alternatives: it is reported
            // beside plausibility, never ranked alone (and the baseline's is 0 by construction).
            _ if name == "variety" => "not ranked",
            (Some(a), Some(b)) if a.value.is_finite() && b.value.is_finite() => {
                let ours = if lower_better.contains(&name) { a.value < b.value } else { a.value > b.value };
                if ours {
                    wins.0.push(name)
                } else {
                    wins.1.push(name)
                };
                if ours {
                    "reprise"
                } else {
                    "Motion Graphs"
                }
            }
            _ => "–",
        };
        let _ = writeln!(s, "| `{name}` | {} | {} | {better} |", cell(a), cell(b));
    }
    let cov = |sys: &str| {
        let v: Vec<f64> = m
            .iter()
            .filter(|x| x.system == sys && x.metric == "coverage" && x.from != "all")
            .map(|x| x.value)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let pts = |sys: &str| {
        m.iter().filter(|x| x.system == sys && x.metric == "transition_points").map(|x| x.value).sum::<f64>()
    };
    let _ = writeln!(s, "| `coverage` (mean over pairs) | {:.3} | {:.3} | – |", cov("reprise"), cov("baseline"));
    let _ = writeln!(s, "| `transition_points` (total) | {:.0} | {:.0} | – |\n", pts("reprise"), pts("baseline"));
    let _ = writeln!(
        s,
        "## Paired, on the requests both systems answered (reprise − Motion Graphs; mean [95 % CI])\n\n| metric | difference | n | lower is |\n|---|---|---|---|"
    );
    for name in ["paired_latency_s", "paired_peak_accel_ratio", "paired_peak_jerk_ratio", "paired_plausibility"] {
        if let Some(d) = find(m, "reprise-baseline", name, "all", "all") {
            let side = match (d.ci_low, d.ci_high) {
                (_, Some(hi)) if hi < 0.0 => "reprise (CI below 0)",
                (Some(lo), _) if lo > 0.0 => "Motion Graphs (CI above 0)",
                _ => "neither (CI spans 0)",
            };
            let _ = writeln!(s, "| `{name}` | {} | {} | {side} |", cell(Some(d)), d.n);
        }
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "The Motion Graph keeps {scc} of {frames} training frames after pruning to its largest strongly connected component.\n"
    );
    let _ = writeln!(s, "## Conclusions\n");
    let _ = writeln!(
        s,
        "- reprise is better on: {}.",
        if wins.0.is_empty() { "nothing measured here".to_string() } else { wins.0.join(", ") }
    );
    let _ = writeln!(
        s,
        "- **Motion Graphs is better on: {}.**",
        if wins.1.is_empty() { "nothing measured here".to_string() } else { wins.1.join(", ") }
    );
    let _ = writeln!(
        s,
        "- Motion Graphs plays training frames between transitions, so its poses away from the blends are training poses by \
         construction; its plausibility floor is 0 where reprise's is its PCA reconstruction error.\n"
    );
    let _ = writeln!(
        s,
        "## Coverage within {} s (share of the pair's requests reaching B in time; reprise / Motion Graphs)\n",
        args.coverage_seconds
    );
    let _ = write!(s, "| from \\ to |");
    labels.iter().for_each(|l| {
        let _ = write!(s, " {l} |");
    });
    let _ = writeln!(s, "\n|---|{}", "---|".repeat(labels.len()));
    for a in labels {
        let _ = write!(s, "| {a} |");
        for b in labels {
            let v = |sys| find(m, sys, "coverage", a, b).map_or("–".to_string(), |x| format!("{:.2}", x.value));
            let _ = if a == b { write!(s, " – |") } else { write!(s, " {} / {} |", v("reprise"), v("baseline")) };
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "\n## Model quality\n\n| label | held-out GPLVM | held-out PCA (q) | PCA d = 3 scaled | unscaled |\n|---|---|---|---|---|");
    for l in labels {
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
    let _ = writeln!(s, "\n## Definitions\n");
    let _ = writeln!(
        s,
        "- `peak_accel_ratio`, `peak_jerk_ratio`: per answered request, the largest per-frame peak vertex acceleration \
         (jerk) — max over vertices of the central second (third) difference of positions, × fps² (fps³) — over the whole \
         answer, from the request to {e} frames after the first frame of the target label (the end of the blend), divided by \
         the 95th percentile of the same per-frame quantity over the training segments ({acc95:.4} and {jerk95:.4} mesh \
         units/s² and /s³).\n\
         - `plausibility`: per synthesized frame (every {ps}-th), the distance in scaled control space to the nearest training \
         frame, divided by the median distance between consecutive training frames ({step:.4}).\n\
         - `answered`: share of requests answered; `latency_s`: seconds from the request to the first frame of the target label \
         (reprise's hold before its TRANSITION is not counted; for both systems a blended frame counts as the target's).\n\
         - `variety`: per request, the mean over frames of the RMS vertex distance between reprise's answer and its answer \
         under another seed (the random force's); the baseline's graph search is deterministic, so its variety is 0.\n\
         - `coverage`: simulated, the share of the benchmark's requests from A (seeded start frames, the same for both systems) \
         that reach B within {cs} s of the request.\n\
         - `success`: share of requests answered with no frame whose peak vertex speed exceeds {jr} × the training data's 99th \
         percentile ({s99:.4} mesh units/s) — the same criterion for both systems.\n\
         - `paired_*`: per request answered by both, reprise's value minus the baseline's; mean and bootstrap CI.\n\
         - `transition_points`: bridges A → B (reprise); transition edges from A to B in the pruned graph (Motion Graphs).\n\
         - `heldout_mesh_rmse`: RMS vertex error of held-out frames (GPLVM through its best latent point; PCA with q components \
         of the same training frames); `ablation_mesh_rmse`: RMS vertex error of 3-component PCA, scaled against unscaled controls.\n\
         - CIs: 95 % percentile bootstrap of the mean, 1000 resamples.",
        e = args.window,
        jr = args.jump_ratio,
        ps = args.plausibility_stride,
        cs = args.coverage_seconds,
    );
    s
}

/// The figures' data and the provenance lines.
#[allow(clippy::too_many_arguments)]
fn figures<'a>(
    args: &'a Args,
    rig: &'a (Box<dyn reprise_rig::Rig>, reprise_rig::PoseLayout),
    links: &[bridges::Bridge],
    labels: &'a [String],
    camera_mesh: &'a [f64],
    md: &'a str,
    speed: Vec<(String, Vec<i64>, Vec<f64>)>,
    provenance: &reprise_artifact::Provenance,
) -> StageResult<html::Page<'a>> {
    let lat = reprise_artifact::gplvm::read_latents(&args.latents)?;
    let latents = labels
        .iter()
        .map(|l| {
            let mut segs: BTreeMap<i64, Vec<[f64; 2]>> = BTreeMap::new();
            for r in (0..lat.label.len()).filter(|&r| &lat.label[r] == l) {
                segs.entry(lat.segment_id[r]).or_default().push([lat.x[r][0], lat.x[r].get(1).copied().unwrap_or(0.0)]);
            }
            (l.clone(), segs.into_values().collect())
        })
        .collect();
    let models = reprise_model::load(&args.gplvm_models, &args.pca_models, &args.scales)?;
    let pose = |m: &reprise_numerics::gplvm::LatentModel, x: &[f64]| {
        let mut p = vec![0.0; m.controls()];
        m.controls_into(x, &mut vec![0.0; m.d()], &mut p);
        p
    };
    let mut best: Vec<&bridges::Bridge> = links.iter().filter(|b| b.rank == 1).collect();
    best.sort_by(|a, b| {
        a.mesh_distance.unwrap_or(a.rig_distance).total_cmp(&b.mesh_distance.unwrap_or(b.rig_distance))
    });
    let mut bridge_figs = Vec::new();
    for b in best.into_iter().take(6) {
        let (m1, m2) = (models.require(&b.from)?, models.require(&b.to)?);
        let poses = meshes(rig, &[pose(m1, &b.x1), pose(m2, &b.x2)])?;
        let half = poses.len() / 2;
        let caption = format!("{} → {} (mesh distance {:.3})", b.from, b.to, b.mesh_distance.unwrap_or(f64::NAN));
        bridge_figs.push((caption, poses[..half].to_vec(), poses[half..].to_vec()));
    }
    let synth = curves::read(&args.curves)?;
    let filmstrip = match synth.script.first().cloned() {
        None => None,
        Some(name) => {
            let n = synth.controls.len();
            let rows: Vec<usize> =
                (0..synth.script.len()).filter(|&r| synth.script[r] == name).step_by(12).take(16).collect();
            let poses: Vec<Vec<f64>> = rows.iter().map(|&r| synth.values[r * n..(r + 1) * n].to_vec()).collect();
            let m = meshes(rig, &poses)?;
            let d = m.len() / poses.len().max(1);
            let frames = rows
                .iter()
                .enumerate()
                .map(|(i, &r)| (format!("{} · {:.1} s", synth.model[r], synth.time[r]), m[i * d..(i + 1) * d].to_vec()))
                .collect();
            Some((format!("Script `{name}`, every 12th frame (0.5 s), captioned with the model that made it."), frames))
        }
    };
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or("unknown".into(), |o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let pipeline = reprise_artifact::provenance::hash_file(std::path::Path::new("pipeline.toml"))
        .unwrap_or_else(|_| "no pipeline.toml beside the run".into());
    let mut prov = vec![
        ("stage".to_string(), format!("{} {}", provenance.stage, provenance.stage_version)),
        ("commit".to_string(), commit),
        ("pipeline.toml blake3".to_string(), pipeline),
        ("machine".to_string(), machine()),
    ];
    for (role, input) in &provenance.inputs {
        prov.push((
            format!("input {role}"),
            format!("{} (blake3 {})", input.path, &input.blake3[..16.min(input.blake3.len())]),
        ));
    }
    if let Some(lock) = args.lock.as_ref().and_then(|p| std::fs::read_to_string(p).ok()) {
        prov.extend(stage_times(&lock));
    }
    Ok(html::Page {
        name: &args.name,
        summary_md: md,
        latents,
        bridges: bridge_figs,
        filmstrip,
        triangles: rig.0.triangles(),
        camera_mesh,
        speed,
        labels,
        provenance: prov,
    })
}

/// CPU model and cores, from /proc/cpuinfo where there is one.
fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .unwrap_or("unknown")
        .trim()
        .to_string();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{model}, {cores} cores")
}

/// `seconds <stage>` lines from the runner's lock file (its stage entries' `seconds`).
fn stage_times(lock: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    for line in lock.lines() {
        let t = line.trim();
        if line.starts_with("    \"") && !line.starts_with("     ") && t.ends_with('{') {
            current = t.split('"').nth(1).map(str::to_string);
        }
        if let (Some(stage), Some(v)) = (&current, t.strip_prefix("\"seconds\":")) {
            out.push((format!("seconds {stage}"), v.trim().trim_end_matches(',').to_string()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(id: i64, from: &str, to: &str, ours: Option<i64>, theirs: Option<i64>) -> Request {
        let answer = |l: Option<i64>| Answer { latency: l, asked: 0, error: String::new() };
        Request {
            request: id,
            from: from.into(),
            to: to.into(),
            segment_id: 0,
            clip: "c".into(),
            frame: 0,
            reprise: answer(ours),
            baseline: answer(theirs),
        }
    }

    fn value(m: &[Metric], system: &str, name: &str, from: &str, to: &str) -> f64 {
        find(m, system, name, from, to).unwrap_or_else(|| panic!("no {system} {name} {from}→{to}")).value
    }

    /// Coverage is the share of a pair's requests answered within the horizon: a → b, reprise
    /// reaches 3 of 4 in time (one too late, at 30 > 24 frames), the baseline 2 (two
    /// unanswered); b → a the baseline wins, 2 of 2 against reprise's 0 (one too late, one
    /// unanswered).
    #[test]
    fn coverage_counts_the_requests_reached_in_time() {
        let reqs = vec![
            request(0, "a", "b", Some(10), Some(5)),
            request(1, "a", "b", Some(24), None),
            request(2, "a", "b", Some(30), Some(20)),
            request(3, "a", "b", Some(1), None),
            request(4, "b", "a", Some(25), Some(3)),
            request(5, "b", "a", None, Some(24)),
        ];
        let pairs = vec![("a".to_string(), "b".to_string()), ("b".to_string(), "a".to_string())];
        let m = coverage(&reqs, &pairs, 24);
        assert_eq!(value(&m, "reprise", "coverage", "a", "b"), 0.75);
        assert_eq!(value(&m, "baseline", "coverage", "a", "b"), 0.5);
        assert_eq!(value(&m, "reprise", "coverage", "b", "a"), 0.0);
        assert_eq!(value(&m, "baseline", "coverage", "b", "a"), 1.0);
        assert!((value(&m, "reprise", "coverage", "all", "all") - 0.5).abs() < 1e-12);
        assert!((value(&m, "baseline", "coverage", "all", "all") - 4.0 / 6.0).abs() < 1e-12);
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
            plausibility: vec![latency],
            speed: vec![],
        }
    }

    /// Paired differences use only the requests both answered, reprise minus baseline: here
    /// reprise is 0.5 s slower on each (it loses) and 1 lower in acceleration (it wins).
    #[test]
    fn paired_differences_on_common_requests() {
        let ours = vec![measured(0, 1.0, 1.0), measured(1, 2.0, 2.0), measured(2, 9.0, 9.0)];
        let theirs = vec![measured(0, 0.5, 2.0), measured(1, 1.5, 3.0), measured(3, 0.0, 0.0)];
        let m = paired(&ours, &theirs, &[("a".into(), "b".into())]);
        let lat = find(&m, "reprise-baseline", "paired_latency_s", "all", "all").unwrap();
        assert_eq!((lat.value, lat.n), (0.5, 2));
        assert!(lat.ci_low.unwrap() > 0.0, "reprise is slower on every common request");
        assert_eq!(value(&m, "reprise-baseline", "paired_peak_accel_ratio", "a", "b"), -1.0);
    }
}
