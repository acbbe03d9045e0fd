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
