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
//! - `coverage`: the share of training frames of A from which a transition to B can start
//!   and reach B within `coverage_seconds`. Baseline: the graph's shortest path from the
//!   frame (0 outside the pruned graph). reprise: every frame, if the bridges connect A to
//!   B directly or through a third label and the route's fixed cost (per hop: reach plus
//!   hover, 18 frames at the defaults) fits.
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
use reprise_artifact::transitions::{self, Request};
use reprise_artifact::{bridges, motion_graph, scales, Columns, Kind, Table};
use reprise_metrics::{bootstrap_mean_ci, nearest_distance, peaks, quantile};
use reprise_motiongraph::Graph;
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
    from: String,
    to: String,
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
    let per_segment: Vec<StageResult<(Vec<f64>, Vec<f64>)>> = seg_runs
        .par_iter()
        .map(|&(s, e)| {
            let m = meshes(&rig, &rows[s..e])?;
            let (a, j) = peaks(&m, dim, fps);
            Ok((a[1..a.len().saturating_sub(1)].to_vec(), j[1..j.len().saturating_sub(2).max(1)].to_vec()))
        })
        .collect();
    let (mut tr_acc, mut tr_jerk) = (Vec::new(), Vec::new());
    for r in per_segment {
        let (a, j) = r?;
        tr_acc.extend(a);
        tr_jerk.extend(j);
    }
    let (acc95, jerk95) = (quantile(&tr_acc, 0.95), quantile(&tr_jerk, 0.95));
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
                Ok(Measured {
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
        }
    }

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
    let mut g = Graph::new(nodes.frame.len());
    for (i, e) in edges.iter().enumerate() {
        g.add(e.from as usize, e.to as usize, e.cost as u32, i);
    }
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
    let direct = |a: &str, b: &str| links.iter().any(|l| l.from == a && l.to == b);
    let hop_frames = ((0.5 + 0.25) * fps).round() as u32;
    // Baseline: per start frame, the fewest frames to each label (one Dijkstra per frame).
    let reach: Vec<Vec<u32>> = (0..nodes.frame.len())
        .into_par_iter()
        .map(|s| {
            labels
                .iter()
                .map(|b| {
                    if nodes.in_scc[s] {
                        g.shortest_to(s, &nodes.in_scc, |v| &nodes.label[v] == b).map_or(u32::MAX, |(c, _)| c)
                    } else {
                        u32::MAX
                    }
                })
                .collect()
        })
        .collect();
    for (ai, a) in labels.iter().enumerate() {
        let starts: Vec<usize> = (0..nodes.frame.len()).filter(|&r| &nodes.label[r] == a).collect();
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
            let hops = if direct(a, b) {
                Some(1)
            } else if labels.iter().any(|c| c != a && c != b && direct(a, c) && direct(c, b)) {
                Some(2)
            } else {
                None
            };
            let ours_cov = hops.map_or(0.0, |h| f64::from(u8::from(h * hop_frames <= horizon)));
            let theirs: Vec<f64> = starts.iter().map(|&s| f64::from(u8::from(reach[s][bi] <= horizon))).collect();
            out.push(exact("reprise", "coverage", a, b, ours_cov, starts.len(), "share"));
            out.push(exact(
                "baseline",
                "coverage",
                a,
                b,
                theirs.iter().sum::<f64>() / theirs.len().max(1) as f64,
                starts.len(),
                "share",
            ));
        }
    }
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
        acc95,
        jerk95,
        step,
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

#[allow(clippy::too_many_arguments)]
fn report(
    m: &[Metric],
    labels: &[String],
    acc95: f64,
    jerk95: f64,
    step: f64,
    args: &Args,
    scc: usize,
    frames: usize,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# reprise against Motion Graphs\n");
    let _ = writeln!(s, "## Overall (all label pairs; mean [95 % bootstrap CI])\n");
    let _ = writeln!(s, "| metric | reprise | Motion Graphs | better |\n|---|---|---|---|");
    let lower_better = ["peak_accel_ratio", "peak_jerk_ratio", "latency_s", "plausibility"];
    let mut wins = (Vec::new(), Vec::new());
    for name in ["answered", "latency_s", "peak_accel_ratio", "peak_jerk_ratio", "plausibility", "variety"] {
        let (a, b) = (find(m, "reprise", name, "all", "all"), find(m, "baseline", name, "all", "all"));
        let better = match (a, b) {
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
        let v: Vec<f64> = m.iter().filter(|x| x.system == sys && x.metric == "coverage").map(|x| x.value).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let pts = |sys: &str| {
        m.iter().filter(|x| x.system == sys && x.metric == "transition_points").map(|x| x.value).sum::<f64>()
    };
    let _ = writeln!(
        s,
        "| `coverage` (mean over pairs) | {:.3} | {:.3} | {} |",
        cov("reprise"),
        cov("baseline"),
        if cov("reprise") > cov("baseline") { "reprise" } else { "Motion Graphs" }
    );
    let _ = writeln!(s, "| `transition_points` (total) | {:.0} | {:.0} | – |\n", pts("reprise"), pts("baseline"));
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
        "- Motion Graphs plays training frames between transitions, so its poses are plausible by construction; reprise reaches \
         every label from every frame through its bridges, where the pruned graph cannot start from the frames it dropped.\n"
    );
    let _ = writeln!(
        s,
        "## Coverage within {} s (share of start frames; reprise / Motion Graphs)\n",
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
         (jerk) — max over vertices of the central second (third) difference of positions, × fps² (fps³) — from {h} frames \
         before the first frame of the target label to {e} after it, divided by the 95th percentile of the same per-frame \
         quantity over the training segments ({acc95:.4} and {jerk95:.4} mesh units/s² and /s³).\n\
         - `plausibility`: per synthesized frame (every {ps}-th), the distance in scaled control space to the nearest training \
         frame, divided by the median distance between consecutive training frames ({step:.4}).\n\
         - `answered`: share of requests answered; `latency_s`: seconds from the request to the first frame of the target label \
         (reprise holds 0.5 s before its TRANSITION; the baseline leaves at once).\n\
         - `variety`: per request, the mean over frames of the RMS vertex distance between reprise's answer and its answer \
         under another seed (the random force's); the baseline's graph search is deterministic, so its variety is 0.\n\
         - `coverage`: share of training frames of A from which B is reached within {cs} s (baseline: shortest path in the pruned \
         graph, 0 for pruned frames; reprise: 1 when the bridges connect A to B directly or through a third label within the \
         route's fixed cost of reach + hover per hop).\n\
         - `transition_points`: bridges A → B (reprise); transition edges from A to B in the pruned graph (Motion Graphs).\n\
         - `heldout_mesh_rmse`: RMS vertex error of held-out frames (GPLVM through its best latent point; PCA with q components \
         of the same training frames); `ablation_mesh_rmse`: RMS vertex error of 3-component PCA, scaled against unscaled controls.\n\
         - CIs: 95 % percentile bootstrap of the mean, 1000 resamples.",
        h = args.window / 2,
        e = args.window + args.window / 2,
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
