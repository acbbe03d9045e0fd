//! A linear rig, `e(p) = b + A p`: the reference evaluator behind the example external
//! process (`reprise-example-rig`) and a rig whose scaling weights are known exactly
//! (`w_j = ‖A_{:,j}‖`, the paper's Eq. 3 solved analytically).

use crate::local::PoseEvaluator;

/// `e(p) = b + A p` with a fixed, deterministic `A` (3V × C) and `b`.
#[derive(Debug, Clone)]
pub struct LinearRig {
    names: Vec<String>,
    vertices: usize,
    /// Row-major (3V × C).
    a: Vec<f64>,
}

impl LinearRig {
    /// A linear rig over `controls` with `vertices` vertices. Column `j` of `A` has
    /// entries `sin(1.3 (r+1)(j+1)) · (j+1)` for row `r`, so columns differ in norm by
    /// design (control `j` moves the mesh about `j+1` times as much as control 0).
    pub fn new(controls: Vec<String>, vertices: usize) -> Self {
        let c = controls.len();
        let a = (0..3 * vertices)
            .flat_map(|r| (0..c).map(move |j| (1.3 * ((r + 1) * (j + 1)) as f64).sin() * (j + 1) as f64))
            .collect();
        Self { names: controls, vertices, a }
    }

    /// `‖A_{:,j}‖`: the exact scaling weight of control `j`.
    pub fn column_norm(&self, j: usize) -> f64 {
        let c = self.names.len();
        (0..3 * self.vertices).map(|r| self.a[r * c + j].powi(2)).sum::<f64>().sqrt()
    }

    /// Positions for one pose: `b_r = r` (so the rest mesh is not degenerate) plus `A p`.
    pub fn eval_into(&self, pose: &[f64], out: &mut [f64]) {
        let c = self.names.len();
        for (r, o) in out.iter_mut().enumerate() {
            *o = r as f64 + self.a[r * c..(r + 1) * c].iter().zip(pose).map(|(a, p)| a * p).sum::<f64>();
        }
    }
}

impl PoseEvaluator for LinearRig {
    fn describe(&self) -> String {
        format!("linear ({} controls, {} vertices)", self.names.len(), self.vertices)
    }
    fn control_names(&self) -> Vec<String> {
        self.names.clone()
    }
    fn rest_pose(&self) -> Vec<f64> {
        vec![0.0; self.names.len()]
    }
    fn vertex_count(&self) -> usize {
        self.vertices
    }
    fn triangles(&self) -> &[[u32; 3]] {
        &[]
    }
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
        self.eval_into(pose, out);
    }
}
