//! Opening the rig a controls table names, as every mesh-space stage does.

use reprise_artifact::controls::Controls;
use reprise_rig::{PoseLayout, Rig};

use crate::{StageError, StageResult};

/// The rig of `controls` and the layout that puts rows of `table_controls` into its
/// control vector (controls the table lacks stay at their default).
pub fn open_rig(controls: &Controls, table_controls: &[String]) -> StageResult<(Box<dyn Rig>, PoseLayout)> {
    let names: Vec<String> = controls.controls.iter().map(|c| c.name.clone()).collect();
    let defaults: Vec<f64> = controls.controls.iter().map(|c| c.default).collect();
    let rig = reprise_rig::open(&controls.rig, std::path::Path::new("."), &names, &defaults)
        .map_err(|e| StageError::Input(e.to_string()))?;
    if rig.control_names() != names.as_slice() {
        return Err(StageError::Input(format!(
            "the rig {} has {} controls, the controls table {}; rerun ingest",
            rig.describe(),
            rig.control_names().len(),
            names.len()
        )));
    }
    let layout =
        PoseLayout::new(rig.control_names(), defaults, table_controls).map_err(|e| StageError::Input(e.to_string()))?;
    Ok((rig, layout))
}

/// Frames evaluated per rig batch.
const BATCH: usize = 256;

/// Mesh positions (`x0, y0, z0, x1, …` per pose, concatenated) of table rows, through the
/// rig and the layout of [`open_rig`].
pub fn meshes(rig: &(Box<dyn Rig>, PoseLayout), rows: &[Vec<f64>]) -> StageResult<Vec<f64>> {
    let (rig, layout) = rig;
    let m = 3 * rig.vertex_count();
    let mut out = vec![0.0; rows.len() * m];
    for (chunk, o) in rows.chunks(BATCH).zip(out.chunks_mut(BATCH * m)) {
        let poses: Vec<f64> = chunk.iter().flat_map(|r| layout.full(r)).collect();
        rig.evaluate_batch(&poses, o).map_err(|e| StageError::Input(e.to_string()))?;
    }
    Ok(out)
}

/// RMS over poses and vertices of the vertex distance between two mesh batches:
/// $\sqrt{\sum\lVert a_v - b_v\rVert^2 / V_{total}}$, mesh units.
pub fn mesh_rmse(a: &[f64], b: &[f64]) -> f64 {
    let vertices = a.len() / 3;
    let sq: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    (sq / vertices.max(1) as f64).sqrt()
}
