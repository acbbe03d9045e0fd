//! `scales`: per label and per control, the scaling weight of Bailey et al. Eq. 3.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `label` | Utf8 | label |
//! | `control` | Utf8 | control name |
//! | `mean` | Float64 | the control's mean over the label's frames ($\bar p_i$) |
//! | `std` | Float64 | its sample standard deviation ($\sigma_i$) |
//! | `weight` | Float64 | $w_i$, mesh length per control unit (0 when not used) |
//! | `residual` | Float64 | RMS residual of the 1-D fit, mesh length units |
//! | `used` | Boolean | whether the control enters the label's PCA |
//! | `reason` | Utf8 | why not: `constant` (zero variance), `no-effect` (moves no vertex); empty when used |
//!
//! Scaled controls are $z_i = w_i (p_i - \bar p_i) + \bar p_i$.

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the scales table.
pub const SCALES: Kind = Kind { name: "scales", version: 1 };

/// One (label, control) row.
#[derive(Debug, Clone, PartialEq)]
pub struct Scale {
    /// Label.
    pub label: String,
    /// Control.
    pub control: String,
    /// Mean.
    pub mean: f64,
    /// Standard deviation.
    pub std: f64,
    /// Weight.
    pub weight: f64,
    /// Fit residual.
    pub residual: f64,
    /// Used in PCA.
    pub used: bool,
    /// Why not used.
    pub reason: String,
}

/// Writes the scales table atomically.
pub fn write(path: &Path, rows: &[Scale], provenance: &Provenance) -> Result<()> {
    let strs = |f: fn(&Scale) -> &str| rows.iter().map(f).collect::<Vec<_>>();
    let nums = |f: fn(&Scale) -> f64| rows.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .str("label", &strs(|s| &s.label))
        .str("control", &strs(|s| &s.control))
        .f64("mean", nums(|s| s.mean))
        .f64("std", nums(|s| s.std))
        .f64("weight", nums(|s| s.weight))
        .f64("residual", nums(|s| s.residual))
        .bool("used", rows.iter().map(|s| s.used).collect())
        .str("reason", &strs(|s| &s.reason));
    crate::table::write(path, SCALES, cols, provenance, &[])
}

/// Per control of `controls`, its weight averaged over the labels that use it (0 where
/// none does): one metric for comparing frames across labels.
pub fn mean_weights(rows: &[Scale], controls: &[String]) -> Vec<f64> {
    controls
        .iter()
        .map(|c| {
            let used: Vec<f64> = rows.iter().filter(|s| &s.control == c && s.used).map(|s| s.weight).collect();
            if used.is_empty() {
                0.0
            } else {
                used.iter().sum::<f64>() / used.len() as f64
            }
        })
        .collect()
}

/// Reads a scales table.
pub fn read(path: &Path) -> Result<Vec<Scale>> {
    let t = Table::read(path, SCALES)?;
    let (label, control, reason) = (t.str("label")?, t.str("control")?, t.str("reason")?);
    let (mean, std, weight, residual, used) =
        (t.f64("mean")?, t.f64("std")?, t.f64("weight")?, t.f64("residual")?, t.bool("used")?);
    Ok((0..t.rows())
        .map(|i| Scale {
            label: label[i].into(),
            control: control[i].into(),
            mean: mean[i],
            std: std[i],
            weight: weight[i],
            residual: residual[i],
            used: used[i],
            reason: reason[i].into(),
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.parquet");
        let rows = vec![
            Scale {
                label: "happy".into(),
                control: "jaw_open".into(),
                mean: 0.2,
                std: 0.1,
                weight: 3.5,
                residual: 0.01,
                used: true,
                reason: String::new(),
            },
            Scale {
                label: "happy".into(),
                control: "tweak_1".into(),
                mean: 0.0,
                std: 0.0,
                weight: 0.0,
                residual: 0.0,
                used: false,
                reason: "constant".into(),
            },
        ];
        write(&path, &rows, &Provenance::new("scale", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read(&path).unwrap(), rows);
    }
}
