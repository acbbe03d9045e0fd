//! The motion-graph stage: the Motion Graphs baseline ([`reprise_transition_graph`]) on the
//! labeled frames. A frame's pose is its scaled control vector $z_c = \bar w_c p_c$ with
//! $\bar w_c$ the control's scale-stage weight averaged over the labels that use it (one
//! metric for the whole graph: mesh length per control unit); masked controls are absent.
//! Every ordered pair of segments (the same one included) is compared with window
//! $k$ = `window` frames (the synthesis blend length, default 12); local minima within
//! `rho` below the threshold become transitions; the graph is pruned to its largest
//! strongly connected component.

use clap::{Parser, ValueEnum};
use rayon::prelude::*;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::motion_graph::{self, Edge, Nodes};
use reprise_artifact::scales;
use reprise_stagekit::{StageError, StageResult};
use reprise_transition_graph::{largest_scc, local_minima, window_distances, Graph};
use serde::Serialize;

/// How transition candidates are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Threshold {
    /// The `--quantile` lowest of all local minima.
    Quantile,
    /// Windowed distance at most `--max-distance`.
    Absolute,
    /// Per ordered pair of labels (of the frames left and entered), the `--quantile`
    /// lowest of that pair's local minima, at least one — the per-pair rule of the bridges
    /// stage, for a baseline at its strongest: every pair with a local minimum gets a
    /// direct transition.
    PerPair,
}

reprise_stagekit::stage_io! {
    stage: "motion-graph", bin: "reprise-motion-graph",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the labeled frames.
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the scales.
        scales: required "scales.parquet",
    }
    outputs {
        /// Output: the nodes.
        nodes: artifact "mg_nodes.parquet",
        /// Output: the edges.
        edges: artifact "mg_edges.parquet",
    }
}

/// `reprise-motion-graph`: the Motion Graphs baseline.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-motion-graph", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Window and blend length k, frames.
    #[arg(long, default_value_t = 12)]
    pub window: usize,
    /// Local-minimum neighbourhood radius ρ.
    #[arg(long, default_value_t = 2)]
    pub rho: usize,
    /// Which threshold keeps a local minimum.
    #[arg(long, value_enum, default_value_t = Threshold::Quantile)]
    pub threshold: Threshold,
    /// With `quantile`: the share of local minima kept.
    #[arg(long, default_value_t = 0.1)]
    pub quantile: f64,
    /// With `absolute`: the largest windowed distance kept.
    #[arg(long)]
    pub max_distance: Option<f64>,
    /// Limit: the most windowed distances computed for one pair of motions (frames of A ×
    /// frames of B; 16 bytes of memory each, per thread). A labeling that leaves one very
    /// long segment would otherwise allocate without bound.
    #[arg(long, default_value_t = 25_000_000)]
    #[serde(skip)]
    pub max_pair_cells: usize,
}

/// The longest window accepted, frames (a transition's cost must fit the graph's costs).
pub const MAX_WINDOW: usize = 10_000;

/// What the stage built.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames (nodes).
    pub frames: usize,
    /// Frames in the largest SCC.
    pub frames_in_scc: usize,
    /// Local minima found, and kept as transitions.
    pub minima: usize,
    /// Transitions kept.
    pub transitions: usize,
    /// Per label: (label, frames, frames in the SCC).
    pub per_label: Vec<(String, usize, usize)>,
    /// The distance threshold used (with `per-pair`, the largest of the pairs').
    pub threshold: f64,
}

/// Refuses, before the distances are computed, labeled frames the graph cannot be built
/// from: no controls left (every one masked), or two motions whose distance surface would
/// have more than `--max-pair-cells` entries (naming the longest motion).
fn check_sizes(args: &Args, dim: usize, segs: &[(usize, usize)]) -> StageResult<()> {
    let file = args.io.labeled_frames.display();
    if dim == 0 {
        return Err(StageError::Input(format!(
            "{file}: no controls (all masked?): a motion graph compares poses by their controls"
        )));
    }
    let longest = segs.iter().map(|&(s, e)| (e - s, s)).max().unwrap_or((0, 0));
    if longest.0.saturating_mul(longest.0) > args.max_pair_cells {
        return Err(StageError::Input(format!(
            "{file}: row {}: a motion of {} frames makes {} windowed distances against itself, more than the limit \
             --max-pair-cells {}; split the segment (label a shorter range) or raise the limit",
            longest.1,
            longest.0,
            longest.0 as u128 * longest.0 as u128,
            args.max_pair_cells
        )));
    }
    Ok(())
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let bad_threshold = match args.threshold {
        Threshold::Quantile | Threshold::PerPair => !(args.quantile > 0.0 && args.quantile <= 1.0),
        Threshold::Absolute => !args.max_distance.is_some_and(|d| d >= 0.0),
    };
    if !(2..=MAX_WINDOW).contains(&args.window) || bad_threshold || args.max_pair_cells == 0 {
        return Err(StageError::Config(format!(
            "need 2 <= --window <= {MAX_WINDOW}, --max-pair-cells >= 1, and 0 < --quantile <= 1 (quantile) or \
             --max-distance >= 0 (absolute)"
        )));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let scale_rows = scales::read(&args.io.scales)?;
    reprise_artifact::provenance::check_made_from(&args.io.scales, &provenance)?;
    let controls = &labeled.frames.controls;
    let weight = scales::mean_weights(&scale_rows, &labeled.frames.controls);
    let dim = controls.len();
    let n = labeled.frames.rows();
    let segs = labeled.segment_runs();
    check_sizes(args, dim, &segs)?;
    let z: Vec<f64> = (0..n)
        .flat_map(|r| labeled.frames.row(r).iter().zip(&weight).map(|(p, w)| p * w).collect::<Vec<_>>())
        .collect();
    let k = args.window;
    let pairs: Vec<(usize, usize)> = (0..segs.len()).flat_map(|a| (0..segs.len()).map(move |b| (a, b))).collect();
    let bar = reprise_stagekit::progress(pairs.len() as u64, "motion-graph");
    // Local minima per segment pair: (from row A_i, to row B_{j+1}, D).
    let minima: Vec<(usize, usize, f64)> = pairs
        .par_iter()
        .flat_map_iter(|&(a, b)| {
            let ((sa, ea), (sb, eb)) = (segs[a], segs[b]);
            let d = window_distances(&z[sa * dim..ea * dim], &z[sb * dim..eb * dim], dim, k);
            let (na, nb) = (ea - sa, eb - sb);
            // Trivial self-transitions: the same segment, arriving within k of where the
            // windows coincide (j = i + k − 1).
            let same = a == b;
            let m = local_minima(&d, na, nb, args.rho, |i, j| same && (j as i64 - (i + k - 1) as i64).abs() < k as i64);
            bar.inc(1);
            m.into_iter().filter(move |&(_, j, _)| j + 1 < nb).map(move |(i, j, v)| (sa + i, sb + j + 1, v))
        })
        .collect();
    bar.finish_and_clear();
    // The `q` quantile of a set of distances (the ⌈q·n⌉-th smallest, at least the smallest).
    let quantile = |mut v: Vec<f64>| -> f64 {
        v.sort_by(f64::total_cmp);
        let idx = ((args.quantile * v.len() as f64).ceil() as usize).clamp(1, v.len().max(1)) - 1;
        v.get(idx).copied().unwrap_or(0.0)
    };
    let pair_of = |m: &(usize, usize, f64)| (labeled.label[m.0].as_str(), labeled.label[m.1].as_str());
    let limits: std::collections::HashMap<(&str, &str), f64> = match args.threshold {
        Threshold::PerPair => {
            let mut by_pair: std::collections::HashMap<(&str, &str), Vec<f64>> = std::collections::HashMap::new();
            for m in &minima {
                by_pair.entry(pair_of(m)).or_default().push(m.2);
            }
            by_pair.into_iter().map(|(k, v)| (k, quantile(v))).collect()
        }
        _ => Default::default(),
    };
    let threshold = match args.threshold {
        Threshold::Absolute => args.max_distance.unwrap_or(0.0),
        Threshold::Quantile => quantile(minima.iter().map(|m| m.2).collect()),
        Threshold::PerPair => limits.values().copied().fold(0.0, f64::max),
    };
    let kept = |m: &(usize, usize, f64)| match args.threshold {
        Threshold::PerPair => limits.get(&pair_of(m)).is_some_and(|&t| m.2 <= t),
        _ => m.2 <= threshold,
    };
    let mut edges: Vec<Edge> = Vec::new();
    let mut g = Graph::new(n);
    for &(s, e) in &segs {
        for r in s..e - 1 {
            g.add(r, r + 1, 1, edges.len());
            edges.push(Edge {
                from: r as i64,
                to: (r + 1) as i64,
                kind: "next".into(),
                cost: 1,
                distance: 0.0,
                in_scc: false,
            });
        }
    }
    let mut transitions = 0;
    for &(from, to, d) in minima.iter().filter(|m| kept(m)) {
        g.add(from, to, k as u32, edges.len());
        edges.push(Edge {
            from: from as i64,
            to: to as i64,
            kind: "transition".into(),
            cost: k as i64,
            distance: d,
            in_scc: false,
        });
        transitions += 1;
    }
    let alive = largest_scc(&g);
    edges.iter_mut().for_each(|e| e.in_scc = alive[e.from as usize] && alive[e.to as usize]);
    let nodes = Nodes {
        segment_id: labeled.segment_id.clone(),
        label: labeled.label.clone(),
        clip: labeled.frames.clip.clone(),
        frame: labeled.frames.frame.clone(),
        in_scc: alive.clone(),
    };
    let mut per_label: Vec<(String, usize, usize)> = Vec::new();
    for (label, &a) in labeled.label.iter().zip(&alive) {
        let i = match per_label.iter().position(|p| &p.0 == label) {
            Some(i) => i,
            None => {
                per_label.push((label.clone(), 0, 0));
                per_label.len() - 1
            }
        };
        per_label[i].1 += 1;
        per_label[i].2 += usize::from(a);
    }
    motion_graph::write_nodes(&args.io.nodes, &nodes, k, &provenance)?;
    motion_graph::write_edges(&args.io.edges, &edges, k, &provenance)?;
    Ok(Some(Summary {
        frames: n,
        frames_in_scc: alive.iter().filter(|a| **a).count(),
        minima: minima.len(),
        transitions,
        per_label,
        threshold,
    }))
}
