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

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

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

/// Writes the nodes atomically.
pub fn write_nodes(path: &Path, n: &Nodes, provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .i64("node", (0..n.frame.len() as i64).collect())
        .i64("segment_id", n.segment_id.clone())
        .str("label", &n.label)
        .str("clip", &n.clip)
        .i64("frame", n.frame.clone())
        .bool("in_scc", n.in_scc.clone());
    crate::table::write(path, MG_NODES, cols, provenance, &[])
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

/// Writes the edges atomically.
pub fn write_edges(path: &Path, e: &[Edge], provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .i64("edge", (0..e.len() as i64).collect())
        .i64("from", e.iter().map(|e| e.from).collect())
        .i64("to", e.iter().map(|e| e.to).collect())
        .str("kind", &e.iter().map(|e| e.kind.as_str()).collect::<Vec<_>>())
        .i64("cost", e.iter().map(|e| e.cost).collect())
        .f64("distance", e.iter().map(|e| e.distance).collect())
        .bool("in_scc", e.iter().map(|e| e.in_scc).collect());
    crate::table::write(path, MG_EDGES, cols, provenance, &[])
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Nodes and edges come back as written.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let prov = Provenance::new("t", "0", serde_json::json!({}));
        let nodes = Nodes {
            segment_id: vec![0, 0],
            label: vec!["a".into(), "a".into()],
            clip: vec!["c".into(), "c".into()],
            frame: vec![0, 1],
            in_scc: vec![true, false],
        };
        let edges = vec![Edge { from: 0, to: 1, kind: "next".into(), cost: 1, distance: 0.0, in_scc: false }];
        write_nodes(&dir.path().join("n.parquet"), &nodes, &prov).unwrap();
        write_edges(&dir.path().join("e.parquet"), &edges, &prov).unwrap();
        assert_eq!(read_nodes(&dir.path().join("n.parquet")).unwrap(), nodes);
        assert_eq!(read_edges(&dir.path().join("e.parquet")).unwrap(), edges);
    }
}
