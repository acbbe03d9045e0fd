//! The supervised baselines a retargeting is measured against (Bouaziz and Pauly §3), fitted
//! on the labelled pairs alone: ridge regression and Gaussian-process regression.

use faer::prelude::Solve;
use faer::{Mat, Side};
use reprise_numerics::gplvm::{GplvmError, Hyper, Likelihood, LikelihoodConfig, MeanPredictor};
use reprise_numerics::lbfgs::{lbfgs, LbfgsOptions};

use crate::shared::{predictor, Space};

/// Ridge regression with an intercept: $y = W^\top (x - \bar x) + \bar y$,
/// $W = (X_c^\top X_c + \alpha I)^{-1} X_c^\top Y_c$ on centred data.
#[derive(Debug, Clone, PartialEq)]
pub struct Ridge {
    x_mean: Vec<f64>,
    y_mean: Vec<f64>,
    /// `dx × dy` row-major.
    w: Vec<f64>,
}

fn means(v: &[f64], d: usize) -> Vec<f64> {
    let n = (v.len() / d).max(1) as f64;
    (0..d).map(|j| v.chunks_exact(d).map(|r| r[j]).sum::<f64>() / n).collect()
}

impl Ridge {
    /// Fits `n` pairs (`x`: `n × dx`, `y`: `n × dy`) with penalty `alpha` > 0.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for mismatched tables or a non-positive `alpha`.
    pub fn fit(x: &[f64], dx: usize, y: &[f64], dy: usize, alpha: f64) -> Result<Self, GplvmError> {
        let n = x.len().checked_div(dx).unwrap_or(0);
        if n == 0 || x.len() != n * dx || y.len() != n * dy || !(alpha > 0.0 && alpha.is_finite()) {
            return Err(GplvmError::Shape(format!(
                "ridge: {n} rows of {dx} and {} values of {dy}, alpha {alpha}",
                y.len()
            )));
        }
        let (xm, ym) = (means(x, dx), means(y, dy));
        let xc = Mat::from_fn(n, dx, |i, j| x[i * dx + j] - xm[j]);
        let yc = Mat::from_fn(n, dy, |i, j| y[i * dy + j] - ym[j]);
        let mut a = xc.transpose() * &xc;
        for j in 0..dx {
            a[(j, j)] += alpha;
        }
        let mut w = xc.transpose() * &yc;
        a.llt(Side::Lower).map_err(|_| GplvmError::Shape("ridge: singular system".into()))?.solve_in_place(w.as_mut());
        Ok(Self {
            x_mean: xm,
            y_mean: ym,
            w: (0..dx).flat_map(|i| (0..dy).map(move |j| (i, j))).map(|(i, j)| w[(i, j)]).collect(),
        })
    }

    /// The prediction for one `x` (`dx` values).
    pub fn predict(&self, x: &[f64]) -> Vec<f64> {
        let dy = self.y_mean.len();
        let mut out = self.y_mean.clone();
        for (i, (xi, m)) in x.iter().zip(&self.x_mean).enumerate() {
            for (j, o) in out.iter_mut().enumerate() {
                *o += (xi - m) * self.w[i * dy + j];
            }
        }
        out
    }
}

/// Gaussian-process regression $x \mapsto y$ with the RBF kernel, its hyperparameters by
/// maximum marginal likelihood (L-BFGS in log space from $\sigma_f^2 = 1$, $\ell = 1$,
/// $\sigma_w^2 = 0.01$, the inputs fixed): the GPLVM likelihood with the inputs as latents.
///
/// # Errors
/// Bad shapes; a kernel that will not factor at the optimum.
pub fn gpr(x: &[f64], dx: usize, y: &[f64], dy: usize) -> Result<MeanPredictor, GplvmError> {
    let n = x.len().checked_div(dx).unwrap_or(0);
    if n == 0 || x.len() != n * dx || y.len() != n * dy {
        return Err(GplvmError::Shape(format!("gpr: {n} rows of {dx} and {} values of {dy}", y.len())));
    }
    let mut lik = Likelihood::new(y, dy, dx, LikelihoodConfig::default())?;
    let mut gx = vec![0.0; n * dx];
    let r = lbfgs(
        |p, g| {
            let h = Hyper::from_log([p[0], p[1], p[2]]);
            match lik.evaluate(x, &h, &mut gx) {
                Ok(e) => {
                    let gl = e.grad_hyper_log(&h);
                    g.copy_from_slice(&[gl.rbf_variance, gl.lengthscale, gl.white_variance]);
                    e.value
                }
                Err(_) => {
                    g.fill(0.0);
                    f64::INFINITY
                }
            }
        },
        &[0.0, 0.0, (1e-2f64).ln()],
        &LbfgsOptions { max_iters: 500, ..LbfgsOptions::default() },
    );
    let hyper = Hyper::from_log([r.x[0], r.x[1], r.x[2]]);
    predictor(&Space { data: y, dim: dy, rows: (0..n).collect() }, x, dx, hyper)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ridge_recovers_a_linear_map() {
        // y = [2x0 − x1 + 1, 0.5 x1] on a small grid; a tiny penalty recovers it.
        let x: Vec<f64> = (0..12).flat_map(|i| [f64::from(i % 4), f64::from(i / 4)]).collect();
        let y: Vec<f64> = x.chunks_exact(2).flat_map(|p| [2.0 * p[0] - p[1] + 1.0, 0.5 * p[1]]).collect();
        let r = Ridge::fit(&x, 2, &y, 2, 1e-9).unwrap();
        let p = r.predict(&[1.5, 0.5]);
        assert!((p[0] - 3.5).abs() < 1e-6 && (p[1] - 0.25).abs() < 1e-6, "{p:?}");
        assert!(Ridge::fit(&x, 2, &y, 2, 0.0).is_err());
    }

    #[test]
    fn gpr_beats_ridge_on_a_curved_map_between_samples() {
        let t: Vec<f64> = (0..15).map(|i| -2.0 + 4.0 * f64::from(i) / 14.0).collect();
        let f = |s: f64| [s.sin(), (1.3 * s).cos()];
        let y: Vec<f64> = t.iter().flat_map(|&s| f(s)).collect();
        let g = gpr(&t, 1, &y, 2).unwrap();
        let r = Ridge::fit(&t, 1, &y, 2, 1e-6).unwrap();
        let (mut eg, mut er) = (0.0, 0.0);
        let mut out = [0.0; 2];
        for k in 0..14 {
            let s = -2.0 + 4.0 * (f64::from(k) + 0.5) / 14.0;
            g.mean(&[s], &mut out);
            let truth = f(s);
            eg += out.iter().zip(truth).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            er += r.predict(&[s]).iter().zip(truth).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        }
        assert!(eg < 0.01 * er, "GPR {eg} vs ridge {er}");
    }
}
