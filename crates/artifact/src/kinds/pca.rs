//! The PCA stage's artifacts: models, coordinates and reconstruction errors.
//!
//! `pca_models` — one row per (label, variant, component); the row with `component = -1`
//! holds the mean:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `label` | Utf8 | label |
//! | `variant` | Utf8 | `scaled` (the model later stages use) or `unscaled` (ablation) |
//! | `component` | Int64 | 0, 1, … kept components; −1 = the mean row |
//! | `singular_value` | Float64 | $\sigma_i$ (0 on the mean row) |
//! | `explained` | Float64 | $\sigma_i^2/\lVert\tilde Z\rVert_F^2$ |
//! | `cumulative` | Float64 | $v(i+1)$ |
//! | *one per control* | Float64 | the unit direction's loading (0 for controls not used), or the mean |
//!
//! `pca_coords` — one row per (label, variant, frame): `label`, `variant`, `segment_id`,
//! `clip`, `frame`, then `y0, y1, …` up to the largest kept dimension (null beyond the
//! label's own `d`).
//!
//! `pca_errors` — reconstruction error per (label, variant, d): `label`, `variant`, `d`,
//! `which` (`chosen` by the variance threshold, or `fixed`), `explained` at d,
//! `rig_rmse` (RMS over frames and used controls of $p - \hat p$, control units), and
//! `mesh_rmse` (RMS over frames and vertices of $\lVert e(p) - e(\hat p)\rVert$, mesh units;
//! null without a rig).

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the PCA models table.
pub const PCA_MODELS: Kind = Kind { name: "pca_models", version: 1 };
/// Kind of the PCA coordinates table.
pub const PCA_COORDS: Kind = Kind { name: "pca_coords", version: 1 };
/// Kind of the PCA errors table.
pub const PCA_ERRORS: Kind = Kind { name: "pca_errors", version: 1 };
/// The variant later stages model.
pub const SCALED: &str = "scaled";
/// The ablation variant.
pub const UNSCALED: &str = "unscaled";

/// One label's PCA in one variant.
#[derive(Debug, Clone, PartialEq)]
pub struct PcaModel {
    /// Label.
    pub label: String,
    /// `scaled` or `unscaled`.
    pub variant: String,
    /// Mean per control (all controls of the table).
    pub mean: Vec<f64>,
    /// Kept unit directions, row-major `d × controls`.
    pub directions: Vec<f64>,
    /// Kept singular values.
    pub singular_values: Vec<f64>,
    /// Explained share per kept component.
    pub explained: Vec<f64>,
}

impl PcaModel {
    /// Number of kept components.
    pub fn d(&self) -> usize {
        self.singular_values.len()
    }
}

/// Writes the models (all with the same `controls`) atomically.
pub fn write_models(path: &Path, controls: &[String], models: &[PcaModel], provenance: &Provenance) -> Result<()> {
    let (mut label, mut variant, mut component, mut sv, mut ex, mut cum) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); controls.len()];
    for m in models {
        let mut acc = 0.0;
        for k in -1..m.d() as i64 {
            label.push(m.label.clone());
            variant.push(m.variant.clone());
            component.push(k);
            let row = if k < 0 { &m.mean[..] } else { &m.directions[k as usize * controls.len()..][..controls.len()] };
            let (s, e) = if k < 0 { (0.0, 0.0) } else { (m.singular_values[k as usize], m.explained[k as usize]) };
            acc += e;
            sv.push(s);
            ex.push(e);
            cum.push(acc);
            columns.iter_mut().zip(row).for_each(|(c, v)| c.push(*v));
        }
    }
    let mut cols = Columns::new()
        .str("label", &label)
        .str("variant", &variant)
        .i64("component", component)
        .f64("singular_value", sv)
        .f64("explained", ex)
        .f64("cumulative", cum);
    for (name, values) in controls.iter().zip(columns) {
        cols = cols.f64(name, values);
    }
    crate::table::write(path, PCA_MODELS, cols, provenance, &[])
}

/// Reads the models and their control names.
pub fn read_models(path: &Path) -> Result<(Vec<String>, Vec<PcaModel>)> {
    let t = Table::read(path, PCA_MODELS)?;
    let fixed = ["label", "variant", "component", "singular_value", "explained", "cumulative"];
    let controls: Vec<String> = t.column_names().into_iter().filter(|c| !fixed.contains(&c.as_str())).collect();
    let (label, variant, component) = (t.str("label")?, t.str("variant")?, t.i64("component")?);
    let (sv, ex) = (t.f64("singular_value")?, t.f64("explained")?);
    let values = controls.iter().map(|c| t.f64(c)).collect::<Result<Vec<_>>>()?;
    let mut models: Vec<PcaModel> = Vec::new();
    for r in 0..t.rows() {
        let row = values.iter().map(|col| col[r]);
        if component[r] < 0 {
            models.push(PcaModel {
                label: label[r].into(),
                variant: variant[r].into(),
                mean: row.collect(),
                directions: vec![],
                singular_values: vec![],
                explained: vec![],
            });
            continue;
        }
        let m = models
            .last_mut()
            .filter(|m| m.label == label[r] && m.variant == variant[r] && m.d() as i64 == component[r])
            .ok_or_else(|| t.invalid(format!("row {r}: component {} does not follow its mean row", component[r])))?;
        m.directions.extend(row);
        m.singular_values.push(sv[r]);
        m.explained.push(ex[r]);
    }
    Ok((controls, models))
}

/// Per-frame PCA coordinates.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PcaCoords {
    /// Label per row.
    pub label: Vec<String>,
    /// Variant per row.
    pub variant: Vec<String>,
    /// Segment per row.
    pub segment_id: Vec<i64>,
    /// Clip per row.
    pub clip: Vec<String>,
    /// Frame per row.
    pub frame: Vec<i64>,
    /// Coordinates per row (length = that label's d).
    pub y: Vec<Vec<f64>>,
}

/// Writes coordinates atomically.
pub fn write_coords(path: &Path, c: &PcaCoords, provenance: &Provenance) -> Result<()> {
    let width = c.y.iter().map(Vec::len).max().unwrap_or(0);
    let mut cols = Columns::new()
        .str("label", &c.label)
        .str("variant", &c.variant)
        .i64("segment_id", c.segment_id.clone())
        .str("clip", &c.clip)
        .i64("frame", c.frame.clone());
    for k in 0..width {
        cols = cols.f64_opt(&format!("y{k}"), c.y.iter().map(|y| y.get(k).copied()).collect());
    }
    crate::table::write(path, PCA_COORDS, cols, provenance, &[])
}

/// Reads coordinates (each row's `y` stops at its first null).
pub fn read_coords(path: &Path) -> Result<PcaCoords> {
    let t = Table::read(path, PCA_COORDS)?;
    let ys = (0..)
        .map(|k| format!("y{k}"))
        .take_while(|n| t.has_column(n))
        .map(|n| t.f64_opt(&n))
        .collect::<Result<Vec<_>>>()?;
    Ok(PcaCoords {
        label: t.str("label")?.into_iter().map(String::from).collect(),
        variant: t.str("variant")?.into_iter().map(String::from).collect(),
        segment_id: t.i64("segment_id")?.to_vec(),
        clip: t.str("clip")?.into_iter().map(String::from).collect(),
        frame: t.i64("frame")?.to_vec(),
        y: (0..t.rows()).map(|r| ys.iter().map_while(|col| col[r]).collect()).collect(),
    })
}

/// One reconstruction-error measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct PcaError {
    /// Label.
    pub label: String,
    /// Variant.
    pub variant: String,
    /// Components used.
    pub d: i64,
    /// `chosen` or `fixed`.
    pub which: String,
    /// Explained share at d.
    pub explained: f64,
    /// Rig-space RMS error.
    pub rig_rmse: f64,
    /// Mesh-space RMS vertex error (None without a rig).
    pub mesh_rmse: Option<f64>,
}

/// Writes the errors table atomically.
pub fn write_errors(path: &Path, rows: &[PcaError], provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .str("label", &rows.iter().map(|r| r.label.as_str()).collect::<Vec<_>>())
        .str("variant", &rows.iter().map(|r| r.variant.as_str()).collect::<Vec<_>>())
        .i64("d", rows.iter().map(|r| r.d).collect())
        .str("which", &rows.iter().map(|r| r.which.as_str()).collect::<Vec<_>>())
        .f64("explained", rows.iter().map(|r| r.explained).collect())
        .f64("rig_rmse", rows.iter().map(|r| r.rig_rmse).collect())
        .f64_opt("mesh_rmse", rows.iter().map(|r| r.mesh_rmse).collect());
    crate::table::write(path, PCA_ERRORS, cols, provenance, &[])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prov() -> Provenance {
        Provenance::new("test", "0", serde_json::json!({}))
    }

    /// Models of different dimension, and coordinates whose rows stop at their own d,
    /// come back as written.
    #[test]
    fn models_and_coords_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let controls: Vec<String> = ["a", "b", "c"].map(String::from).to_vec();
        let m = |label: &str, d: usize| PcaModel {
            label: label.into(),
            variant: SCALED.into(),
            mean: vec![1.0, 2.0, 3.0],
            directions: (0..d * 3).map(|i| i as f64 / 10.0).collect(),
            singular_values: (0..d).map(|i| 5.0 - i as f64).collect(),
            explained: (0..d).map(|i| 0.5 / (i + 1) as f64).collect(),
        };
        let models = vec![m("x", 2), m("y", 1)];
        let path = dir.path().join("m.parquet");
        write_models(&path, &controls, &models, &prov()).unwrap();
        assert_eq!(read_models(&path).unwrap(), (controls, models));
        let coords = PcaCoords {
            label: vec!["x".into(), "y".into()],
            variant: vec![SCALED.into(), SCALED.into()],
            segment_id: vec![0, 1],
            clip: vec!["c0".into(), "c1".into()],
            frame: vec![0, 0],
            y: vec![vec![0.5, -0.5], vec![1.5]],
        };
        let path = dir.path().join("c.parquet");
        write_coords(&path, &coords, &prov()).unwrap();
        assert_eq!(read_coords(&path).unwrap(), coords);
    }
}
