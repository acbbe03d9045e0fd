//! The motion-graph stage's artifacts.
//!
//! `mg_nodes` — one row per labeled frame (node id = row): `node`, `segment_id`, `label`,
//! `clip`, `frame`, `in_scc` (whether the frame survives pruning to the largest strongly
//! connected component).
//!
//! `mg_edges` — one row per edge: `edge`, `from`, `to` (node ids), `kind` (`next`: the
//! following frame of the same segment, cost 1; `transition`: a blended transition leaving
//! at `from` = $A_i$ and arriving at `to` = $B_{j+1}$, cost $k$ frames), `cost` (frames),
//! `distance` (the windowed rig-space distance $D(i,j)$; 0 for `next`), `in_scc`.
//!
//! Both tables record the window $k$ the graph was built with under [`KEY_WINDOW`]: a
//! stage that plays the graph's transitions must blend over the same $k$ frames.
//!
//! Reading the graph to play it: [`read_graph`] reads both tables and refuses a pair that
//! does not belong together ([`check_same_run`], [`check_edges`]), so every index in the
//! edges is a node; then [`MotionGraph::check_window`] and [`MotionGraph::check_frames`]
//! refuse a window or a labeled frame table other than the graph's.

use std::path::Path;

use crate::error::{ArtifactError, Result};
use crate::frames::{segment_runs, LabeledFrames};
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Metadata key of both tables: the window $k$ (frames) the graph was built with.
pub const KEY_WINDOW: &str = "reprise.mg_window";

/// Edge kind: the next frame of the same motion.
pub const NEXT: &str = "next";
/// Edge kind: a blended transition.
pub const TRANSITION: &str = "transition";

/// Kind of the nodes table.
pub const MG_NODES: Kind = Kind { name: "mg_nodes", version: 1 };
/// Kind of the edges table.
pub const MG_EDGES: Kind = Kind { name: "mg_edges", version: 1 };

/// The graph's nodes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Nodes {
    /// Segment per node.
    pub segment_id: Vec<i64>,
    /// Label per node.
    pub label: Vec<String>,
    /// Clip per node.
    pub clip: Vec<String>,
    /// Frame per node.
    pub frame: Vec<i64>,
    /// Survives pruning.
    pub in_scc: Vec<bool>,
}

/// One edge.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    /// From node.
    pub from: i64,
    /// To node.
    pub to: i64,
    /// `next` or `transition`.
    pub kind: String,
    /// Frames.
    pub cost: i64,
    /// Windowed distance (0 for `next`).
    pub distance: f64,
    /// Both ends survive pruning.
    pub in_scc: bool,
}

fn window_meta(window: usize) -> [(String, String); 1] {
    [(KEY_WINDOW.to_string(), window.to_string())]
}

/// Writes the nodes atomically, recording the graph's `window`.
pub fn write_nodes(path: &Path, n: &Nodes, window: usize, provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .i64("node", (0..n.frame.len() as i64).collect())
        .i64("segment_id", n.segment_id.clone())
        .str("label", &n.label)
        .str("clip", &n.clip)
        .i64("frame", n.frame.clone())
        .bool("in_scc", n.in_scc.clone());
    crate::table::write(path, MG_NODES, cols, provenance, &window_meta(window))
}

/// Reads the nodes (checking that `node` numbers the rows).
pub fn read_nodes(path: &Path) -> Result<Nodes> {
    let t = Table::read(path, MG_NODES)?;
    if t.i64("node")?.iter().enumerate().any(|(i, &v)| v != i as i64) {
        return Err(t.invalid("`node` must number the rows 0, 1, …"));
    }
    Ok(Nodes {
        segment_id: t.i64("segment_id")?.to_vec(),
        label: t.strings("label")?,
        clip: t.strings("clip")?,
        frame: t.i64("frame")?.to_vec(),
        in_scc: t.bool("in_scc")?,
    })
}

/// Writes the edges atomically, recording the graph's `window`.
pub fn write_edges(path: &Path, e: &[Edge], window: usize, provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .i64("edge", (0..e.len() as i64).collect())
        .i64("from", e.iter().map(|e| e.from).collect())
        .i64("to", e.iter().map(|e| e.to).collect())
        .str("kind", &e.iter().map(|e| e.kind.as_str()).collect::<Vec<_>>())
        .i64("cost", e.iter().map(|e| e.cost).collect())
        .f64("distance", e.iter().map(|e| e.distance).collect())
        .bool("in_scc", e.iter().map(|e| e.in_scc).collect());
    crate::table::write(path, MG_EDGES, cols, provenance, &window_meta(window))
}

/// Reads the edges.
pub fn read_edges(path: &Path) -> Result<Vec<Edge>> {
    let t = Table::read(path, MG_EDGES)?;
    let (from, to, kind, cost, dist, scc) =
        (t.i64("from")?, t.i64("to")?, t.str("kind")?, t.i64("cost")?, t.f64("distance")?, t.bool("in_scc")?);
    Ok((0..t.rows())
        .map(|r| Edge {
            from: from[r],
            to: to[r],
            kind: kind[r].into(),
            cost: cost[r],
            distance: dist[r],
            in_scc: scc[r],
        })
        .collect())
}

/// The window $k$ (frames) the motion graph in `path` (nodes or edges) was built with:
/// its [`KEY_WINDOW`] metadata, or for a graph written before that key, the `window`
/// parameter in its provenance.
pub fn window_of(path: &Path) -> Result<usize> {
    let meta = crate::table::metadata_of(path)?;
    let bad = |message: String| ArtifactError::Metadata { path: path.into(), key: KEY_WINDOW.into(), message };
    if let Some(v) = meta.get(KEY_WINDOW) {
        return v.parse().map_err(|_| bad(format!("`{v}` is not a window length in frames")));
    }
    let params = Provenance::from_metadata(path, &meta)?.params;
    params
        .get("window")
        .and_then(serde_json::Value::as_u64)
        .and_then(|w| usize::try_from(w).ok())
        .ok_or_else(|| bad("missing, and the provenance has no `window` parameter; rerun motion-graph".into()))
}

/// Refuses nodes and edges written by different motion-graph runs: both tables record
/// the run's parameters and input files, and the window, which must be equal
/// ([`crate::provenance::check_same_run`]).
pub fn check_same_run(nodes_path: &Path, edges_path: &Path) -> Result<()> {
    crate::provenance::check_same_run(nodes_path, edges_path, &[KEY_WINDOW])
}

fn mismatch(path: &Path, other: &Path, message: String) -> ArtifactError {
    ArtifactError::Mismatch { path: path.into(), other: other.into(), message }
}

/// Checks that `edges` (read from `edges_path`) are edges of `nodes` (from `nodes_path`)
/// built with `window` (`None`: not checked), so that playing them cannot index past
/// either table:
/// - every `from` and `to` is a node (`0 ≤ id < nodes`);
/// - the kind is `next` or `transition`; a `next` edge goes to the following frame of the
///   same motion (a run of one segment's consecutive frames) at cost 1;
/// - a transition costs `window` frames, its blend window on A (`from … from + k − 1`) and
///   on B (`to − k … to − 1`) lie inside one motion each;
/// - `in_scc` of an edge is that of both its ends.
///
/// The first violation is reported with the edge's row and both files.
pub fn check_edges(
    nodes: &Nodes,
    nodes_path: &Path,
    edges: &[Edge],
    edges_path: &Path,
    window: Option<usize>,
) -> Result<()> {
    let n = nodes.frame.len();
    if [nodes.segment_id.len(), nodes.label.len(), nodes.clip.len(), nodes.in_scc.len()].iter().any(|&l| l != n) {
        return Err(ArtifactError::Invalid { path: nodes_path.into(), message: "columns of unequal length".into() });
    }
    // The motion (run) of every node.
    let runs = segment_runs(&nodes.segment_id, &nodes.frame);
    let mut run_of = vec![0usize; n];
    for (i, &(s, e)) in runs.iter().enumerate() {
        run_of[s..e].iter_mut().for_each(|r| *r = i);
    }
    for (row, e) in edges.iter().enumerate() {
        let bad = |what: String| mismatch(edges_path, nodes_path, format!("edge row {row}: {what}"));
        let node = |id: i64| usize::try_from(id).ok().filter(|&i| i < n);
        let (Some(from), Some(to)) = (node(e.from), node(e.to)) else {
            return Err(bad(format!(
                "goes from node {} to node {}, but the nodes table has {n} nodes (0..{}); the edges come from another \
                 motion graph — rerun motion-graph",
                e.from,
                e.to,
                n.saturating_sub(1)
            )));
        };
        match e.kind.as_str() {
            NEXT if to != from + 1 || run_of[from] != run_of[to] || e.cost != 1 => {
                return Err(bad(format!(
                    "a `next` edge must go to the following frame of the same motion at cost 1; this one goes from \
                     node {from} to {to} at cost {}",
                    e.cost
                )));
            }
            NEXT => {}
            TRANSITION => {
                let k = window.unwrap_or(e.cost.max(1) as usize);
                let (ra, rb) = (runs[run_of[from]], runs[run_of[to]]);
                if window.is_some_and(|w| e.cost != w as i64)
                    || from.saturating_add(k) > ra.1
                    || to < rb.0.saturating_add(k)
                {
                    return Err(bad(format!(
                        "a transition from node {from} to {to} costing {} frames does not fit a blend window of {k} \
                         frames inside its motions (rows {}..{} and {}..{})",
                        e.cost, ra.0, ra.1, rb.0, rb.1
                    )));
                }
            }
            other => return Err(bad(format!("kind `{other}` is neither `{NEXT}` nor `{TRANSITION}`"))),
        }
        if e.in_scc != (nodes.in_scc[from] && nodes.in_scc[to]) {
            return Err(bad(format!(
                "`in_scc` is {} but its nodes {from} and {to} say {} and {}; the tables come from different runs",
                e.in_scc, nodes.in_scc[from], nodes.in_scc[to]
            )));
        }
    }
    Ok(())
}

/// A motion graph read for playing: nodes and edges that belong together.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionGraph {
    /// The nodes.
    pub nodes: Nodes,
    /// The edges; every `from`/`to` is a node ([`check_edges`]).
    pub edges: Vec<Edge>,
    /// The window $k$ it was built with (frames).
    pub window: usize,
    /// Where the nodes came from (for messages).
    pub nodes_path: std::path::PathBuf,
    /// Where the edges came from.
    pub edges_path: std::path::PathBuf,
}

/// Reads the nodes and edges and checks that they belong together: the same run
/// ([`check_same_run`]), the same window, and edges that index these nodes with
/// transitions that fit the window ([`check_edges`]). After this, `from`/`to` can be
/// used as indices.
pub fn read_graph(nodes_path: &Path, edges_path: &Path) -> Result<MotionGraph> {
    let nodes = read_nodes(nodes_path)?;
    let edges = read_edges(edges_path)?;
    check_same_run(nodes_path, edges_path)?;
    let window = window_of(nodes_path)?;
    check_edges(&nodes, nodes_path, &edges, edges_path, Some(window))?;
    Ok(MotionGraph { nodes, edges, window, nodes_path: nodes_path.into(), edges_path: edges_path.into() })
}

impl MotionGraph {
    /// Refuses a blend length other than the graph's: `window` is what the caller was
    /// given (`given_by` names it for the message, e.g. "--window"). A different one
    /// would blend other frames than the graph measured (and, larger than a motion, index
    /// before it).
    pub fn check_window(&self, window: usize, given_by: &str) -> Result<()> {
        if window == self.window {
            return Ok(());
        }
        Err(ArtifactError::Invalid {
            path: self.nodes_path.clone(),
            message: format!(
                "the motion graph was built with window {} frames, but {given_by} is {window}; give {given_by} {} or \
                 rebuild the motion graph with window {window}",
                self.window, self.window
            ),
        })
    }

    /// Refuses labeled frames (read from `path`) other than the ones the graph's nodes
    /// are: the same number of rows, and per row the same segment, label, clip and frame.
    pub fn check_frames(&self, labeled: &LabeledFrames, path: &Path) -> Result<()> {
        let n = &self.nodes;
        let rows = labeled.frames.rows();
        let differs = (0..rows.min(n.frame.len())).find(|&r| {
            n.segment_id[r] != labeled.segment_id[r]
                || n.label[r] != labeled.label[r]
                || n.clip[r] != labeled.frames.clip[r]
                || n.frame[r] != labeled.frames.frame[r]
        });
        let message = match differs {
            _ if rows != n.frame.len() => format!("{} nodes but {rows} labeled frames", n.frame.len()),
            Some(r) => format!(
                "node {r} is clip `{}` frame {} (label `{}`), but labeled frame row {r} is clip `{}` frame {} (label `{}`)",
                n.clip[r], n.frame[r], n.label[r], labeled.frames.clip[r], labeled.frames.frame[r], labeled.label[r]
            ),
            None => return Ok(()),
        };
        Err(mismatch(
            &self.nodes_path,
            path,
            format!("{message}; the motion graph was built from other labeled frames — rerun motion-graph"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two motions of 4 frames (segments 0 and 1), a transition from node 0 (A_0) to node
    /// 6 (B_2) with window 2, the `next` edges; all in the SCC.
    fn graph() -> (Nodes, Vec<Edge>) {
        let nodes = Nodes {
            segment_id: vec![0, 0, 0, 0, 1, 1, 1, 1],
            label: vec!["a".into(), "a".into(), "a".into(), "a".into(), "b".into(), "b".into(), "b".into(), "b".into()],
            clip: vec!["c".into(); 8],
            frame: vec![0, 1, 2, 3, 10, 11, 12, 13],
            in_scc: vec![true; 8],
        };
        let mut edges: Vec<Edge> = [0, 1, 2, 4, 5, 6]
            .iter()
            .map(|&f| Edge { from: f, to: f + 1, kind: NEXT.into(), cost: 1, distance: 0.0, in_scc: true })
            .collect();
        edges.push(Edge { from: 0, to: 6, kind: TRANSITION.into(), cost: 2, distance: 0.5, in_scc: true });
        (nodes, edges)
    }

    fn write(
        dir: &Path,
        nodes: &Nodes,
        edges: &[Edge],
        window: usize,
        seed: u64,
    ) -> (std::path::PathBuf, std::path::PathBuf) {
        let prov = Provenance::new("motion-graph", "0", serde_json::json!({ "window": window, "seed": seed }));
        let (n, e) = (dir.join(format!("n{seed}.parquet")), dir.join(format!("e{seed}.parquet")));
        write_nodes(&n, nodes, window, &prov).unwrap();
        write_edges(&e, edges, window, &prov).unwrap();
        (n, e)
    }

    /// Nodes and edges come back as written, with the window.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let (nodes, edges) = graph();
        let (n, e) = write(dir.path(), &nodes, &edges, 2, 0);
        assert_eq!(read_nodes(&n).unwrap(), nodes);
        assert_eq!(read_edges(&e).unwrap(), edges);
        let g = read_graph(&n, &e).unwrap();
        assert_eq!((g.window, window_of(&e).unwrap()), (2, 2));
        g.check_window(2, "--window").unwrap();
    }

    /// Catalogue: `mg_edges` from another labeling (an index past the nodes) is refused
    /// naming both files, instead of a panic in the stage that indexes with it.
    #[test]
    fn edges_of_another_graph_are_refused() {
        let (nodes, mut edges) = graph();
        edges[6].to = 5000;
        let e = check_edges(&nodes, Path::new("mg_nodes.parquet"), &edges, Path::new("mg_edges.parquet"), Some(2))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("mg_edges.parquet and mg_nodes.parquet do not belong together: edge row 6:"), "{e}");
        assert!(e.contains("node 5000") && e.contains("has 8 nodes"), "{e}");
        edges[6].to = -1;
        assert!(check_edges(&nodes, Path::new("n"), &edges, Path::new("e"), None).is_err());
    }

    /// Catalogue: a transition whose blend window leaves its motion, a wrong cost, a `next`
    /// edge that skips, an unknown kind, an `in_scc` that disagrees — each refused.
    #[test]
    fn edges_that_do_not_fit_their_nodes_are_refused() {
        let (nodes, good) = graph();
        let check = |edges: &[Edge], w| {
            check_edges(&nodes, Path::new("n"), edges, Path::new("e"), w).map_err(|e| e.to_string())
        };
        check(&good, Some(2)).unwrap();
        type Case<'a> = (&'a dyn Fn(&mut Vec<Edge>), Option<usize>, &'a str);
        let cases: [Case; 6] = [
            (&|e| e[6].from = 3, Some(2), "does not fit a blend window of 2"),
            (&|e| e[6].to = 5, Some(2), "does not fit a blend window of 2"),
            (&|_| {}, Some(3), "costing 2 frames does not fit a blend window of 3"),
            (&|e| e[0].to = 2, None, "a `next` edge must go to the following frame"),
            (&|e| e[2].to = 4, None, "a `next` edge must go to the following frame"),
            (&|e| e[1].kind = "jump".into(), None, "kind `jump`"),
        ];
        for (edit, w, needle) in cases {
            let mut e = good.clone();
            edit(&mut e);
            let msg = check(&e, w).unwrap_err();
            assert!(msg.contains(needle), "{needle}: {msg}");
        }
        let mut e = good.clone();
        e[3].in_scc = false;
        assert!(check(&e, None).unwrap_err().contains("`in_scc` is false"));
    }

    /// Catalogue: nodes of one run and edges of another are refused even when the indices
    /// happen to fit.
    #[test]
    fn tables_of_two_runs_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (nodes, edges) = graph();
        let (n0, _) = write(dir.path(), &nodes, &edges, 2, 0);
        let (_, e1) = write(dir.path(), &nodes, &edges, 2, 1);
        let e = read_graph(&n0, &e1).unwrap_err().to_string();
        assert!(
            e.contains("n0.parquet and ")
                && e.contains("e1.parquet do not belong together")
                && e.contains("written by different runs")
                && e.contains("rerun `motion-graph`"),
            "{e}"
        );
    }

    /// Catalogue: `--window 24` against a graph built with 2 (was: wrong blends, or an
    /// underflow panic for a window longer than a motion).
    #[test]
    fn another_window_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (nodes, edges) = graph();
        let (n, e) = write(dir.path(), &nodes, &edges, 2, 0);
        let g = read_graph(&n, &e).unwrap();
        let msg = g.check_window(24, "--window").unwrap_err().to_string();
        assert!(
            msg.contains("n0.parquet: the motion graph was built with window 2 frames, but --window is 24"),
            "{msg}"
        );
        assert!(g.check_window(400, "--window").is_err());
    }

    /// Catalogue: labeled frames other than the graph's are refused, naming the first row.
    #[test]
    fn other_labeled_frames_are_refused() {
        use crate::frames::Frames;
        let dir = tempfile::tempdir().unwrap();
        let (nodes, edges) = graph();
        let (n, e) = write(dir.path(), &nodes, &edges, 2, 0);
        let g = read_graph(&n, &e).unwrap();
        let mut lf = LabeledFrames {
            segment_id: nodes.segment_id.clone(),
            label: nodes.label.clone(),
            frames: Frames {
                fps: 24.0,
                controls: vec!["x".into()],
                clip: nodes.clip.clone(),
                frame: nodes.frame.clone(),
                time: vec![0.0; 8],
                values: vec![0.0; 8],
            },
            masked_controls: vec![],
        };
        g.check_frames(&lf, Path::new("lf.parquet")).unwrap();
        lf.label[5] = "c".into();
        let msg = g.check_frames(&lf, Path::new("lf.parquet")).unwrap_err().to_string();
        assert!(
            msg.contains("and lf.parquet do not belong together: node 5 is clip `c` frame 11 (label `b`)"),
            "{msg}"
        );
        lf.segment_id.pop();
        lf.label.pop();
        lf.frames.clip.pop();
        lf.frames.frame.pop();
        lf.frames.time.pop();
        lf.frames.values.pop();
        let msg = g.check_frames(&lf, Path::new("lf.parquet")).unwrap_err().to_string();
        assert!(msg.contains("8 nodes but 7 labeled frames"), "{msg}");
    }

    /// A graph written before the window key: the window comes from its provenance.
    #[test]
    fn window_from_provenance_of_older_graphs() {
        let dir = tempfile::tempdir().unwrap();
        let (nodes, _) = graph();
        let path = dir.path().join("old.parquet");
        let prov = Provenance::new("motion-graph", "0", serde_json::json!({ "window": 12 }));
        let cols = Columns::new().i64("node", (0..8).collect()).i64("segment_id", nodes.segment_id.clone());
        crate::table::write(&path, MG_NODES, cols, &prov, &[]).unwrap();
        assert_eq!(window_of(&path).unwrap(), 12);
    }
}
