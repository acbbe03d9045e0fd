//! The shared GPLVM's objective (Bouaziz and Pauly, Eq. 1–5): latents $Z$ ($N \times q$)
//! shared by a source space $X$ and a target space $Y$, each observed on its own rows of
//! $Z$ (labelled pairs on both; unlabelled source frames only on $X$'s, unlabelled target
//! poses only on $Y$'s), each with its own RBF kernel (the reprise GPLVM likelihood,
//! `reprise_numerics::gplvm::Likelihood`), plus the LLE prior ([`crate::lle`]):
//! $$E(Z, \theta_X, \theta_Y) = E_X(Z_{R_X}, \theta_X) + E_Y(Z_{R_Y}, \theta_Y) +
//! \tfrac12\mathrm{tr}(L Z Z^\top),$$
//!
//! with $R_X$, $R_Y$ the rows each space owns. The parameters are $Z$ row-major, then
//! $\log\theta_X$ and $\log\theta_Y$ ($\log\sigma_f^2, \log\ell, \log\sigma_w^2$ each).

use faer::prelude::Solve;
use faer::{Mat, Side};
use reprise_numerics::gplvm::kernel::rbf_vector;
use reprise_numerics::gplvm::{GplvmError, Hyper, Likelihood, LikelihoodConfig, MeanPredictor};
use reprise_numerics::lbfgs::{lbfgs, LbfgsOptions};
use reprise_numerics::optim::OptInfo;
use reprise_numerics::pca::{Pca, PcaParams};

use crate::lle;

/// One observation space: its data and the latent rows it owns.
#[derive(Debug, Clone, PartialEq)]
pub struct Space<'a> {
    /// Row-major data, one row per owned latent.
    pub data: &'a [f64],
    /// Values per row.
    pub dim: usize,
    /// The latent row of each data row.
    pub rows: Vec<usize>,
}

/// The objective's workspace.
#[derive(Debug)]
pub struct SharedObjective {
    spaces: Vec<(Likelihood, Vec<usize>)>,
    n: usize,
    q: usize,
    prior: Option<Mat<f64>>,
}

impl SharedObjective {
    /// A workspace for `n` latents of `q` dimensions over two (or more) spaces, with the
    /// prior matrix $L$ ([`lle::prior_matrix`]) or none.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for a row out of range, a space whose rows do not match its
    /// data, or a prior of the wrong size; the likelihood's own errors.
    pub fn new(
        spaces: &[Space<'_>],
        n: usize,
        q: usize,
        prior: Option<Mat<f64>>,
        config: LikelihoodConfig,
    ) -> Result<Self, GplvmError> {
        let mut out = Vec::with_capacity(spaces.len());
        for (k, s) in spaces.iter().enumerate() {
            if s.rows.iter().any(|&r| r >= n) || s.dim == 0 || s.data.len() != s.rows.len() * s.dim {
                return Err(GplvmError::Shape(format!(
                    "space {k}: {} values for {} rows of {} (rows must be latents below {n})",
                    s.data.len(),
                    s.rows.len(),
                    s.dim
                )));
            }
            out.push((Likelihood::new(s.data, s.dim, q, config)?, s.rows.clone()));
        }
        if prior.as_ref().is_some_and(|l| l.nrows() != n || l.ncols() != n) {
            return Err(GplvmError::Shape(format!("the prior matrix is not {n} × {n}")));
        }
        Ok(Self { spaces: out, n, q, prior })
    }

    /// Parameters: $nq$ latents and 3 log hyperparameters per space.
    pub fn len(&self) -> usize {
        self.n * self.q + 3 * self.spaces.len()
    }

    /// Whether there are no parameters (never).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// $E$ at `params`, its gradient written into `grad`.
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for wrong lengths; the likelihood's errors (a kernel that will
    /// not factor).
    pub fn evaluate(&mut self, params: &[f64], grad: &mut [f64]) -> Result<f64, GplvmError> {
        let (n, q) = (self.n, self.q);
        if params.len() != self.len() || grad.len() != self.len() {
            return Err(GplvmError::Shape(format!("{} parameters expected", self.len())));
        }
        grad.fill(0.0);
        let z = &params[..n * q];
        let mut value = 0.0;
        for (k, (lik, rows)) in self.spaces.iter_mut().enumerate() {
            let h = n * q + 3 * k;
            let hyper = Hyper::from_log([params[h], params[h + 1], params[h + 2]]);
            let zs: Vec<f64> = rows.iter().flat_map(|&r| z[r * q..(r + 1) * q].iter().copied()).collect();
            let mut gz = vec![0.0; zs.len()];
            let e = lik.evaluate(&zs, &hyper, &mut gz)?;
            value += e.value;
            for (i, &r) in rows.iter().enumerate() {
                for j in 0..q {
                    grad[r * q + j] += gz[i * q + j];
                }
            }
            let g = e.grad_hyper_log(&hyper);
            grad[h] += g.rbf_variance;
            grad[h + 1] += g.lengthscale;
            grad[h + 2] += g.white_variance;
        }
        if let Some(l) = &self.prior {
            let (v, g) = lle::prior(l, z, q);
            value += v;
            for (a, b) in grad.iter_mut().zip(g) {
                *a += b;
            }
        }
        Ok(value)
    }
}

/// Initial latents: every row with source data at its first `q` source principal
/// coordinates, each target-only row at the latent of the labelled row nearest to it in the
/// target space, other rows at 0. (An alternative to the paper's semi-supervised manifold
/// alignment, Ham et al. 2005; it is to be measured against it.)
///
/// # Errors
/// [`GplvmError::Shape`] when the source has fewer than two rows or no variance, or when a
/// target-only row has no labelled row to start from.
pub fn initial_latents(source: &Space<'_>, target: &Space<'_>, n: usize, q: usize) -> Result<Vec<f64>, GplvmError> {
    let pca = Pca::fit(source.data, source.dim, &PcaParams { variance: 1.0, min_components: q, max_components: q })
        .map_err(|e| GplvmError::Shape(format!("the source space: {e}")))?;
    let mut z = vec![0.0; n * q];
    for (i, &r) in source.rows.iter().enumerate() {
        let c = pca.project(&source.data[i * source.dim..(i + 1) * source.dim], q);
        z[r * q..r * q + c.len()].copy_from_slice(&c);
    }
    // Unit variance along the first coordinate, the kernel's initial length scale.
    let sd = (source.rows.iter().map(|&r| z[r * q].powi(2)).sum::<f64>() / source.rows.len().max(1) as f64).sqrt();
    if sd > 0.0 {
        z.iter_mut().for_each(|v| *v /= sd);
    }
    let labelled: Vec<(usize, usize)> =
        target.rows.iter().enumerate().filter(|(_, r)| source.rows.contains(r)).map(|(i, &r)| (i, r)).collect();
    let t = |i: usize| &target.data[i * target.dim..(i + 1) * target.dim];
    for (i, &r) in target.rows.iter().enumerate().filter(|(_, r)| !source.rows.contains(r)) {
        let d2 = |j: usize| t(i).iter().zip(t(j)).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        let &(_, from) = labelled
            .iter()
            .min_by(|a, b| d2(a.0).total_cmp(&d2(b.0)))
            .ok_or_else(|| GplvmError::Shape("target-only rows need at least one labelled pair".into()))?;
        let start = z[from * q..(from + 1) * q].to_vec();
        z[r * q..(r + 1) * q].copy_from_slice(&start);
    }
    Ok(z)
}

/// Minimises the objective by L-BFGS from `start` (parameters as [`SharedObjective::evaluate`]
/// takes them). A kernel that will not factor counts as $+\infty$, so the line search backs
/// off from it.
pub fn fit(obj: &mut SharedObjective, start: &[f64], opts: &LbfgsOptions) -> (Vec<f64>, OptInfo) {
    let r = lbfgs(
        |p, g| match obj.evaluate(p, g) {
            Ok(v) => v,
            Err(_) => {
                g.fill(0.0);
                f64::INFINITY
            }
        },
        start,
        opts,
    );
    (r.x, r.info)
}

/// The GP mean of one space at any latent (Eq. 16, Eq. 18):
/// $\mu(z) = k(z)^\top (K + \sigma_w^2 I)^{-1} D$ over the rows `space` owns, with its
/// hyperparameters `hyper` and the fitted latents `z` (`n × q`).
///
/// # Errors
/// A kernel matrix that will not factor; bad shapes.
pub fn predictor(space: &Space<'_>, z: &[f64], q: usize, hyper: Hyper) -> Result<MeanPredictor, GplvmError> {
    let zs = owned_latents(space, z, q);
    let m = space.rows.len();
    let k = kernel_matrix(&zs, q, &hyper);
    let mut rhs = Mat::from_fn(m, space.dim, |i, j| space.data[i * space.dim + j]);
    k.llt(Side::Lower)
        .map_err(|_| GplvmError::Shape("the kernel matrix is not positive definite".into()))?
        .solve_in_place(rhs.as_mut());
    let kinv_d = (0..m).flat_map(|i| (0..space.dim).map(move |j| (i, j))).map(|(i, j)| rhs[(i, j)]).collect();
    MeanPredictor::from_parts(zs, kinv_d, q, space.dim, hyper)
}

/// The latents `space` owns, in its rows' order.
pub fn owned_latents(space: &Space<'_>, z: &[f64], q: usize) -> Vec<f64> {
    space.rows.iter().flat_map(|&r| z[r * q..(r + 1) * q].iter().copied()).collect()
}

/// $K = K^{rbf} + \sigma_w^2 I$ over the latents `zs` (`m × q`).
pub fn kernel_matrix(zs: &[f64], q: usize, hyper: &Hyper) -> Mat<f64> {
    let m = zs.len() / q;
    let mut k = Mat::<f64>::zeros(m, m);
    let mut row = vec![0.0; m];
    for i in 0..m {
        rbf_vector(&zs[i * q..(i + 1) * q], zs, hyper, &mut row);
        for (j, v) in row.iter().enumerate() {
            k[(i, j)] = *v;
        }
        k[(i, i)] += hyper.white_variance;
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two spaces over 9 latents: rows 0–3 labelled (both), 4–6 source only, 7–8 target
    /// only; smooth functions of a hidden 1-D parameter.
    fn problem() -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..9).map(|i| f64::from(i) / 8.0).collect();
        let x_rows: Vec<usize> = (0..7).collect();
        let y_rows: Vec<usize> = (0..4).chain(7..9).collect();
        let x: Vec<f64> = x_rows.iter().flat_map(|&r| [t[r].sin(), t[r].cos(), t[r] * t[r]]).collect();
        let y: Vec<f64> = y_rows.iter().flat_map(|&r| [2.0 * t[r] - 1.0, (3.0 * t[r]).sin()]).collect();
        (x, y)
    }

    #[test]
    fn the_gradient_matches_central_differences() {
        let (x, y) = problem();
        let (n, q) = (9, 2);
        let weights_x = lle::weights(&x, 3, 3).unwrap();
        let weights_y = lle::weights(&y, 2, 3).unwrap();
        let x_rows: Vec<usize> = (0..7).collect();
        let y_rows: Vec<usize> = (0..4).chain(7..9).collect();
        let l = lle::prior_matrix(&[(&weights_x, &x_rows), (&weights_y, &y_rows)], n);
        let spaces =
            [Space { data: &x, dim: 3, rows: x_rows.clone() }, Space { data: &y, dim: 2, rows: y_rows.clone() }];
        let mut obj = SharedObjective::new(&spaces, n, q, Some(l), LikelihoodConfig::default()).unwrap();
        let mut p: Vec<f64> = (0..n * q).map(|i| (f64::from(i as u32) * 0.71).sin()).collect();
        p.extend([0.1, -0.2, -2.0, -0.3, 0.2, -1.5]);
        let mut g = vec![0.0; obj.len()];
        let e0 = obj.evaluate(&p, &mut g).unwrap();
        assert!(e0.is_finite());
        let h = 1e-6;
        let mut scratch = vec![0.0; obj.len()];
        for i in 0..p.len() {
            let (mut a, mut b) = (p.clone(), p.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (obj.evaluate(&a, &mut scratch).unwrap() - obj.evaluate(&b, &mut scratch).unwrap()) / (2.0 * h);
            assert!((fd - g[i]).abs() < 1e-5 * (1.0 + g[i].abs()), "∂E/∂p[{i}]: differences {fd}, analytic {}", g[i]);
        }
    }

    #[test]
    fn a_fit_maps_source_only_frames_to_their_targets() {
        let (x, y) = problem();
        let (n, q) = (9, 2);
        let x_rows: Vec<usize> = (0..7).collect();
        let y_rows: Vec<usize> = (0..4).chain(7..9).collect();
        let source = Space { data: &x, dim: 3, rows: x_rows.clone() };
        let target = Space { data: &y, dim: 2, rows: y_rows.clone() };
        let z0 = initial_latents(&source, &target, n, q).unwrap();
        let l = lle::prior_matrix(
            &[(&lle::weights(&x, 3, 3).unwrap(), &x_rows), (&lle::weights(&y, 2, 3).unwrap(), &y_rows)],
            n,
        );
        let mut obj =
            SharedObjective::new(&[source.clone(), target.clone()], n, q, Some(l), LikelihoodConfig::default())
                .unwrap();
        let mut start = z0;
        start.extend([0.0, 0.0, (1e-2f64).ln(), 0.0, 0.0, (1e-2f64).ln()]);
        let mut g = vec![0.0; obj.len()];
        let e0 = obj.evaluate(&start, &mut g).unwrap();
        let (p, info) = fit(&mut obj, &start, &LbfgsOptions::default());
        let e1 = obj.evaluate(&p, &mut g).unwrap();
        assert!(e1 < e0, "the fit lowers the objective: {e0} → {e1} ({info:?})");
        // The target space's mean at the source-only rows' latents against their true targets.
        let h = n * q + 3;
        let hy = Hyper::from_log([p[h], p[h + 1], p[h + 2]]);
        let pred = predictor(&target, &p[..n * q], q, hy).unwrap();
        let truth = |r: usize| {
            let t = r as f64 / 8.0;
            [2.0 * t - 1.0, (3.0 * t).sin()]
        };
        let mut out = [0.0; 2];
        let mut sq = 0.0;
        for r in 4..7 {
            pred.mean(&p[r * q..(r + 1) * q], &mut out);
            sq += out.iter().zip(truth(r)).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        }
        let rms = (sq / 6.0).sqrt();
        // Y's own spread is about 0.6: the mapping recovers the unseen targets far better.
        assert!(rms < 0.2, "RMS {rms} on the source-only rows");
    }

    #[test]
    fn bad_shapes_are_errors() {
        let (x, _) = problem();
        let bad = [Space { data: &x, dim: 3, rows: vec![0, 1, 2, 3, 4, 5, 9] }];
        assert!(SharedObjective::new(&bad, 9, 2, None, LikelihoodConfig::default()).is_err());
        let short = [Space { data: &x[..20], dim: 3, rows: (0..7).collect() }];
        assert!(SharedObjective::new(&short, 9, 2, None, LikelihoodConfig::default()).is_err());
    }
}
