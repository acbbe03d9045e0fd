//! `bridges` — matching latent points between two label models (Bailey et al. 2016 §5.2):
//! one row per kept bridge.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `from`, `to` | Utf8 | the ordered pair of labels M1 → M2 |
//! | `from_point` | Int64 | the training point of M1 the bridge starts at (row of its model) |
//! | `x1_0…` | Float64 | that latent point in M1 |
//! | `x2_0…` | Float64 | the matching latent point in M2 |
//! | `rig_distance` | Float64 | $\lVert W_2(g_1(x_1) - g_2(x_2))\rVert$, M2's scaled control space (mesh length) |
//! | `mesh_distance` | Float64 | RMS vertex distance of the two poses (null without a rig) |
//! | `rank` | Int64 | 1 = the closest bridge of its pair |

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the bridges table.
pub const BRIDGES: Kind = Kind { name: "bridges", version: 1 };

/// One bridge.
#[derive(Debug, Clone, PartialEq)]
pub struct Bridge {
    /// M1.
    pub from: String,
    /// M2.
    pub to: String,
    /// M1's training point.
    pub from_point: i64,
    /// Latent point in M1.
    pub x1: Vec<f64>,
    /// Latent point in M2.
    pub x2: Vec<f64>,
    /// Scaled rig distance.
    pub rig_distance: f64,
    /// RMS vertex distance.
    pub mesh_distance: Option<f64>,
    /// 1 = closest in its pair.
    pub rank: i64,
}

/// Writes the bridges atomically (all latents of one dimension q).
pub fn write(path: &Path, bridges: &[Bridge], q: usize, provenance: &Provenance) -> Result<()> {
    let b = bridges;
    let mut cols = Columns::new()
        .str("from", &b.iter().map(|b| b.from.as_str()).collect::<Vec<_>>())
        .str("to", &b.iter().map(|b| b.to.as_str()).collect::<Vec<_>>())
        .i64("from_point", b.iter().map(|b| b.from_point).collect());
    for k in 0..q {
        cols = cols.f64(&format!("x1_{k}"), b.iter().map(|b| b.x1[k]).collect());
    }
    for k in 0..q {
        cols = cols.f64(&format!("x2_{k}"), b.iter().map(|b| b.x2[k]).collect());
    }
    let cols = cols
        .f64("rig_distance", b.iter().map(|b| b.rig_distance).collect())
        .f64_opt("mesh_distance", b.iter().map(|b| b.mesh_distance).collect())
        .i64("rank", b.iter().map(|b| b.rank).collect());
    crate::table::write(path, BRIDGES, cols, provenance, &[])
}

/// Reads the bridges.
pub fn read(path: &Path) -> Result<Vec<Bridge>> {
    let t = Table::read(path, BRIDGES)?;
    let names = |p: &str| -> Vec<String> { (0..).map(|k| format!("{p}{k}")).take_while(|n| t.has_column(n)).collect() };
    let (n1, n2) = (names("x1_"), names("x2_"));
    if n1.is_empty() || n1.len() != n2.len() {
        return Err(t.invalid(format!("{} x1_ and {} x2_ columns; expected the same q ≥ 1", n1.len(), n2.len())));
    }
    let x1 = n1.iter().map(|n| t.f64(n)).collect::<Result<Vec<_>>>()?;
    let x2 = n2.iter().map(|n| t.f64(n)).collect::<Result<Vec<_>>>()?;
    let (from, to, fp) = (t.str("from")?, t.str("to")?, t.i64("from_point")?);
    let (rig, mesh, rank) = (t.f64("rig_distance")?, t.f64_opt("mesh_distance")?, t.i64("rank")?);
    Ok((0..t.rows())
        .map(|r| Bridge {
            from: from[r].into(),
            to: to[r].into(),
            from_point: fp[r],
            x1: x1.iter().map(|c| c[r]).collect(),
            x2: x2.iter().map(|c| c[r]).collect(),
            rig_distance: rig[r],
            mesh_distance: mesh[r],
            rank: rank[r],
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bridges come back as written.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let b = Bridge {
            from: "a".into(),
            to: "b".into(),
            from_point: 4,
            x1: vec![0.1, 0.2],
            x2: vec![-1.0, 2.0],
            rig_distance: 0.5,
            mesh_distance: None,
            rank: 1,
        };
        let path = dir.path().join("b.parquet");
        let rows = vec![b.clone(), Bridge { mesh_distance: Some(0.25), rank: 2, ..b }];
        write(&path, &rows, 2, &Provenance::new("t", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read(&path).unwrap(), rows);
    }
}
