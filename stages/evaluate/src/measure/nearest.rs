//! The nearest training poses of an answer's frames, computed once per frame and shared by
//! the measures that need them (arrival reads every frame until it finds B, plausibility
//! every n-th).

use crate::training::{Nearest, Training};

/// Per frame of one answer, its distances to the raw and the floor reference sets
/// ([`Training::distances`]), computed on first use.
pub struct Cache<'a> {
    training: &'a Training,
    controls: &'a [Vec<f64>],
    meshes: &'a [f64],
    done: Vec<Option<(Nearest, Nearest)>>,
}

impl<'a> Cache<'a> {
    /// For the frames `controls` whose meshes are `meshes` (`frames × dim`).
    pub fn new(training: &'a Training, controls: &'a [Vec<f64>], meshes: &'a [f64]) -> Self {
        Self { training, controls, meshes, done: vec![None; controls.len()] }
    }

    /// Frames of the answer.
    pub fn frames(&self) -> usize {
        self.controls.len()
    }

    /// The training reference.
    pub fn training(&self) -> &'a Training {
        self.training
    }

    /// Frame `t`'s (raw, floor) nearest poses.
    pub fn get(&mut self, t: usize) -> (Nearest, Nearest) {
        if let Some(d) = self.done[t] {
            return d;
        }
        let dim = self.training.dim;
        let d = self.training.distances(&self.controls[t], &self.meshes[t * dim..(t + 1) * dim]);
        self.done[t] = Some(d);
        d
    }

    /// The label (index into [`Training::labels`]) of frame `t`'s nearest pose on the mesh
    /// among the training frames and their PCA projections.
    pub fn label(&mut self, t: usize) -> Option<usize> {
        let row = self.get(t).1.row?;
        self.training.row_label.get(row).copied()
    }
}
