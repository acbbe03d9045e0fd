//! A fitted label model as later stages use it (Bailey et al. 2016 §4.4): a latent point
//! $x$ → PCA coordinates $y(x) = \bar y + \mu(x)$ → scaled controls
//! $z = \bar z + \sum_k y_k u_k$ → rig controls $p_c = (z_c - \bar p_c)/w_c + \bar p_c$.
//!
//! Because every step after the GP mean is affine, the last two fold into one
//! [`RigMap`], $p = b + V^\top y$ with $V_{kc} = u_{kc}/w_c$ and
//! $b_c = (\bar z_c - \bar p_c)/w_c + \bar p_c$ (controls the PCA does not use keep their
//! mean: $V_{kc} = 0$, $b_c = \bar p_c$). A reconstruction costs $O(N(q+d) + dC)$ for $N$
//! training points, $d$ PCA components and $C$ controls; its Jacobian $V^\top\,\partial\mu/\partial x$
//! costs $O(Ndq + Cdq)$.

use super::{GplvmError, LatentDensity, Predictor};

/// The affine map $p = b + V^\top y$ from PCA coordinates to rig controls, and its
/// left inverse, the projection of the paper's Eq. 13,
/// $y = P p + o$ with $P_{kc} = u_{kc}w_c$ and $o_k = \sum_c u_{kc}(\bar p_c - w_c\bar p_c - \bar z_c)$
/// (scale, centre, project), so that `project(apply(y)) = y`.
#[derive(Debug, Clone, PartialEq)]
pub struct RigMap {
    d: usize,
    base: Vec<f64>,
    basis: Vec<f64>,
    analysis: Vec<f64>,
    analysis_offset: Vec<f64>,
    weight: Vec<f64>,
}

impl RigMap {
    /// From a PCA in scaled space: its mean $\bar z$ and unit directions $u_k$ (row-major
    /// `d × C`), and the scaling's means $\bar p$ and weights $w$ (length $C$; a weight of
    /// 0 marks a control the PCA does not use, whose loadings must be 0). For an unscaled
    /// PCA pass $w = 1$.
    pub fn from_pca(mean_z: &[f64], directions: &[f64], mean_p: &[f64], weight: &[f64]) -> Result<Self, GplvmError> {
        let c = mean_z.len();
        if c == 0 || mean_p.len() != c || weight.len() != c || !directions.len().is_multiple_of(c) {
            return Err(GplvmError::Shape(format!(
                "PCA mean {c}, directions {}, scale means {} and weights {}: need C, d × C, C, C",
                directions.len(),
                mean_p.len(),
                weight.len()
            )));
        }
        let d = directions.len() / c;
        let mut base = Vec::with_capacity(c);
        for j in 0..c {
            let w = weight[j];
            if w == 0.0 {
                if (0..d).any(|k| directions[k * c + j] != 0.0) {
                    return Err(GplvmError::Params(format!("control {j} has weight 0 but a nonzero loading")));
                }
                base.push(mean_p[j]);
            } else if w.is_finite() {
                base.push((mean_z[j] - mean_p[j]) / w + mean_p[j]);
            } else {
                return Err(GplvmError::Params(format!("control {j} has a non-finite weight")));
            }
        }
        let basis =
            (0..d * c).map(|i| if weight[i % c] == 0.0 { 0.0 } else { directions[i] / weight[i % c] }).collect();
        let analysis: Vec<f64> = (0..d * c).map(|i| directions[i] * weight[i % c]).collect();
        let analysis_offset = (0..d)
            .map(|k| (0..c).map(|j| directions[k * c + j] * (mean_p[j] - weight[j] * mean_p[j] - mean_z[j])).sum())
            .collect();
        Ok(Self { d, base, basis, analysis, analysis_offset, weight: weight.to_vec() })
    }

    /// $y = Pp + o$ (the paper's Eq. 13) into `out` (length $d$) for controls `p`.
    pub fn project(&self, p: &[f64], out: &mut [f64]) {
        let c = self.base.len();
        assert_eq!(p.len(), c, "p must have C values");
        for (o, (row, off)) in out.iter_mut().zip(self.analysis.chunks_exact(c).zip(&self.analysis_offset)) {
            *o = off + row.iter().zip(p).map(|(a, b)| a * b).sum::<f64>();
        }
    }

    /// $\lVert W(p - p')\rVert_2$: the distance of two poses in this model's scaled control
    /// space (mesh length; controls the model does not use have weight 0).
    pub fn scaled_distance(&self, p: &[f64], p2: &[f64]) -> f64 {
        self.weight.iter().zip(p.iter().zip(p2)).map(|(w, (a, b))| (w * (a - b)).powi(2)).sum::<f64>().sqrt()
    }

    /// Number of PCA coordinates $d$.
    pub fn d(&self) -> usize {
        self.d
    }

    /// Number of controls $C$.
    pub fn controls(&self) -> usize {
        self.base.len()
    }

    /// $p = b + V^\top y$ into `out` (length $C$).
    pub fn apply(&self, y: &[f64], out: &mut [f64]) {
        assert_eq!(y.len(), self.d, "y must have d values");
        out.copy_from_slice(&self.base);
        for (yk, row) in y.iter().zip(self.basis.chunks_exact(self.base.len())) {
            out.iter_mut().zip(row).for_each(|(o, v)| *o += yk * v);
        }
    }

    /// $V^\top J$ into `out` (row-major `C × q`) for a Jacobian `jac` of $y$ (row-major `d × q`).
    pub fn apply_jacobian(&self, jac: &[f64], q: usize, out: &mut [f64]) {
        let c = self.base.len();
        assert_eq!(jac.len(), self.d * q, "the Jacobian of y is d × q");
        assert_eq!(out.len(), c * q, "the Jacobian of p is C × q");
        out.fill(0.0);
        for (k, row) in self.basis.chunks_exact(c).enumerate() {
            let jk = &jac[k * q..(k + 1) * q];
            for (j, v) in row.iter().enumerate() {
                out[j * q..(j + 1) * q].iter_mut().zip(jk).for_each(|(o, a)| *o += v * a);
            }
        }
    }
}

/// A label's model: the GPLVM predictor, the training latents, its output offset
/// $\bar y$, the map to rig controls, and the latent density.
#[derive(Debug, Clone)]
pub struct LatentModel {
    /// The label.
    pub label: String,
    /// The GP (mean of centred outputs, variance), over its support points: the training
    /// latents of a dense fit, the inducing points of a sparse one.
    pub predictor: Predictor,
    /// The training latents, one row per frame of the label (row-major `N × q`).
    latents: Vec<f64>,
    /// $\bar y$, added to the GP mean.
    pub offset: Vec<f64>,
    /// PCA coordinates → rig controls.
    pub map: RigMap,
    /// $p(x\mid M)$.
    pub density: LatentDensity,
}

/// The default bandwidth of [`LatentModel::density`], in units of the RBF length scale.
pub const DENSITY_BANDWIDTH: f64 = 0.5;

impl LatentModel {
    /// Assembles a model from its predictor and training `latents` (row-major `N × q`);
    /// the density over the latents uses $h = $ [`DENSITY_BANDWIDTH`] $\cdot\,\ell$.
    pub fn new(
        label: String,
        predictor: Predictor,
        latents: Vec<f64>,
        offset: Vec<f64>,
        map: RigMap,
    ) -> Result<Self, GplvmError> {
        if offset.len() != predictor.d() || map.d() != predictor.d() {
            return Err(GplvmError::Shape(format!(
                "model `{label}`: GP output d = {}, offset {}, rig map d = {}",
                predictor.d(),
                offset.len(),
                map.d()
            )));
        }
        let q = predictor.q();
        if latents.is_empty() || !latents.len().is_multiple_of(q) {
            return Err(GplvmError::Shape(format!(
                "model `{label}`: {} latent values are not rows of q = {q}",
                latents.len()
            )));
        }
        let h = DENSITY_BANDWIDTH * predictor.hyper().lengthscale;
        let density = LatentDensity::from_points(latents.clone(), q, h);
        Ok(Self { label, predictor, latents, offset, map, density })
    }

    /// The training latents (row-major `N × q`, one row per frame of the label).
    pub fn latents(&self) -> &[f64] {
        &self.latents
    }

    /// The number of training frames $N$.
    pub fn frames(&self) -> usize {
        self.latents.len() / self.q()
    }

    /// The GP means $\mu(x_i)$ at the training latents (centred PCA coordinates,
    /// row-major `N × d`), $O(N\cdot S(q + d))$ for $S$ support points.
    pub fn training_means(&self) -> Vec<f64> {
        let (q, d) = (self.q(), self.d());
        let mut out = vec![0.0; self.frames() * d];
        for (xi, o) in self.latents.chunks_exact(q).zip(out.chunks_exact_mut(d)) {
            self.predictor.mean(xi, o);
        }
        out
    }

    /// Latent dimension $q$.
    pub fn q(&self) -> usize {
        self.predictor.q()
    }

    /// PCA dimension $d$.
    pub fn d(&self) -> usize {
        self.predictor.d()
    }

    /// Number of controls $C$.
    pub fn controls(&self) -> usize {
        self.map.controls()
    }

    /// The PCA coordinates $y(x) = \bar y + \mu(x)$ into `out` (length $d$).
    pub fn pca_coords(&self, x: &[f64], out: &mut [f64]) {
        self.predictor.mean(x, out);
        out.iter_mut().zip(&self.offset).for_each(|(o, m)| *o += m);
    }

    /// The rig controls $g(x)$ into `out` (length $C$); `y` is scratch of length $d$.
    pub fn controls_into(&self, x: &[f64], y: &mut [f64], out: &mut [f64]) {
        self.pca_coords(x, y);
        self.map.apply(y, out);
    }

    /// $g(x)$ into `out` and $\partial g/\partial x$ into `jac` (row-major `C × q`).
    pub fn controls_jacobian(&self, x: &[f64], out: &mut [f64], jac: &mut [f64]) {
        let (d, q) = (self.d(), self.q());
        let (mut y, mut jy) = (vec![0.0; d], vec![0.0; d * q]);
        self.predictor.mean_jacobian(x, &mut y, &mut jy);
        y.iter_mut().zip(&self.offset).for_each(|(o, m)| *o += m);
        self.map.apply(&y, out);
        self.map.apply_jacobian(&jy, q, jac);
    }

    /// The GP's predictive variance of the latent function at `x` (per PCA coordinate;
    /// the same for all of them), $\sigma_f^2 - k^\top K^{-1}k$.
    pub fn variance(&self, x: &[f64]) -> f64 {
        self.predictor.variance(x, false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};
    use crate::gplvm::{Hyper, LikelihoodConfig};

    /// The folded map equals the three-step recipe of §4.4 (project, unscale, add the
    /// mean), unused controls sit at their mean, and the Jacobian of g equals central
    /// differences.
    #[test]
    fn reconstruction_is_the_papers_recipe_with_exact_jacobian() {
        let (c, d, q, n) = (5, 2, 2, 20);
        let mean_p = [1.0, -2.0, 0.5, 3.0, 0.0];
        let weight = [2.0, 0.5, 0.0, 4.0, 1.0];
        // z̄ = p̄ for the used controls (the scale stage's transform keeps the mean).
        let mean_z = mean_p;
        let dirs = [0.6, 0.8, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.6, 0.8];
        let map = RigMap::from_pca(&mean_z, &dirs, &mean_p, &weight).unwrap();
        let y = [0.7, -1.1];
        let mut p = [0.0; 5];
        map.apply(&y, &mut p);
        for j in 0..c {
            let z = mean_z[j] + y[0] * dirs[j] + y[1] * dirs[c + j];
            let want = if weight[j] == 0.0 { mean_p[j] } else { (z - mean_p[j]) / weight[j] + mean_p[j] };
            assert!((p[j] - want).abs() < 1e-14, "control {j}");
        }
        assert!(RigMap::from_pca(&mean_z, &[0.0, 0.0, 1.0, 0.0, 0.0], &mean_p, &weight).is_err());
        // Eq. 13 inverts the map, also when z̄ differs from p̄.
        let mean_z2 = [1.5, -2.0, 0.5, 2.0, 0.3];
        let map2 = RigMap::from_pca(&mean_z2, &dirs, &mean_p, &weight).unwrap();
        map2.apply(&y, &mut p);
        let mut back = [0.0; 2];
        map2.project(&p, &mut back);
        assert!((back[0] - y[0]).abs() < 1e-12 && (back[1] - y[1]).abs() < 1e-12, "{back:?}");
        let mut p2 = p;
        p2[0] += 1.0;
        p2[2] += 5.0; // unused: no distance
        assert!((map2.scaled_distance(&p, &p2) - 2.0).abs() < 1e-12);

        let (x, ys) = random_problem(n, d, q, 9);
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.9, white_variance: 0.01 };
        let pred = Predictor::new(&x, &ys, d, hyper, &LikelihoodConfig::default()).unwrap();
        let model = LatentModel::new("m".into(), pred, x.clone(), vec![0.3, -0.2], map).unwrap();
        let at = [0.1, 0.4];
        let (mut g, mut jac) = (vec![0.0; c], vec![0.0; c * q]);
        model.controls_jacobian(&at, &mut g, &mut jac);
        let mut g2 = vec![0.0; c];
        model.controls_into(&at, &mut vec![0.0; d], &mut g2);
        assert!(max_rel_err(&g, &g2) < 1e-14);
        for j in [0, 1, 3, 4] {
            let fd = central_diff(&at, 1e-4, |xs| {
                let mut o = vec![0.0; c];
                model.controls_into(xs, &mut vec![0.0; d], &mut o);
                o[j]
            });
            assert!(max_rel_err(&jac[j * q..(j + 1) * q], &fd) < 1e-7, "control {j}");
        }
        assert!(jac[2 * q..3 * q].iter().all(|v| *v == 0.0));
        assert!(model.variance(&at) >= 0.0 && model.variance(&[40.0, 40.0]) > 0.99);
    }
}
