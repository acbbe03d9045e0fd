//! What later stages ask of a fitted latent space: how probable a latent point is
//! ([`LatentDensity`]) and which latent point best explains a given output
//! ([`best_latent`], the inverse problem of the paper's §5.2, Eq. 15).

use rand::{Rng, SeedableRng};

use super::kernel::{exp_nonpositive, sq_dist, vectorised};

use super::MeanPredictor;
use crate::scg::{scg, ScgOptions};

/// The latent density $p(x\mid M)$ that the synthesis force of the paper's Eq. 11–12
/// pushes toward: a Gaussian kernel density estimate over the $N$ training latents,
///
/// $$p(x\mid M) = \frac1N\sum_{i=1}^N \mathcal N(x;\,x_i,\,h^2 I_q),\qquad h = c\,\ell,$$
///
/// with $\ell$ the GPLVM's RBF length scale and $c$ the bandwidth factor, and its
/// gradient $\nabla p = -\frac1{Nh^2}\sum_i \mathcal N(x; x_i, h^2I)(x - x_i)$.
///
/// Why this and not the GP's own predictive variance: the paper wants "probable" regions,
/// where reconstructions are trustworthy. Those are the regions near training latents at
/// the scale on which the GP correlates points, $\ell$ — exactly what this estimate
/// measures. It is a proper density, smooth, positive everywhere, with a gradient that
/// points toward the data from any distance (the predictive variance saturates at
/// $\sigma_f^2$ away from the data, so its gradient vanishes exactly where a restoring
/// force is needed), and it costs $O(Nq)$ per point with its gradient, not the $O(N^2)$
/// the paper reports for its GP derivatives.
///
/// [`LatentDensity::relative`] divides by the mean density at the training points, so
/// that the sigmoid threshold $v$ of Eq. 11 is scale-free ($v = 0.1$: a tenth of the
/// typical density at the data).
#[derive(Debug, Clone, PartialEq)]
pub struct LatentDensity {
    q: usize,
    x: Vec<f64>,
    /// The points as per-dimension columns (`q × N`).
    xc: Vec<f64>,
    bandwidth: f64,
    norm: f64,
    reference: f64,
}

impl LatentDensity {
    /// The estimate over `x` (row-major `N × q`) with bandwidth `h > 0`.
    pub fn from_points(x: Vec<f64>, q: usize, h: f64) -> Self {
        assert!(h > 0.0 && h.is_finite(), "bandwidth must be positive");
        assert!(q > 0 && !x.is_empty() && x.len().is_multiple_of(q), "x must be N × q");
        let n = x.len() / q;
        let norm = (2.0 * std::f64::consts::PI * h * h).powf(-(q as f64) / 2.0) / n as f64;
        let xc = (0..q).flat_map(|k| x.chunks_exact(q).map(move |r| r[k])).collect();
        let mut me = Self { q, x, xc, bandwidth: h, norm, reference: 1.0 };
        let mut g = vec![0.0; q];
        let total: f64 = (0..n).map(|i| me.density_grad(&me.x[i * q..(i + 1) * q], &mut g)).sum();
        me.reference = total / n as f64;
        me
    }

    /// The bandwidth $h$.
    pub fn bandwidth(&self) -> f64 {
        self.bandwidth
    }

    /// The mean density at the training points (the unit of [`Self::relative`]).
    pub fn reference(&self) -> f64 {
        self.reference
    }

    /// $p(x\mid M)$, with $\nabla_x p$ written into `grad` (length $q$).
    pub fn density_grad(&self, x: &[f64], grad: &mut [f64]) -> f64 {
        assert_eq!(x.len(), self.q, "x must have q values");
        assert_eq!(grad.len(), self.q, "grad must have q values");
        let c = -0.5 / (self.bandwidth * self.bandwidth);
        let p = vectorised(DensityPass { xc: &self.xc, x, c, grad });
        grad.iter_mut().for_each(|g| *g *= self.norm);
        p * self.norm
    }

    /// $p(x\mid M)$ divided by [`Self::reference`], and its gradient likewise.
    pub fn relative(&self, x: &[f64], grad: &mut [f64]) -> f64 {
        let p = self.density_grad(x, grad);
        grad.iter_mut().for_each(|g| *g /= self.reference);
        p / self.reference
    }
}

/// Points per block of the per-ISA passes (distances, kernel values on the stack).
const BLOCK: usize = 64;

/// $\sum_i e^{c\lVert x - x_i\rVert^2}$ and its gradient (unnormalised), over the points in
/// per-dimension columns `xc` (`q × N`), block by block so that every inner loop runs over
/// points and vectorises; compiled per ISA.
struct DensityPass<'a> {
    xc: &'a [f64],
    x: &'a [f64],
    c: f64,
    grad: &'a mut [f64],
}

impl pulp::WithSimd for DensityPass<'_> {
    type Output = f64;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> f64 {
        let Self { xc, x, c, grad } = self;
        let q = x.len();
        let n = xc.len() / q;
        grad.fill(0.0);
        let mut p = 0.0;
        let mut k = [0.0; BLOCK];
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            let k = &mut k[..len];
            k.fill(0.0);
            for (dim, &xd) in x.iter().enumerate() {
                let col = &xc[dim * n + start..dim * n + start + len];
                k.iter_mut().zip(col).for_each(|(kk, v)| *kk += (xd - v) * (xd - v));
            }
            k.iter_mut().for_each(|kk| *kk = exp_nonpositive(c * *kk));
            p += k.iter().sum::<f64>();
            for (dim, (&xd, g)) in x.iter().zip(grad.iter_mut()).enumerate() {
                let col = &xc[dim * n + start..dim * n + start + len];
                *g += 2.0 * c * k.iter().zip(col).map(|(kk, v)| kk * (xd - v)).sum::<f64>();
            }
        }
        p
    }
}

/// How [`best_latent`] searches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectOptions {
    /// Start from the training latents whose outputs are nearest the target (default 3).
    pub nearest: usize,
    /// Plus this many uniformly random starts in the training latents' bounding box
    /// (default 2).
    pub random: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// The optimiser of each start (default: 100 iterations, tolerances $10^{-6}$ on $x$
    /// and $10^{-10}$ on the squared error).
    pub scg: ScgOptions,
    /// Where the search may go. `Some(m)`: inside the training latents' bounding box
    /// widened by `m` times its extent on each side (`m = 0.25`: a box 1.5 × the latents'
    /// extent), by searching $u$ with $x = c + h\tanh u$ per dimension ($c$ the box's
    /// centre, $h$ its half-width), so a result never leaves it; a result pressed against
    /// the bound is counted ([`Projection::at_bound`]). Far from its latents a GP's mean
    /// reverts to the output mean, so an unbounded search can "match" a pose near the mean
    /// at a point the model knows nothing of. `None` (the default): anywhere.
    pub margin: Option<f64>,
}

impl Default for ProjectOptions {
    fn default() -> Self {
        Self {
            nearest: 3,
            random: 2,
            seed: 0,
            scg: ScgOptions { max_iters: 100, xtol: 1e-6, ftol: 1e-10, ..Default::default() },
            margin: None,
        }
    }
}

/// The outcome of [`best_latent`].
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// The best latent point found (length $q$).
    pub x: Vec<f64>,
    /// $\lVert y - \mu(x)\rVert^2$ there.
    pub sq_error: f64,
    /// Objective evaluations over all starts.
    pub evaluations: usize,
    /// Whether the best point found presses against the bound of
    /// [`ProjectOptions::margin`] (within $10^{-6}$ of its half-width): the search wanted
    /// to go farther from the latents.
    pub at_bound: bool,
}

/// The latent point minimising $E(x) = \lVert y - \mu(x)\rVert^2$ for the target output
/// `y` (length $d$, in the predictor's centred output space), by multi-start SCG with
/// $\nabla E = -2\,(\partial\mu/\partial x)^\top(y - \mu(x))$. The starts are the
/// `latents` (row-major `N × q`: the training latents, or any points of the latent space)
/// whose outputs `train_y` (row-major `N × d`, centred like `y`) are nearest `y`, plus
/// random ones in their bounding box.
pub fn best_latent(
    predictor: &MeanPredictor,
    y: &[f64],
    latents: &[f64],
    train_y: &[f64],
    opts: &ProjectOptions,
) -> Projection {
    let (q, d) = (predictor.q(), predictor.d());
    let n = latents.len() / q;
    assert_eq!(y.len(), d, "the target has d values");
    assert_eq!(latents.len(), n * q, "latents must be N × q");
    assert_eq!(train_y.len(), n * d, "train_y must be N × d");
    let mut order: Vec<(f64, usize)> = train_y.chunks_exact(d).map(|r| sq_dist(r, y)).zip(0..).collect();
    let k = opts.nearest.min(n);
    if k > 0 && k < n {
        order.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
    }
    let mut starts: Vec<Vec<f64>> = order[..k].iter().map(|&(_, i)| latents[i * q..(i + 1) * q].to_vec()).collect();
    let (mut lo, mut hi) = (vec![f64::INFINITY; q], vec![f64::NEG_INFINITY; q]);
    for xi in latents.chunks_exact(q) {
        for c in 0..q {
            lo[c] = lo[c].min(xi[c]);
            hi[c] = hi[c].max(xi[c]);
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    for _ in 0..opts.random {
        starts.push((0..q).map(|c| if hi[c] > lo[c] { rng.gen_range(lo[c]..hi[c]) } else { lo[c] }).collect());
    }
    let mut evaluations = 0;
    // The search variable: x itself, or u with x = c + h tanh(u) inside the widened box.
    let bounds: Option<Bounds> = opts.margin.map(|m| Bounds {
        centre: (0..q).map(|c| 0.5 * (lo[c] + hi[c])).collect(),
        half: (0..q).map(|c| ((0.5 + m) * (hi[c] - lo[c])).max(1e-9)).collect(),
    });
    let mut scratch = Scratch::new(q, d);
    let mut best = Projection { x: starts[0].clone(), sq_error: f64::INFINITY, evaluations: 0, at_bound: false };
    for s in &starts {
        let start = bounds.as_ref().map_or_else(|| s.clone(), |b| b.to_u(s));
        let r = scg(
            |u, g| {
                evaluations += 1;
                search_error(predictor, y, bounds.as_ref(), u, g, &mut scratch)
            },
            &start,
            &opts.scg,
        );
        if r.info.value < best.sq_error {
            best.x = bounds.as_ref().map_or_else(|| r.x.clone(), |b| b.to_x(&r.x));
            best.at_bound = bounds.is_some() && r.x.iter().any(|u| 1.0 - u.tanh().abs() < 1e-6);
            best.sq_error = r.info.value;
        }
    }
    best.evaluations = evaluations;
    best
}

/// The box [`best_latent`] searches with a margin: $x = c + h\tanh u$ per dimension.
struct Bounds {
    centre: Vec<f64>,
    half: Vec<f64>,
}

impl Bounds {
    fn to_x(&self, u: &[f64]) -> Vec<f64> {
        u.iter().zip(self.centre.iter().zip(&self.half)).map(|(u, (c, h))| c + h * u.tanh()).collect()
    }

    /// The search variable of `x` (a point on the bound is moved just inside).
    fn to_u(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.centre.iter().zip(&self.half))
            .map(|(x, (c, h))| ((x - c) / h).clamp(-1.0 + 1e-9, 1.0 - 1e-9).atanh())
            .collect()
    }
}

/// Work space of [`search_error`].
struct Scratch {
    x: Vec<f64>,
    mu: Vec<f64>,
    jac: Vec<f64>,
}

impl Scratch {
    fn new(q: usize, d: usize) -> Self {
        Self { x: vec![0.0; q], mu: vec![0.0; d], jac: vec![0.0; d * q] }
    }
}

/// $E = \lVert y - \mu(x)\rVert^2$ at the search variable `u` ($x = u$ without bounds)
/// and its gradient in `g`: $\nabla_x E = -2\,(\partial\mu/\partial x)^\top(y - \mu)$, times
/// $dx/du = h(1 - \tanh^2 u)$ with bounds.
fn search_error(
    predictor: &MeanPredictor,
    y: &[f64],
    bounds: Option<&Bounds>,
    u: &[f64],
    g: &mut [f64],
    s: &mut Scratch,
) -> f64 {
    let q = u.len();
    match bounds {
        None => s.x.copy_from_slice(u),
        Some(b) => s.x = b.to_x(u),
    }
    predictor.mean_jacobian(&s.x, &mut s.mu, &mut s.jac);
    g.fill(0.0);
    let mut e = 0.0;
    for (j, yj) in y.iter().enumerate() {
        let r = yj - s.mu[j];
        e += r * r;
        g.iter_mut().zip(&s.jac[j * q..(j + 1) * q]).for_each(|(g, jk)| *g -= 2.0 * r * jk);
    }
    if let Some(b) = bounds {
        g.iter_mut().zip(u.iter().zip(&b.half)).for_each(|(g, (u, h))| *g *= h * (1.0 - u.tanh().powi(2)));
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};
    use crate::gplvm::{Hyper, LikelihoodConfig, Predictor};

    /// The density integrates to 1 (1-D, by quadrature), its gradient equals central
    /// differences, and the relative density is 1 on average at the training points.
    #[test]
    fn density_is_normalised_with_exact_gradient() {
        let d1 = LatentDensity::from_points(vec![0.0, 1.0, 3.0], 1, 0.7);
        let mut g = [0.0];
        let integral: f64 = (-8000..11000).map(|i| d1.density_grad(&[i as f64 * 1e-3], &mut g) * 1e-3).sum();
        assert!((integral - 1.0).abs() < 1e-10, "{integral}");
        let (x, _) = random_problem(30, 1, 3, 3);
        let dens = LatentDensity::from_points(x.clone(), 3, 0.6);
        let at = [0.3, -0.2, 0.5];
        let mut grad = [0.0; 3];
        dens.relative(&at, &mut grad);
        let fd = central_diff(&at, 1e-4, |p| dens.relative(p, &mut [0.0; 3]));
        assert!(max_rel_err(&grad, &fd) < 1e-8);
        let mean_rel: f64 = x.chunks(3).map(|p| dens.relative(p, &mut [0.0; 3])).sum::<f64>() / 30.0;
        assert!((mean_rel - 1.0).abs() < 1e-12);
        assert!(dens.relative(&[50.0, 50.0, 50.0], &mut grad) < 1e-100);
    }

    /// A predictor of a random `n`-point problem, and its outputs.
    fn problem(n: usize, d: usize, q: usize, seed: u64, lengthscale: f64) -> (Predictor, Vec<f64>) {
        let (x, y) = random_problem(n, d, q, seed);
        let hyper = Hyper { rbf_variance: 1.0, lengthscale, white_variance: 1e-3 };
        (Predictor::new(&x, &y, d, hyper, &LikelihoodConfig::default()).unwrap(), y)
    }

    /// The output of a training latent projects back to (a point reconstructing) it, and a
    /// perturbed start still finds it.
    #[test]
    fn best_latent_inverts_the_mean() {
        let (d, q) = (6, 2);
        let (p, y) = problem(40, d, q, 8, 0.8);
        let mut target = vec![0.0; d];
        let x_true = [0.37, -0.52];
        p.mean(&x_true, &mut target);
        let opts = ProjectOptions { nearest: 2, random: 3, ..Default::default() };
        let found = best_latent(&p, &target, p.x(), &y, &opts);
        let scale: f64 = target.iter().map(|v| v * v).sum();
        assert!(found.sq_error < 1e-10 * scale, "{found:?}");
        assert!(found.evaluations > 5);
    }

    /// A target near the output mean is matched best far from the latents, where the
    /// mean reverts to it: unbounded, the search goes there; with a margin it stops at the
    /// widened box's edge, saying so.
    #[test]
    fn a_margin_keeps_the_result_near_the_latents() {
        // Outputs far from zero along a line of latents in [-1, 1]: the mean is ≈ 3 + x
        // there and reverts to 0 (the centred output mean) far away.
        let n = 21;
        let x: Vec<f64> = (0..n).map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 + v).collect();
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.5, white_variance: 1e-4 };
        let p = Predictor::new(&x, &y, 1, hyper, &LikelihoodConfig::default()).unwrap();
        let target = [0.05];
        let free = ProjectOptions { nearest: 3, random: 2, ..Default::default() };
        let far = best_latent(&p, &target, p.x(), &y, &free);
        assert!(far.x[0].abs() > 1.5, "the unbounded search leaves the latents: {far:?}");
        let bounded = best_latent(&p, &target, p.x(), &y, &ProjectOptions { margin: Some(0.25), ..free });
        assert!(bounded.x[0].abs() <= 1.5 + 1e-12 && bounded.x[0].abs() > 1.4, "{bounded:?}");
        assert!(bounded.at_bound && !far.at_bound, "{bounded:?}");
        assert!(bounded.sq_error > far.sq_error);
        // A target the model reaches inside the box is found there, not at the bound.
        let mut inner = [0.0];
        p.mean(&[0.3], &mut inner);
        let found = best_latent(&p, &inner, p.x(), &y, &ProjectOptions { margin: Some(0.25), ..free });
        assert!((found.x[0] - 0.3).abs() < 1e-4 && !found.at_bound, "{found:?}");
    }

    /// The bounded search's gradient in u equals central differences (and without bounds
    /// in x).
    #[test]
    fn search_gradient_matches_finite_differences() {
        let (d, q) = (4, 2);
        let (p, _) = problem(25, d, q, 5, 0.7);
        let target = [0.3, -0.1, 0.7, 0.2];
        let bounds = Bounds { centre: vec![0.1, -0.2], half: vec![1.3, 0.9] };
        let mut s = Scratch::new(q, d);
        for b in [None, Some(&bounds)] {
            let at = [0.4, -0.8];
            let mut g = [0.0; 2];
            search_error(&p, &target, b, &at, &mut g, &mut s);
            let fd = central_diff(&at, 1e-5, |u| {
                let mut s = Scratch::new(q, d);
                search_error(&p, &target, b, u, &mut [0.0; 2], &mut s)
            });
            assert!(max_rel_err(&g, &fd) < 1e-6, "{g:?} {fd:?}");
        }
    }
}
