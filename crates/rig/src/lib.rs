//! The rig evaluator `e(p)` of the paper: a control vector `p` in, mesh vertex positions
//! out. Scaling, every mesh-space metric and every picture go through [`Rig`].
//!
//! Implementations: the built-in dragon-face rig ([`dragon`]), glTF characters and BVH
//! skeletons ([`skeleton`]), blendshape faces ([`blendshape`]), an external process
//! speaking Arrow IPC ([`external`]), and a linear example rig ([`linear`]) that is both
//! the protocol's reference evaluator and a rig with analytic answers for tests.
//! [`open`] rebuilds the rig an artifact names ([`RigRef`]), so every stage evaluates
//! the same rig as ingest saw.
#![warn(missing_docs)]

pub mod blendshape;
pub mod dragon;
pub mod error;
pub mod external;
pub mod linear;
pub mod local;
pub mod pose;
pub mod skeleton;

use std::path::Path;

pub use error::RigError;
pub use local::{Local, PoseEvaluator};
pub use pose::PoseLayout;
use rayon::prelude::*;
use reprise_artifact::controls::RigRef;

/// A rig evaluator: control vectors to vertex positions.
///
/// Control vectors follow [`Rig::control_names`]; positions are `x, y, z` per vertex,
/// interleaved, in the rig's length unit (cm for dragon-face, m for glTF).
pub trait Rig: Send + Sync {
    /// A short description for messages, e.g. `dragon-face (seed 7)`.
    fn describe(&self) -> String;
    /// Control names: the order of every control vector.
    fn control_names(&self) -> &[String];
    /// The rest (default) pose.
    fn rest_pose(&self) -> Vec<f64>;
    /// Number of vertices of the evaluated mesh.
    fn vertex_count(&self) -> usize;
    /// Triangles, where the rig has them (empty for skeletons).
    fn triangles(&self) -> &[[u32; 3]];
    /// Bones, where the rig is a skeleton: pairs of vertices (parent joint, child joint or
    /// end site), so that a skeleton without triangles can still be drawn.
    fn bones(&self) -> Vec<[u32; 2]> {
        Vec::new()
    }
    /// Evaluates `poses` (row-major, one pose per `control_names().len()` values) into
    /// `out` (row-major, `3 · vertex_count()` values per pose).
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError>;

    /// Evaluates one pose.
    fn evaluate(&self, pose: &[f64]) -> Result<Vec<f64>, RigError> {
        let mut out = vec![0.0; 3 * self.vertex_count()];
        self.evaluate_batch(pose, &mut out)?;
        Ok(out)
    }
}

/// Evaluates a batch pose by pose in parallel (rayon) with `eval(pose, out)`, after
/// checking the batch shape. For in-process rigs.
pub fn par_batch(
    rig: &dyn Rig,
    poses: &[f64],
    out: &mut [f64],
    eval: impl Fn(&[f64], &mut [f64]) + Sync,
) -> Result<(), RigError> {
    let (n, m) = (rig.control_names().len(), 3 * rig.vertex_count());
    if n == 0 || !poses.len().is_multiple_of(n) || out.len() != poses.len() / n * m {
        return Err(RigError::BatchShape { rig: rig.describe(), values: poses.len(), controls: n });
    }
    poses.par_chunks(n).zip(out.par_chunks_mut(m)).for_each(|(p, o)| eval(p, o));
    Ok(())
}

/// Rebuilds the rig an artifact names. Paths in the reference are relative to `base`
/// (the pipeline directory). `controls` are the control names of the controls table,
/// needed by rigs that learn them from the data (external).
pub fn open(rig: &RigRef, base: &Path, controls: &[String], rest: &[f64]) -> Result<Box<dyn Rig>, RigError> {
    match rig {
        RigRef::DragonFace { seed, version } => Ok(Box::new(dragon::open(*seed, version)?)),
        RigRef::External { command } => {
            Ok(Box::new(external::ExternalRig::spawn(command, base, controls.to_vec(), rest.to_vec())?))
        }
        RigRef::Bvh { path, blake3 } => Ok(Box::new(skeleton::open_bvh(base, path, blake3)?)),
        RigRef::Gltf { path, blake3 } => Ok(Box::new(skeleton::open_gltf(base, path, blake3)?)),
        RigRef::Blendshapes { path, blake3 } => Ok(Box::new(blendshape::open(base, path, blake3)?)),
        RigRef::None => Err(RigError::Open {
            rig: "none".into(),
            message: "the controls table names no rig (curve tables carry none); mesh-space stages need one: \
                      ingest a glTF/BVH character or give an external evaluator"
                .into(),
        }),
    }
}
