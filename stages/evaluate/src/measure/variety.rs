//! Variety: how different a system's answer to the same request is under another seed.

use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::StageResult;

use crate::systems::Played;
use crate::training::RigRef;

/// The mean over the frames both answers have of the RMS vertex distance between them
/// (mesh units): 0 for a system that answers the same under every seed.
pub fn measure(rig: RigRef<'_>, a: &Played, b: &Played) -> StageResult<f64> {
    let frames = a.controls.len().min(b.controls.len());
    between(&meshes(rig, &a.controls[..frames])?, rig, b)
}

/// [`measure`] with the first answer's meshes already evaluated (`ma`: one mesh per frame
/// of it, flattened; only the frames `b` also has are read).
pub fn between(ma: &[f64], rig: RigRef<'_>, b: &Played) -> StageResult<f64> {
    let dim = 3 * rig.0.vertex_count();
    let frames = (ma.len() / dim.max(1)).min(b.controls.len());
    if frames == 0 {
        return Ok(f64::NAN);
    }
    let mb = meshes(rig, &b.controls[..frames])?;
    let total: f64 = (0..frames).map(|t| mesh_rmse(&ma[t * dim..(t + 1) * dim], &mb[t * dim..(t + 1) * dim])).sum();
    Ok(total / frames as f64)
}
