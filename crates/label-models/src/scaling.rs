//! One label's control scaling (Bailey et al. 2016 Eq. 3), the convention the pca stage
//! fits its PCA in and every later user of that PCA must share.
//!
//! Over a frame table's controls $c = 1 … C$ (control units), a label has per control a
//! mean $\bar p_c$ and a weight $w_c$ (mesh length per control unit), and the set $U$ of
//! the controls its PCA uses. The scaled controls are
//! $z_c = w_c(p_c - \bar p_c) + \bar p_c$ for $c \in U$ (so that a unit of $z$ moves the
//! mesh about one mesh length whatever the control); unscaling inverts it,
//! $p_c = (z_c - \bar p_c)/w_c + \bar p_c$, and a control outside $U$ is held at $\bar p_c$.
//! A PCA is fitted on the $|U|$-vector $z_U$; [`Scaling::pca_model`] spreads it over all
//! $C$ controls (mean $\bar p_c$ and loading 0 outside $U$), the form the `pca_models`
//! artifact stores and [`Scaling::rig_map`] folds with the unscaling into one affine map.

use std::path::Path;

use reprise_artifact::pca::PcaModel;
use reprise_artifact::scales::Scale;
use reprise_numerics::gplvm::RigMap;
use reprise_numerics::pca::Pca;
use reprise_stagekit::{StageError, StageResult};

/// One label's scaling over the controls of a frame table.
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    /// The label.
    pub label: String,
    /// Table columns of the controls the PCA uses ($U$), ascending.
    pub used: Vec<usize>,
    /// Per table control: $\bar p_c$, control units.
    pub mean: Vec<f64>,
    /// Per table control: $w_c$, mesh length per control unit (meaningful on $U$ only).
    pub weight: Vec<f64>,
}

impl Scaling {
    /// The scaling of `label` over `controls` (a frame table's columns) from the rows of
    /// the `scales` artifact at `scales_path`; a control without a row is an input error
    /// naming the file.
    pub fn new(label: &str, controls: &[String], scales: &[Scale], scales_path: &Path) -> StageResult<Self> {
        let mine: Vec<&Scale> = scales.iter().filter(|s| s.label == label).collect();
        let per: Vec<&Scale> = controls
            .iter()
            .map(|c| {
                mine.iter().copied().find(|s| &s.control == c).ok_or_else(|| {
                    StageError::Input(format!(
                        "{}: no scale for label `{label}`, control `{c}`; rerun scale",
                        scales_path.display()
                    ))
                })
            })
            .collect::<StageResult<_>>()?;
        Ok(Self {
            label: label.into(),
            used: (0..controls.len()).filter(|&c| per[c].used).collect(),
            mean: per.iter().map(|s| s.mean).collect(),
            weight: per.iter().map(|s| s.weight).collect(),
        })
    }

    /// The used controls of a full table row: $z_U$ when `scaled`, $p_U$ otherwise.
    pub fn values<'a>(&'a self, row: &'a [f64], scaled: bool) -> impl Iterator<Item = f64> + 'a {
        self.used
            .iter()
            .map(move |&c| if scaled { self.weight[c] * (row[c] - self.mean[c]) + self.mean[c] } else { row[c] })
    }

    /// A full table row from used-control values ($z_U$ when `scaled`, $p_U$ otherwise):
    /// unscale, and hold the controls outside $U$ at $\bar p_c$.
    pub fn full_row(&self, used_values: &[f64], scaled: bool) -> Vec<f64> {
        let mut row = self.mean.clone();
        for (&c, &v) in self.used.iter().zip(used_values) {
            row[c] = if scaled { (v - self.mean[c]) / self.weight[c] + self.mean[c] } else { v };
        }
        row
    }

    /// The first `pca.kept` components of a PCA over $U$ as a model over all $C$ controls
    /// (mean $\bar p_c$ and loading 0 outside $U$), tagged `variant`.
    pub fn pca_model(&self, pca: &Pca, variant: &str) -> PcaModel {
        let (d, n, u) = (pca.kept, self.mean.len(), self.used.len());
        let mut directions = vec![0.0; d * n];
        for k in 0..d {
            for (j, &c) in self.used.iter().enumerate() {
                directions[k * n + c] = pca.directions[k * u + j];
            }
        }
        let mut mean = self.mean.clone();
        for (j, &c) in self.used.iter().enumerate() {
            mean[c] = pca.mean[j];
        }
        PcaModel {
            label: self.label.clone(),
            variant: variant.into(),
            mean,
            directions,
            singular_values: pca.singular_values[..d].to_vec(),
            explained: pca.explained()[..d].to_vec(),
        }
    }

    /// The affine map from the coordinates $y$ of a scaled PCA `model` (over all $C$
    /// controls, as [`Self::pca_model`] makes it) to rig controls,
    /// $p = b + V^\top y$ ([`RigMap::from_pca`], weight 0 outside $U$).
    pub fn rig_map(&self, model: &PcaModel) -> StageResult<RigMap> {
        let mut weight = vec![0.0; self.mean.len()];
        self.used.iter().for_each(|&c| weight[c] = self.weight[c]);
        RigMap::from_pca(&model.mean, &model.directions, &self.mean, &weight)
            .map_err(|e| StageError::Input(format!("label `{}`: {e}", self.label)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_numerics::pca::PcaParams;

    fn scale(label: &str, control: &str, mean: f64, weight: f64, used: bool) -> Scale {
        Scale {
            label: label.into(),
            control: control.into(),
            mean,
            std: 1.0,
            weight,
            residual: 0.0,
            used,
            reason: String::new(),
        }
    }

    /// Scaling and unscaling invert each other on the used controls, an unused control
    /// comes back at its mean, and a PCA's reconstruction through the rig map equals its
    /// reconstruction in scaled space unscaled (the two routes of the convention agree).
    #[test]
    fn scale_unscale_and_rig_map_agree() {
        let controls: Vec<String> = ["a", "b", "c"].map(String::from).to_vec();
        let scales = vec![
            scale("l", "a", 1.0, 2.0, true),
            scale("l", "b", -3.0, 0.0, false),
            scale("l", "c", 0.5, 0.25, true),
            scale("other", "a", 9.0, 9.0, true),
        ];
        let s = Scaling::new("l", &controls, &scales, Path::new("s.parquet")).unwrap();
        assert_eq!(s.used, [0, 2]);
        let rows = [[2.0, 7.0, 1.5], [0.0, 7.0, -0.5], [1.5, 7.0, 2.5]];
        let z: Vec<f64> = rows.iter().flat_map(|r| s.values(r, true).collect::<Vec<_>>()).collect();
        assert_eq!(&z[..2], &[2.0 * (2.0 - 1.0) + 1.0, 0.25 * (1.5 - 0.5) + 0.5]);
        assert_eq!(s.full_row(&z[..2], true), [2.0, -3.0, 1.5]);
        assert_eq!(s.values(&rows[0], false).collect::<Vec<_>>(), [2.0, 1.5]);
        let pca = Pca::fit(&z, 2, &PcaParams { variance: 1.0, min_components: 1, max_components: 1 }).unwrap();
        let map = s.rig_map(&s.pca_model(&pca, "scaled")).unwrap();
        let mut p = vec![0.0; 3];
        for zi in z.chunks(2) {
            let y = pca.project(zi, 1);
            map.apply(&y, &mut p);
            let want = s.full_row(&pca.reconstruct(&y), true);
            assert!(p.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-12), "{p:?} vs {want:?}");
        }
        let e = Scaling::new("m", &controls, &scales, Path::new("s.parquet")).unwrap_err().to_string();
        assert!(e.contains("s.parquet: no scale for label `m`, control `a`"), "{e}");
    }
}
