//! Character files as rigs: a BVH skeleton (forward kinematics, joint positions as the
//! vertices) and a glTF character (morph targets, then linear blend skinning). The file
//! must be the one ingest read: its content hash is checked.

use std::path::{Path, PathBuf};

use reprise_bvh::BvhRig;
use reprise_gltf::GltfRig;

use crate::local::{Local, PoseEvaluator};
use crate::RigError;

/// A BVH skeleton as a [`Rig`](crate::Rig).
pub type BvhSkeleton = Local<BvhRig>;
/// A glTF character as a [`Rig`](crate::Rig).
pub type GltfCharacter = Local<GltfRig>;

/// Fails unless `path` (relative to `base`) still has the content hash ingest saw.
pub(crate) fn check_hash(base: &Path, path: &str, blake3: &str) -> Result<PathBuf, RigError> {
    let full = base.join(path);
    let now = reprise_artifact::provenance::hash_file(&full)
        .map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
    if now != blake3 {
        return Err(RigError::Open {
            rig: path.into(),
            message: "the file changed since ingest read it (content hash differs); rerun ingest".into(),
        });
    }
    Ok(full)
}

/// Opens the skeleton of `path` (relative to `base`), checking its content hash.
pub fn open_bvh(base: &Path, path: &str, blake3: &str) -> Result<BvhSkeleton, RigError> {
    let full = check_hash(base, path, blake3)?;
    let rig = BvhRig::open(&full).map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
    Ok(Local::new(rig))
}

/// Opens the character of `path` (relative to `base`), checking its content hash.
pub fn open_gltf(base: &Path, path: &str, blake3: &str) -> Result<GltfCharacter, RigError> {
    let full = check_hash(base, path, blake3)?;
    let rig = GltfRig::open(&full).map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
    Ok(Local::new(rig))
}

impl PoseEvaluator for BvhRig {
    fn describe(&self) -> String {
        BvhRig::describe(self)
    }
    fn control_names(&self) -> Vec<String> {
        BvhRig::control_names(self).to_vec()
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.default_controls()
    }
    fn vertex_count(&self) -> usize {
        BvhRig::vertex_count(self)
    }
    fn triangles(&self) -> &[[u32; 3]] {
        BvhRig::triangles(self)
    }
    fn bones(&self) -> Vec<[u32; 2]> {
        BvhRig::bones(self).into_iter().map(|(a, b)| [a, b]).collect()
    }
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
        self.evaluate(pose, out);
    }
}

impl PoseEvaluator for GltfRig {
    fn describe(&self) -> String {
        format!("glTF character ({} controls, {} vertices)", GltfRig::control_names(self).len(), self.vertex_count())
    }
    fn control_names(&self) -> Vec<String> {
        GltfRig::control_names(self).to_vec()
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.default_controls()
    }
    fn vertex_count(&self) -> usize {
        GltfRig::vertex_count(self)
    }
    fn triangles(&self) -> &[[u32; 3]] {
        GltfRig::triangles(self)
    }
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
        self.evaluate(pose, out);
    }
}
