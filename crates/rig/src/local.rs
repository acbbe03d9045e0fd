//! In-process rigs: anything that evaluates one pose at a time becomes a [`Rig`] through
//! [`Local`], which checks batch shapes and evaluates the poses of a batch in parallel.

use crate::{par_batch, Rig, RigError};

/// A rig that lives in this process and evaluates one pose at a time.
pub trait PoseEvaluator: Send + Sync {
    /// A short description for messages.
    fn describe(&self) -> String;
    /// Control names, the order of a pose.
    fn control_names(&self) -> Vec<String>;
    /// The rest pose.
    fn rest_pose(&self) -> Vec<f64>;
    /// Vertex count.
    fn vertex_count(&self) -> usize;
    /// Triangles (empty for skeletons).
    fn triangles(&self) -> &[[u32; 3]];
    /// Bones (pairs of vertices), for a skeleton.
    fn bones(&self) -> Vec<[u32; 2]> {
        Vec::new()
    }
    /// Positions of one pose into `out` (`3 · vertex_count()` values).
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]);
}

/// A [`PoseEvaluator`] behind [`Rig`].
pub struct Local<E> {
    inner: E,
    names: Vec<String>,
}

impl<E: PoseEvaluator> Local<E> {
    /// Wraps an evaluator.
    pub fn new(inner: E) -> Self {
        Self { names: inner.control_names(), inner }
    }
    /// The wrapped evaluator.
    pub fn inner(&self) -> &E {
        &self.inner
    }
}

impl<E: PoseEvaluator> Rig for Local<E> {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn control_names(&self) -> &[String] {
        &self.names
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.inner.rest_pose()
    }
    fn vertex_count(&self) -> usize {
        self.inner.vertex_count()
    }
    fn triangles(&self) -> &[[u32; 3]] {
        self.inner.triangles()
    }
    fn bones(&self) -> Vec<[u32; 2]> {
        self.inner.bones()
    }
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
        par_batch(self, poses, out, |p, o| self.inner.evaluate_pose(p, o))
    }
}
