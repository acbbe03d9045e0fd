//! The RBF part of the kernel, $K^{rbf}_{ij} = \sigma_f^2\exp(-D_{ij}/(2\ell^2))$ with
//! $D_{ij} = \lVert x_i - x_j\rVert^2$, as a Gram matrix (lower triangle) and as the
//! cross-covariance vector of a test point. The white term lives on the diagonal and is
//! added by the callers.

use faer::reborrow::ReborrowMut;
use faer::MatMut;

use super::Hyper;

/// $\lVert a - b\rVert^2$.
#[inline]
pub fn sq_dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| (a - b) * (a - b)).sum()
}

/// Copies a row-major `n × q` matrix to per-dimension columns (`q` contiguous runs of
/// `n`), the layout the $O(N^2)$ loops vectorise over.
pub(crate) fn columns(x: &[f64], n: usize, q: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(n * q, 0.0);
    for (i, row) in x.chunks_exact(q).enumerate() {
        for (k, v) in row.iter().enumerate() {
            out[k * n + i] = *v;
        }
    }
}

/// Squared distances from point `j` to points `j..n`, written to `out[j..n]`, with `xc`
/// the per-dimension columns of $X$.
#[inline(always)]
pub(crate) fn sq_dists_below(xc: &[f64], n: usize, q: usize, j: usize, out: &mut [f64]) {
    let out = &mut out[j..n];
    out.fill(0.0);
    for k in 0..q {
        let col = &xc[k * n..(k + 1) * n];
        let xj = col[j];
        for (o, xi) in out.iter_mut().zip(&col[j..]) {
            let d = xi - xj;
            *o += d * d;
        }
    }
}

/// The pairwise-difference gradient pass for column `j` of a symmetric weight matrix $B$:
/// for every dimension $k$ and $i > j$, `gx[k][i] += b[i]·(x_ik − x_jk)` and
/// `gx[k][j] −= Σ_i b[i]·(x_ik − x_jk)`; `gx` and `xc` are per-dimension columns and `b`
/// holds $B_{ij}$ at indices `j+1..n`. Summed over `j` this gives
/// $\sum_j B_{ij}(x_i - x_j)$, the shape of every latent gradient here. Four independent
/// partial sums let the reduction vectorise.
#[inline(always)]
pub(crate) fn pair_grad_pass(xc: &[f64], gx: &mut [f64], n: usize, q: usize, j: usize, b: &[f64]) {
    let b = &b[j + 1..n];
    for k in 0..q {
        let xcol = &xc[k * n..(k + 1) * n];
        let xj = xcol[j];
        let gcol = &mut gx[k * n..(k + 1) * n];
        let (gj, rest) = gcol[j..].split_first_mut().expect("j < n");
        let xs = &xcol[j + 1..];
        let mut acc = [0.0; 4];
        let mut gi4 = rest.chunks_exact_mut(4);
        let mut xs4 = xs.chunks_exact(4);
        let mut b4 = b.chunks_exact(4);
        for ((g, x), bb) in (&mut gi4).zip(&mut xs4).zip(&mut b4) {
            for l in 0..4 {
                let t = bb[l] * (x[l] - xj);
                g[l] += t;
                acc[l] += t;
            }
        }
        let mut tail = 0.0;
        for ((g, x), bb) in gi4.into_remainder().iter_mut().zip(xs4.remainder()).zip(b4.remainder()) {
            let t = bb * (x - xj);
            *g += t;
            tail += t;
        }
        *gj -= (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail;
    }
}

/// Runs `op` compiled for the widest SIMD instruction set this CPU has (AVX2/FMA,
/// AVX-512; pulp's runtime dispatch, in safe code), so that the O(N²) passes inlined into
/// its `#[inline(always)]` body vectorise beyond the x86-64 baseline. No FMA contraction
/// happens, so results are bit-identical to the baseline build.
#[inline(always)]
pub(crate) fn vectorised<Op: pulp::WithSimd>(op: Op) -> Op::Output {
    pulp::Arch::new().dispatch(op)
}

/// The loop of [`rbf_lower`], as a [`pulp::WithSimd`] so that it is compiled per ISA.
struct RbfLower<'a, 'k> {
    k: MatMut<'k, f64>,
    xc: &'a [f64],
    q: usize,
    s2: f64,
    c: f64,
    dist: &'a mut [f64],
}

impl pulp::WithSimd for RbfLower<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let Self { mut k, xc, q, s2, c, dist } = self;
        let n = k.nrows();
        for j in 0..n {
            sq_dists_below(xc, n, q, j, dist);
            let col = k.rb_mut().col_mut(j).try_as_col_major_mut().expect("column-major");
            let col = col.as_slice_mut();
            for (o, d) in col[j..].iter_mut().zip(&dist[j..n]) {
                *o = s2 * exp_nonpositive(c * d);
            }
        }
    }
}

/// Writes the lower triangle (diagonal included) of $K^{rbf}$ into `k`; `xc` are the
/// per-dimension columns of $X$ ([`columns`]) and `dist` a scratch of length `n`.
pub(crate) fn rbf_lower(mut k: MatMut<'_, f64>, xc: &[f64], q: usize, hyper: &Hyper, dist: &mut [f64]) {
    let s2 = hyper.rbf_variance;
    let c = -0.5 / (hyper.lengthscale * hyper.lengthscale);
    vectorised(RbfLower { k: k.rb_mut(), xc, q, s2, c, dist });
}

/// $e^x$ for $x\le 0$ (larger $x$ are treated as 0), branch-free so that the Gram-matrix
/// loop vectorises: Cody–Waite reduction $x = k\ln 2 + r$, $\lvert r\rvert\le\ln 2/2$, a
/// degree-13 Taylor polynomial for $e^r$ (truncation below $10^{-17}$) in Estrin form, and $2^k$ built
/// from its bits. Relative error within a few ulp of `f64::exp` (tested); results below
/// $e^{-708}$ (subnormal) are flushed to 0.
#[inline(always)]
pub(crate) fn exp_nonpositive(x: f64) -> f64 {
    const LOG2E: f64 = std::f64::consts::LOG2_E;
    // fdlibm's split of ln 2: LN2_HI has trailing zero bits, so k·LN2_HI is exact.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52: adding it rounds to an integer
    let xc = x.clamp(-708.0, 0.0);
    let t = xc * LOG2E + SHIFT;
    let kf = t - SHIFT;
    let k = t.to_bits() as i64 - SHIFT.to_bits() as i64;
    let r = (xc - kf * LN2_HI) - kf * LN2_LO;
    // Estrin's scheme: a short dependency chain (Horner's 14 serial steps made this loop
    // latency-bound).
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let a0 = 1.0 + r;
    let a1 = 0.5 + r * (1.0 / 6.0);
    let a2 = 1.0 / 24.0 + r * (1.0 / 120.0);
    let a3 = 1.0 / 720.0 + r * (1.0 / 5_040.0);
    let a4 = 1.0 / 40_320.0 + r * (1.0 / 362_880.0);
    let a5 = 1.0 / 3_628_800.0 + r * (1.0 / 39_916_800.0);
    let a6 = 1.0 / 479_001_600.0 + r * (1.0 / 6_227_020_800.0);
    let b0 = a0 + r2 * a1;
    let b1 = a2 + r2 * a3;
    let b2 = a4 + r2 * a5;
    let c0 = b0 + r4 * b1;
    let c1 = b2 + r4 * a6;
    let p = c0 + r8 * c1;
    let scale = f64::from_bits(((k + 1023) << 52) as u64);
    if x < -708.0 {
        0.0
    } else {
        p * scale
    }
}

/// The cross-covariance $k_i = K^{rbf}(x_*, x_i)$ of a test point with every row of the
/// row-major `x`.
pub fn rbf_vector(x_star: &[f64], x: &[f64], hyper: &Hyper, out: &mut [f64]) {
    let q = x_star.len();
    let c = -0.5 / (hyper.lengthscale * hyper.lengthscale);
    for (o, xi) in out.iter_mut().zip(x.chunks_exact(q)) {
        *o = hyper.rbf_variance * exp_nonpositive(c * sq_dist(x_star, xi));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The branch-free exponential is within 4 ulp (relative 1e-15) of `f64::exp` over
    /// [−708, 0], exact at 0, and 0 below −708 (subnormals flushed).
    #[test]
    fn exp_matches_std() {
        let mut worst: f64 = 0.0;
        let m = 2_000_000;
        for i in 0..=m {
            let x = -708.0 * (i as f64 / m as f64).powi(3);
            let (a, b) = (exp_nonpositive(x), x.exp());
            worst = worst.max((a - b).abs() / b);
        }
        for x in [-1e-300, -1e-17, -0.3465, -0.3466, -0.5, -1.0, -2.0f64.ln()] {
            worst = worst.max((exp_nonpositive(x) - x.exp()).abs() / x.exp());
        }
        assert!(worst < 4.0 * f64::EPSILON, "{worst:e}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert_eq!(exp_nonpositive(-709.0), 0.0);
        assert_eq!(exp_nonpositive(f64::NEG_INFINITY), 0.0);
    }

    /// The lower triangle matches the defining formula entry by entry.
    #[test]
    fn gram_matches_definition() {
        let (n, q) = (5, 2);
        let x: Vec<f64> = (0..n * q).map(|i| (i as f64 * 0.37).sin()).collect();
        let h = Hyper { rbf_variance: 1.7, lengthscale: 0.8, white_variance: 0.1 };
        let mut xc = Vec::new();
        columns(&x, n, q, &mut xc);
        let mut k = faer::Mat::<f64>::zeros(n, n);
        let mut dist = vec![0.0; n];
        rbf_lower(k.as_mut(), &xc, q, &h, &mut dist);
        let mut v = vec![0.0; n];
        for i in 0..n {
            rbf_vector(&x[i * q..(i + 1) * q], &x, &h, &mut v);
            for j in 0..=i {
                let want = 1.7 * (-sq_dist(&x[i * q..(i + 1) * q], &x[j * q..(j + 1) * q]) / (2.0 * 0.64)).exp();
                assert!((k[(i, j)] - want).abs() < 1e-15 * want.max(1e-300), "{i} {j}");
                assert!((v[j] - want).abs() < 1e-15 * want.max(1e-300));
            }
        }
    }
}
