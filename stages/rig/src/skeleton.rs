//! Character files as rigs: a BVH skeleton (forward kinematics, joint positions as the
//! vertices) and a glTF character (morph targets, then linear blend skinning). The file
//! must be the one ingest read: its content hash is checked.

use std::path::Path;

use reprise_bvh::BvhRig;
use reprise_gltf::GltfRig;

use crate::{par_batch, Rig, RigError};

/// Fails unless `path` (relative to `base`) still has the content hash ingest saw.
pub(crate) fn check_hash(base: &Path, path: &str, blake3: &str) -> Result<std::path::PathBuf, RigError> {
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

/// A BVH skeleton behind [`Rig`].
pub struct BvhSkeleton {
    rig: BvhRig,
    names: Vec<String>,
}

impl BvhSkeleton {
    /// Opens the skeleton of `path` (relative to `base`), checking its content hash.
    pub fn open(base: &Path, path: &str, blake3: &str) -> Result<Self, RigError> {
        let full = check_hash(base, path, blake3)?;
        let rig = BvhRig::open(&full).map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
        Ok(Self { names: rig.control_names().to_vec(), rig })
    }
}

impl Rig for BvhSkeleton {
    fn describe(&self) -> String {
        self.rig.describe()
    }
    fn control_names(&self) -> &[String] {
        &self.names
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.rig.default_controls()
    }
    fn vertex_count(&self) -> usize {
        self.rig.vertex_count()
    }
    fn triangles(&self) -> &[[u32; 3]] {
        self.rig.triangles()
    }
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
        par_batch(self, poses, out, |p, o| self.rig.evaluate(p, o))
    }
}

/// A glTF character behind [`Rig`].
pub struct GltfCharacter {
    rig: GltfRig,
    names: Vec<String>,
    path: String,
}

impl GltfCharacter {
    /// Opens the character of `path` (relative to `base`), checking its content hash.
    pub fn open(base: &Path, path: &str, blake3: &str) -> Result<Self, RigError> {
        let full = check_hash(base, path, blake3)?;
        let rig = GltfRig::open(&full).map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
        Ok(Self { names: rig.control_names().to_vec(), rig, path: path.into() })
    }
}

impl Rig for GltfCharacter {
    fn describe(&self) -> String {
        format!("glTF `{}`", self.path)
    }
    fn control_names(&self) -> &[String] {
        &self.names
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.rig.default_controls()
    }
    fn vertex_count(&self) -> usize {
        self.rig.vertex_count()
    }
    fn triangles(&self) -> &[[u32; 3]] {
        self.rig.triangles()
    }
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
        par_batch(self, poses, out, |p, o| self.rig.evaluate(p, o))
    }
}
