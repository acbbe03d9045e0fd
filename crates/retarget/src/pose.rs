//! Posing from a few controls (Bouaziz and Pauly, Fig. 8): an animator fixes a few of the
//! character's controls and the model completes the pose from what its training poses say
//! goes with them. With the target GP's mean $\mu(z)$ (normalised coordinates, [`Model`]),
//! the coordinates $c(z) = \bar c + s\,\mu(z)$, and control $j$'s scaled value
//! $u_j(z) = m_j + V_j^\top c(z)$ ([`TargetSpace`], mesh length), the latent minimises
//! $$E(z) = \sum_{j\ \text{fixed}} \frac{(u_j(z) - w_j v_j)^2}{2\sigma^2} + \tfrac12\lVert z\rVert^2,$$
//!
//! $v_j$ the fixed value, $w_j$ the control's weight and $\sigma$ a tolerance in mesh length;
//! the pose is the decoded mean at the optimum, every control filled in.

use reprise_numerics::gplvm::{GplvmError, MeanPredictor};
use reprise_numerics::lbfgs::{lbfgs, LbfgsOptions};

use crate::model::Model;
use crate::shared::predictor;
use crate::target::TargetSpace;

/// A completed pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Posed {
    /// Every control.
    pub pose: Vec<f64>,
    /// The latent found.
    pub z: Vec<f64>,
    /// RMS over the fixed controls of $w_j (p_j - v_j)$, mesh length.
    pub residual: f64,
}

/// Completes poses from fixed controls through one model.
pub struct Poser<'m> {
    model: &'m Model,
    space: &'m TargetSpace,
    target: MeanPredictor,
}

impl<'m> Poser<'m> {
    /// The poser of `model` in `space`.
    ///
    /// # Errors
    /// A target kernel that will not factor.
    pub fn new(model: &'m Model, space: &'m TargetSpace) -> Result<Self, GplvmError> {
        let target = predictor(&model.target(), &model.z, model.q, model.hyper_y)?;
        Ok(Self { model, space, target })
    }

    /// Each fixed control $(j, v_j)$ as $(a_j, b_j, w_j v_j)$ with
    /// $u_j(z) = a_j + b_j^\top \mu(z)$: $a_j = m_j + V_j^\top\bar c$, $b_j = s V_j$.
    fn goals(&self, fixed: &[(usize, f64)]) -> Vec<(f64, Vec<f64>, f64)> {
        let (space, m) = (self.space, self.model);
        let (c, d) = (space.weights.len(), m.dy());
        fixed
            .iter()
            .map(|&(j, v)| {
                let col = |i: usize| space.directions[i * c + j];
                let a = space.mean[j] + (0..d).map(|i| col(i) * m.y_norm.mean[i]).sum::<f64>();
                let b: Vec<f64> = (0..d).map(|i| col(i) * m.y_norm.scale).collect();
                (a, b, space.weights[j] * v)
            })
            .collect()
    }

    /// $E(z)$, its gradient written into `g`.
    fn energy(&self, goals: &[(f64, Vec<f64>, f64)], sigma: f64, z: &[f64], g: &mut [f64]) -> f64 {
        let (q, d) = (self.model.q, self.model.dy());
        let mut mu = vec![0.0; d];
        let mut jac = vec![0.0; d * q];
        self.target.mean_jacobian(z, &mut mu, &mut jac);
        g.copy_from_slice(z);
        let mut e = 0.5 * z.iter().map(|v| v * v).sum::<f64>();
        for (a, b, goal) in goals {
            let r = a + b.iter().zip(&mu).map(|(b, m)| b * m).sum::<f64>() - goal;
            e += r * r / (2.0 * sigma * sigma);
            for (i, bi) in b.iter().enumerate() {
                for (k, gk) in g.iter_mut().enumerate() {
                    *gk += r / (sigma * sigma) * bi * jac[i * q + k];
                }
            }
        }
        e
    }

    /// The pose with the controls `fixed` (index, value) held, within `sigma` mesh length.
    ///
    /// # Errors
    /// A control index out of range, a control that moves no vertex ($w_j = 0$), a
    /// non-finite value, or a non-positive `sigma`.
    pub fn pose(&self, fixed: &[(usize, f64)], sigma: f64) -> Result<Posed, GplvmError> {
        let (space, m) = (self.space, self.model);
        let c = space.weights.len();
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(GplvmError::Shape(format!("the tolerance {sigma} must be positive")));
        }
        for &(j, v) in fixed {
            if j >= c || space.weights[j] <= 0.0 || !v.is_finite() {
                return Err(GplvmError::Shape(format!(
                    "control {j} cannot be fixed to {v}: out of range, moving no vertex, or not finite"
                )));
            }
        }
        let (q, d) = (m.q, m.dy());
        let goals = self.goals(fixed);
        let energy = |z: &[f64], g: &mut [f64]| self.energy(&goals, sigma, z, g);
        // Start at the training latent whose energy is lowest.
        let mut scratch = vec![0.0; q];
        let start = (0..m.n())
            .map(|r| m.z[r * q..(r + 1) * q].to_vec())
            .min_by(|a, b| energy(a, &mut scratch).total_cmp(&energy(b, &mut scratch)))
            .unwrap_or_else(|| vec![0.0; q]);
        let z = lbfgs(energy, &start, &LbfgsOptions { max_iters: 500, ..LbfgsOptions::default() }).x;
        let mut mu = vec![0.0; d];
        self.target.mean(&z, &mut mu);
        let pose = space.decode(&m.y_norm.invert(&mu));
        let sq: f64 = fixed.iter().map(|&(j, v)| (space.weights[j] * (pose[j] - v)).powi(2)).sum();
        Ok(Posed { pose, z, residual: (sq / fixed.len().max(1) as f64).sqrt() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Init, Prior, Settings, TrainingSet};

    /// A character of four controls that move together along one hidden parameter; the
    /// capture sees the same parameter through three values.
    #[test]
    fn two_fixed_controls_complete_the_pose_from_the_training_poses() {
        let t: Vec<f64> = (0..30).map(|i| -1.0 + 2.0 * f64::from(i) / 29.0).collect();
        let pose = |s: f64| [10.0 * s, s * s, (2.0 * s).sin(), 3.0 - s];
        let x: Vec<f64> = t.iter().flat_map(|&s| [s.cos(), s.sin(), 0.5 * s]).collect();
        let y: Vec<f64> = t.iter().flat_map(|&s| pose(s)).collect();
        let weights = [0.1, 1.0, 1.0, 1.0];
        let space = TargetSpace::fit(&y, &weights, 1.0, 8).unwrap();
        let coords: Vec<f64> = y.chunks_exact(4).flat_map(|p| space.encode(p)).collect();
        let set = TrainingSet { x: &x, dx: 3, y: &coords, dy: space.d(), labelled: 30 };
        let settings = Settings { q: 2, k: 4, prior: Prior::Lle, init: Init::Pca, capture_noise: 0.0, max_iters: 300 };
        let (model, _) = Model::fit(&set, &settings).unwrap();
        let poser = Poser::new(&model, &space).unwrap();
        let s = 0.37;
        let truth = pose(s);
        // Fix the first two controls; the other two follow.
        let posed = poser.pose(&[(0, truth[0]), (1, truth[1])], 1e-3).unwrap();
        assert!(posed.residual < 0.05, "the fixed controls are held: {}", posed.residual);
        for (j, (got, want)) in posed.pose.iter().zip(truth).enumerate().skip(2) {
            assert!((got - want).abs() < 0.1, "control {j}: {got} vs {want}");
        }
        // Holding the others at their mean would be far off.
        let mean2 = y.chunks_exact(4).map(|p| p[2]).sum::<f64>() / 30.0;
        assert!((mean2 - truth[2]).abs() > 0.3);
        assert!(poser.pose(&[(9, 1.0)], 1e-3).is_err());
        // The energy's gradient against central differences.
        let goals = poser.goals(&[(0, truth[0]), (2, truth[2])]);
        let z = [0.3, -0.2];
        let mut g = [0.0; 2];
        poser.energy(&goals, 0.05, &z, &mut g);
        let mut scratch = [0.0; 2];
        for k in 0..2 {
            let (mut a, mut b) = (z, z);
            a[k] += 1e-6;
            b[k] -= 1e-6;
            let fd =
                (poser.energy(&goals, 0.05, &a, &mut scratch) - poser.energy(&goals, 0.05, &b, &mut scratch)) / 2e-6;
            assert!((fd - g[k]).abs() < 1e-4 * (1.0 + g[k].abs()), "∂E/∂z{k}: {fd} vs {}", g[k]);
        }
        assert!(poser.pose(&[(0, f64::NAN)], 1e-3).is_err());
    }
}
