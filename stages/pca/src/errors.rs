//! Reconstruction error of a label's frames through `d` components, in rig space and,
//! through the rig, in mesh space: the scaled-versus-unscaled ablation of the paper's
//! §4.2 (which claims scaling wins in mesh space at small `d`).

use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::pca::{PcaError, SCALED, UNSCALED};
use reprise_numerics::pca::Pca;
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::StageResult;

use crate::LabelData;

/// Error rows for both variants at each variant's chosen d and at `fixed` d.
pub(crate) fn measure(
    labeled: &LabeledFrames,
    data: &LabelData,
    scaled: &Pca,
    unscaled: &Pca,
    fixed: &[usize],
    rig: Option<&(Box<dyn Rig>, PoseLayout)>,
) -> StageResult<Vec<PcaError>> {
    let originals: Vec<Vec<f64>> = data.rows.iter().map(|&r| labeled.frames.row(r).to_vec()).collect();
    let truth = rig.map(|r| meshes(r, &originals)).transpose()?;
    let mut ds: Vec<(usize, &str)> = vec![(scaled.kept, "chosen"), (unscaled.kept, "chosen")];
    ds.extend(fixed.iter().map(|&d| (d, "fixed")));
    let mut rows = Vec::new();
    for (variant, pca, is_scaled) in [(SCALED, scaled, true), (UNSCALED, unscaled, false)] {
        let z = data.matrix(labeled, is_scaled);
        let u = data.scaling.used.len();
        let mut seen = Vec::new();
        for &(d, which) in &ds {
            let d = d.min(pca.singular_values.len());
            let which = if which == "chosen" && d == pca.kept { "chosen" } else { "fixed" };
            if seen.contains(&d) {
                continue;
            }
            seen.push(d);
            let recon: Vec<Vec<f64>> = z
                .chunks(u)
                .map(|row| data.scaling.full_row(&pca.reconstruct(&pca.project(row, d)), is_scaled))
                .collect();
            let rig_sq: f64 = recon
                .iter()
                .zip(&originals)
                .map(|(a, b)| data.scaling.used.iter().map(|&c| (a[c] - b[c]).powi(2)).sum::<f64>())
                .sum();
            let rig_rmse = (rig_sq / (recon.len() * u) as f64).sqrt();
            let mesh = match (rig, &truth) {
                (Some(r), Some(t)) => Some(mesh_rmse(&meshes(r, &recon)?, t)),
                _ => None,
            };
            rows.push(PcaError {
                label: data.scaling.label.clone(),
                variant: variant.into(),
                d: d as i64,
                which: which.into(),
                explained: pca.cumulative_explained()[d - 1],
                rig_rmse,
                mesh_rmse: mesh,
            });
        }
    }
    Ok(rows)
}
