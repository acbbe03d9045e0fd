//! A blendshape face as a rig: one control per shape (its weight, a slider, rest 0), the
//! vertices $x_0 + \sum_i w_i (x_i - x_0)$ (`reprise_blendshape`). The file must be the
//! one ingest read: its content hash is checked.

use std::path::Path;

use reprise_blendshape::Blendshapes;

use crate::{Local, PoseEvaluator, RigError};

/// A blendshape face as a [`Rig`](crate::Rig).
pub type BlendshapeFace = Local<Face>;

/// The shapes, with the file they came from for messages.
pub struct Face {
    shapes: Blendshapes,
    source: String,
}

impl Face {
    /// The shapes.
    pub fn shapes(&self) -> &Blendshapes {
        &self.shapes
    }
}

/// Reads the zip at `path` (relative to `base`) as a face rig, without a hash check (for
/// ingest, which records the hash).
pub fn read(base: &Path, path: &str) -> Result<BlendshapeFace, RigError> {
    let shapes = Blendshapes::read_zip(&base.join(path))
        .map_err(|e| RigError::Open { rig: path.into(), message: e.to_string() })?;
    Ok(Local::new(Face { shapes, source: path.into() }))
}

/// Opens the face of `path` (relative to `base`), checking its content hash.
pub fn open(base: &Path, path: &str, blake3: &str) -> Result<BlendshapeFace, RigError> {
    crate::skeleton::check_hash(base, path, blake3)?;
    read(base, path)
}

impl PoseEvaluator for Face {
    fn describe(&self) -> String {
        format!(
            "blendshape face {} ({} shapes, {} vertices)",
            self.source,
            self.shapes.names.len(),
            self.shapes.vertex_count()
        )
    }
    fn control_names(&self) -> Vec<String> {
        self.shapes.names.clone()
    }
    fn rest_pose(&self) -> Vec<f64> {
        vec![0.0; self.shapes.names.len()]
    }
    fn vertex_count(&self) -> usize {
        self.shapes.vertex_count()
    }
    fn triangles(&self) -> &[[u32; 3]] {
        &self.shapes.triangles
    }
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
        self.shapes.evaluate(pose, out);
    }
}
