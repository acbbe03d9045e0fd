//! The dynamics prior of Lawrence & Moore 2007 (method.md §2): each latent column is a
//! draw from a GP over time, independently per segment, with fixed hyperparameters.
//!
//! $$E_D = -w\,\psi_D = w\Big[\tfrac12\sum_{k=1}^q x_{:,k}^\top K_t^{-1}x_{:,k} +
//! \tfrac q2\log\lvert K_t\rvert + \tfrac{Nq}2\log 2\pi\Big],\qquad
//! \nabla_X E_D = w\,K_t^{-1}X,$$
//!
//! with $K_t$ block diagonal, one block per segment,
//! $[K_t^{(s)}]_{ab} = \sigma_t^2\exp(-(t_a-t_b)^2/(2\ell_t^2)) + \sigma_{tw}^2\delta_{ab}$, and
//! $w$ an optional weight on the whole log density. The blocks are factored once at
//! construction (a one-off $\sum_s n_s^3/3$); an evaluation costs $O(q\sum_s n_s^2)$.
//! Frames may come in any order: blocks gather their rows by segment id. The constant
//! terms are included so that the value is exactly $-w\log\mathcal N$.

use std::collections::HashMap;
use std::hash::Hash;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::triangular_solve;
use faer::{Mat, Par};

use super::params::{cholesky_with_jitter, JitterUsed};
use super::{GplvmError, Jitter};

/// Fixed hyperparameters of the time kernel, and the prior's weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicsParams {
    /// $\sigma_t^2$ (default 1, matching unit-variance latent columns).
    pub rbf_variance: f64,
    /// $\ell_t$, in the units of the times given (default 5, meant for frame indices at
    /// 24 fps: 0.2 s; method.md §2.2 suggests 3–10 frames).
    pub lengthscale: f64,
    /// $\sigma_{tw}^2$ (default $10^{-4}$; never 0 — the RBF Gram matrix of a dense grid
    /// is numerically singular).
    pub white_variance: f64,
    /// $w$ (default 1).
    pub weight: f64,
    /// Jitter policy for the block factorisations (default: none, escalation as GPy).
    pub jitter: Jitter,
}

impl Default for DynamicsParams {
    fn default() -> Self {
        Self {
            rbf_variance: 1.0,
            lengthscale: 5.0,
            white_variance: 1e-4,
            weight: 1.0,
            jitter: Jitter { base: 0.0, ..Jitter::GPY },
        }
    }
}

#[derive(Debug, Clone)]
struct Block {
    rows: Vec<usize>,
    chol: Mat<f64>,
}

/// The factored dynamics prior for fixed frame times and segments.
#[derive(Debug, Clone)]
pub struct DynamicsPrior {
    n: usize,
    q: usize,
    params: DynamicsParams,
    blocks: Vec<Block>,
    constant: f64,
    jitter: JitterUsed,
    rhs: Mat<f64>,
}

impl DynamicsPrior {
    /// Builds and factors $K_t$ for `times[i]` and `segments[i]` of frame `i` (frames with
    /// equal segment ids form one block), for latent dimension `q`.
    pub fn new<S: Eq + Hash + Clone>(
        times: &[f64],
        segments: &[S],
        q: usize,
        params: DynamicsParams,
    ) -> Result<Self, GplvmError> {
        let n = times.len();
        if n == 0 || segments.len() != n || q == 0 {
            return Err(GplvmError::Shape(format!(
                "dynamics prior needs one time and one segment per frame, got {n} times and {} segments (q = {q})",
                segments.len()
            )));
        }
        let p = &params;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !(pos(p.rbf_variance)
            && pos(p.lengthscale)
            && pos(p.white_variance)
            && p.weight.is_finite()
            && p.weight >= 0.0)
        {
            return Err(GplvmError::Params(format!("dynamics parameters must be positive and finite, got {p:?}")));
        }
        if times.iter().any(|t| !t.is_finite()) {
            return Err(GplvmError::NonFinite("frame time"));
        }
        let mut order: HashMap<S, usize> = HashMap::new();
        let mut rows: Vec<Vec<usize>> = Vec::new();
        for (i, s) in segments.iter().enumerate() {
            let b = *order.entry(s.clone()).or_insert_with(|| {
                rows.push(Vec::new());
                rows.len() - 1
            });
            rows[b].push(i);
        }
        let c = -0.5 / (p.lengthscale * p.lengthscale);
        let mut blocks = Vec::with_capacity(rows.len());
        let mut logdet = 0.0;
        let mut jitter = JitterUsed::default();
        let max_len = rows.iter().map(Vec::len).max().unwrap_or(0);
        let mut mem =
            MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(max_len, Par::Seq, Default::default()));
        for r in rows {
            let m = r.len();
            let mut chol = Mat::<f64>::zeros(m, m);
            let fill = |mut k: faer::MatMut<'_, f64>| {
                for a in 0..m {
                    for b in a..m {
                        let dt = times[r[b]] - times[r[a]];
                        k[(b, a)] = p.rbf_variance * (c * dt * dt).exp() + if a == b { p.white_variance } else { 0.0 };
                    }
                }
            };
            let used = cholesky_with_jitter(chol.as_mut(), fill, &p.jitter, "K_t", Par::Seq, MemStack::new(&mut mem))?;
            if used.added > jitter.added {
                jitter = used;
            }
            logdet += 2.0 * (0..m).map(|i| chol[(i, i)].ln()).sum::<f64>();
            blocks.push(Block { rows: r, chol });
        }
        let constant = p.weight * 0.5 * (q as f64 * logdet + (n * q) as f64 * (2.0 * std::f64::consts::PI).ln());
        Ok(Self { n, q, params, blocks, constant, jitter, rhs: Mat::zeros(max_len, q) })
    }

    /// Number of frames $N$.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of segments (blocks).
    pub fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    /// The parameters.
    pub fn params(&self) -> &DynamicsParams {
        &self.params
    }

    /// The largest jitter any block needed.
    pub fn jitter_used(&self) -> JitterUsed {
        self.jitter
    }

    /// The constant part $w[\tfrac q2\log\lvert K_t\rvert + \tfrac{Nq}2\log 2\pi]$ of $E_D$.
    pub fn constant(&self) -> f64 {
        self.constant
    }

    /// The whitening map $X = L_tZ$ ($K_t = L_tL_t^\top$ block by block, row-major `N × q`):
    /// in $Z$ the prior is $\tfrac w2\lVert Z\rVert_F^2$ + const, perfectly conditioned,
    /// which is why the fit optimises $Z$ (see `fit`).
    pub fn unwhiten(&self, z: &[f64], x: &mut [f64]) {
        let q = self.q;
        for b in &self.blocks {
            for (a, &i) in b.rows.iter().enumerate().rev() {
                for k in 0..q {
                    x[i * q + k] = (0..=a).map(|c| b.chol[(a, c)] * z[b.rows[c] * q + k]).sum();
                }
            }
        }
    }

    /// $Z = L_t^{-1}X$, the inverse of [`Self::unwhiten`].
    pub fn whiten(&self, x: &[f64], z: &mut [f64]) {
        let q = self.q;
        for b in &self.blocks {
            for (a, &i) in b.rows.iter().enumerate() {
                for k in 0..q {
                    let done: f64 = (0..a).map(|c| b.chol[(a, c)] * z[b.rows[c] * q + k]).sum();
                    z[i * q + k] = (x[i * q + k] - done) / b.chol[(a, a)];
                }
            }
        }
    }

    /// The gradient in $Z$ from the gradient in $X = L_tZ$: $\nabla_Z = L_t^\top\nabla_X$.
    pub fn grad_to_white(&self, gx: &[f64], gz: &mut [f64]) {
        let q = self.q;
        for b in &self.blocks {
            for (c, &j) in b.rows.iter().enumerate() {
                for k in 0..q {
                    gz[j * q + k] = (c..b.rows.len()).map(|a| b.chol[(a, c)] * gx[b.rows[a] * q + k]).sum();
                }
            }
        }
    }

    /// Returns $E_D(X)$ and **adds** $\nabla_X E_D = wK_t^{-1}X$ to `grad` (row-major `N × q`).
    pub fn value_grad_add(&mut self, x: &[f64], grad: &mut [f64]) -> Result<f64, GplvmError> {
        let (n, q) = (self.n, self.q);
        if x.len() != n * q || grad.len() != n * q {
            return Err(GplvmError::Shape(format!(
                "dynamics prior: x and grad need N·q = {} values, got {} and {}",
                n * q,
                x.len(),
                grad.len()
            )));
        }
        let w = self.params.weight;
        let mut quad = 0.0;
        for b in &self.blocks {
            let m = b.rows.len();
            let mut rhs = self.rhs.as_mut().subrows_mut(0, m);
            for (a, &i) in b.rows.iter().enumerate() {
                for k in 0..q {
                    rhs[(a, k)] = x[i * q + k];
                }
            }
            triangular_solve::solve_lower_triangular_in_place(b.chol.as_ref(), rhs.as_mut(), Par::Seq);
            triangular_solve::solve_upper_triangular_in_place(b.chol.transpose(), rhs.as_mut(), Par::Seq);
            for (a, &i) in b.rows.iter().enumerate() {
                for k in 0..q {
                    let s = rhs[(a, k)];
                    quad += x[i * q + k] * s;
                    grad[i * q + k] += w * s;
                }
            }
        }
        let value = 0.5 * w * quad + self.constant;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(GplvmError::NonFinite("dynamics prior"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gplvm::testutil::{central_diff, max_rel_err, random_problem};

    fn three_segments(n: usize) -> (Vec<f64>, Vec<u32>) {
        // Interleaved segment ids so that blocks must be gathered, times = index within segment.
        let seg: Vec<u32> = (0..n).map(|i| (i % 3) as u32).collect();
        let times: Vec<f64> = (0..n).map(|i| (i / 3) as f64 * 0.7).collect();
        (times, seg)
    }

    /// The gradient equals central finite differences of the value (1e-7 relative).
    #[test]
    fn gradient_matches_finite_differences() {
        let (n, q) = (31, 3);
        let (x, _) = random_problem(n, 1, q, 11);
        let (times, seg) = three_segments(n);
        let params = DynamicsParams { lengthscale: 1.5, white_variance: 1e-2, weight: 0.7, ..Default::default() };
        let mut prior = DynamicsPrior::new(&times, &seg, q, params).unwrap();
        assert_eq!(prior.n_blocks(), 3);
        let mut g = vec![0.0; n * q];
        prior.value_grad_add(&x, &mut g).unwrap();
        let mut scratch = vec![0.0; n * q];
        let fd = central_diff(&x, 1e-4, |xp| prior.value_grad_add(xp, &mut scratch).unwrap());
        let err = max_rel_err(&g, &fd);
        eprintln!("{}:{} max relative error {err:.1e}", file!(), line!());
        assert!(err < 1e-7, "{err:e}");
    }

    /// Blocks are independent: moving a point of one segment (in latent dimension 0)
    /// changes the dimension-0 gradient of every point of its segment and of no other, and
    /// never the dimension-1 gradient (latent dimensions are independent too).
    /// Whitening: unwhiten ∘ whiten is the identity, the prior in Z is w/2 ‖Z‖² + const,
    /// and grad_to_white is the transpose of unwhiten (⟨L z, g⟩ = ⟨z, Lᵀg⟩).
    #[test]
    fn whitening_round_trips_and_is_adjoint() {
        let (n, q) = (23, 2);
        let times: Vec<f64> = (0..n).map(|i| (i / 3) as f64).collect();
        let seg: Vec<usize> = (0..n).map(|i| i % 3).collect();
        let p = DynamicsParams { lengthscale: 2.0, weight: 0.7, ..Default::default() };
        let mut prior = DynamicsPrior::new(&times, &seg, q, p).unwrap();
        let x: Vec<f64> = (0..n * q).map(|i| ((i * 37 % 11) as f64 - 5.0) / 3.0).collect();
        let (mut z, mut back) = (vec![0.0; n * q], vec![0.0; n * q]);
        prior.whiten(&x, &mut z);
        prior.unwhiten(&z, &mut back);
        assert!(x.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-9), "{x:?} {back:?}");
        let mut g = vec![0.0; n * q];
        let v = prior.value_grad_add(&x, &mut g).unwrap();
        let zz: f64 = z.iter().map(|v| v * v).sum();
        assert!((v - (0.5 * 0.7 * zz + prior.constant())).abs() < 1e-8 * v.abs(), "{v}");
        let gv: Vec<f64> = (0..n * q).map(|i| ((i * 13 % 7) as f64 - 3.0) / 2.0).collect();
        let mut lz = vec![0.0; n * q];
        prior.unwhiten(&z, &mut lz);
        let mut ltg = vec![0.0; n * q];
        prior.grad_to_white(&gv, &mut ltg);
        let lhs: f64 = lz.iter().zip(&gv).map(|(a, b)| a * b).sum();
        let rhs: f64 = z.iter().zip(&ltg).map(|(a, b)| a * b).sum();
        assert!((lhs - rhs).abs() < 1e-10 * lhs.abs().max(1.0), "{lhs} {rhs}");
    }

    #[test]
    fn blocks_do_not_interact() {
        let (n, q) = (30, 2);
        let (mut x, _) = random_problem(n, 1, q, 12);
        let (times, seg) = three_segments(n);
        let mut prior = DynamicsPrior::new(&times, &seg, q, DynamicsParams::default()).unwrap();
        let mut g0 = vec![0.0; n * q];
        prior.value_grad_add(&x, &mut g0).unwrap();
        x[4 * q] += 0.3; // frame 4 is in segment 1
        let mut g1 = vec![0.0; n * q];
        prior.value_grad_add(&x, &mut g1).unwrap();
        for i in 0..n {
            assert_eq!(g0[i * q] == g1[i * q], seg[i] != 1, "frame {i}");
            assert_eq!(g0[i * q + 1], g1[i * q + 1], "frame {i}, dimension 1");
        }
    }

    /// ℓ_t → 0 makes K_t = (σ_t² + σ_tw²)I: E_D = ½‖X‖²/v + (Nq/2) log(2πv).
    #[test]
    fn short_lengthscale_is_isotropic_gaussian() {
        let (n, q) = (20, 3);
        let (x, _) = random_problem(n, 1, q, 13);
        let (times, seg) = three_segments(n);
        let params = DynamicsParams { lengthscale: 1e-3, rbf_variance: 0.8, white_variance: 0.2, ..Default::default() };
        let mut prior = DynamicsPrior::new(&times, &seg, q, params).unwrap();
        let mut g = vec![0.0; n * q];
        let v = prior.value_grad_add(&x, &mut g).unwrap();
        let xx: f64 = x.iter().map(|v| v * v).sum();
        let want = 0.5 * xx / 1.0 + 0.5 * (n * q) as f64 * (2.0 * std::f64::consts::PI).ln();
        assert!((v - want).abs() < 1e-12 * want.abs(), "{v} vs {want}");
        assert!(g.iter().zip(&x).all(|(g, x)| (g - x).abs() < 1e-12));
    }

    /// Single-frame segments are fine; mismatched shapes and bad parameters are errors.
    #[test]
    fn edge_cases() {
        let mut p = DynamicsPrior::new(&[0.0, 0.0], &[1, 2], 1, DynamicsParams::default()).unwrap();
        assert_eq!(p.n_blocks(), 2);
        let mut g = vec![0.0; 2];
        p.value_grad_add(&[1.0, 2.0], &mut g).unwrap();
        assert!((g[0] - 1.0 / 1.0001).abs() < 1e-12 && (g[1] - 2.0 / 1.0001).abs() < 1e-12);
        assert!(DynamicsPrior::new(&[0.0], &[1, 2], 1, DynamicsParams::default()).is_err());
        let bad = DynamicsParams { white_variance: 0.0, ..Default::default() };
        assert!(matches!(DynamicsPrior::new(&[0.0], &[1], 1, bad), Err(GplvmError::Params(_))));
    }
}
