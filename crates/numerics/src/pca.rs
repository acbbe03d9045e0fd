//! Principal component analysis by a dense thin SVD (faer).
//!
//! For samples $Z \in \mathbb{R}^{N\times D}$ (rows = frames) with column mean $\bar z$,
//! $\tilde Z = Z - \mathbf 1\bar z^\top = U\Sigma V^\top$. The principal directions are
//! the columns of $V$ (here stored as rows), coordinates are $Y = \tilde Z V_d$, and the
//! explained variance of the first $d$ components is
//! $v(d) = \sum_{i\le d}\sigma_i^2 / \lVert\tilde Z\rVert_F^2$ (the paper's §4.2, with the
//! total taken over the whole spectrum — not, as linfa-reduction does, over the kept
//! components only).
//!
//! Why not linfa-reduction: its truncated SVD is an iterative LOBPCG from a random start
//! that was measured to panic, return fewer components than asked, or be 2 % off on
//! rig-shaped matrices (`../shared/DEPENDENCIES.md`); a direct decomposition has no such
//! failure mode and takes well under a second at these sizes. A test cross-checks the
//! result against the exact answer of a constructed matrix.

/// How many components to keep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcaParams {
    /// Keep the fewest components whose explained variance reaches this share (0, 1].
    pub variance: f64,
    /// At least this many (when the data has them).
    pub min_components: usize,
    /// At most this many.
    pub max_components: usize,
}

impl Default for PcaParams {
    fn default() -> Self {
        Self { variance: 0.85, min_components: 1, max_components: 64 }
    }
}

/// Why PCA failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PcaError {
    /// Invalid parameters.
    #[error("pca parameters: {0}")]
    Params(String),
    /// Fewer than two samples, or a matrix of the wrong size.
    #[error("pca needs at least 2 samples of {cols} values, got {values} values")]
    Shape {
        /// Values given.
        values: usize,
        /// Columns.
        cols: usize,
    },
    /// All samples are equal: there is no variance to explain.
    #[error("pca: the samples have no variance")]
    NoVariance,
    /// The SVD did not converge.
    #[error("pca: the SVD did not converge")]
    NoConvergence,
}

/// A fitted PCA.
#[derive(Debug, Clone, PartialEq)]
pub struct Pca {
    /// Column mean $\bar z$ (D).
    pub mean: Vec<f64>,
    /// Principal directions, row-major `r × D` (row $i$ = column $i$ of $V$), for every
    /// nonzero singular value; the sign makes each row's largest entry positive.
    pub directions: Vec<f64>,
    /// Singular values, descending (r).
    pub singular_values: Vec<f64>,
    /// $\lVert\tilde Z\rVert_F^2$.
    pub total: f64,
    /// Components kept by the parameters.
    pub kept: usize,
    cols: usize,
}

impl PcaParams {
    fn check(&self) -> Result<(), PcaError> {
        if !(self.variance > 0.0 && self.variance <= 1.0) {
            return Err(PcaError::Params(format!("variance share must be in (0, 1], got {}", self.variance)));
        }
        if self.min_components == 0 || self.min_components > self.max_components {
            return Err(PcaError::Params(format!(
                "need 1 <= min_components <= max_components, got {} and {}",
                self.min_components, self.max_components
            )));
        }
        Ok(())
    }
}

/// The sign convention of a principal direction: its largest entry (by magnitude) is
/// positive.
fn largest_positive(v: &mut [f64]) {
    let big = (0..v.len()).max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs())).unwrap_or(0);
    if v.get(big).is_some_and(|x| *x < 0.0) {
        v.iter_mut().for_each(|x| *x = -*x);
    }
}

impl Pca {
    /// Fits PCA to `z` (row-major, `cols` columns).
    pub fn fit(z: &[f64], cols: usize, params: &PcaParams) -> Result<Self, PcaError> {
        params.check()?;
        if cols == 0 || !z.len().is_multiple_of(cols) || z.len() / cols < 2 {
            return Err(PcaError::Shape { values: z.len(), cols });
        }
        let rows = z.len() / cols;
        let (mean, _) = crate::stats::mean_std(z, cols);
        let centred = faer::Mat::<f64>::from_fn(rows, cols, |i, j| z[i * cols + j] - mean[j]);
        let total: f64 = (0..cols).map(|j| centred.col(j).iter().map(|v| v * v).sum::<f64>()).sum();
        if total <= 0.0 {
            return Err(PcaError::NoVariance);
        }
        let svd = centred.thin_svd().map_err(|_| PcaError::NoConvergence)?;
        let (s, v) = (svd.S().column_vector(), svd.V());
        let tiny = s[0] * f64::EPSILON * rows.max(cols) as f64;
        let r = (0..s.nrows()).take_while(|&i| s[i] > tiny).count();
        let mut directions = Vec::with_capacity(r * cols);
        for i in 0..r {
            let col = v.col(i);
            let mut dir: Vec<f64> = (0..cols).map(|j| col[j]).collect();
            largest_positive(&mut dir);
            directions.extend(dir);
        }
        let singular_values: Vec<f64> = (0..r).map(|i| s[i]).collect();
        let mut pca = Self { mean, directions, singular_values, total, kept: 0, cols };
        let cumulative = pca.cumulative_explained();
        let by_share = cumulative.iter().position(|c| *c >= params.variance - 1e-12).map_or(r, |i| i + 1);
        pca.kept = by_share.clamp(params.min_components.min(r), params.max_components.min(r));
        Ok(pca)
    }

    /// The top `k` principal components of wide data ($D \gg N$) through the rows' Gram
    /// matrix: with $\tilde Z$ centred in place (it takes `z` by value),
    /// $G = \tilde Z\tilde Z^\top = U\Lambda U^\top$ ($N\times N$), $\sigma_i = \sqrt{\lambda_i}$
    /// and $v_i = \tilde Z^\top u_i/\sigma_i$. The same components as [`Self::fit`] (up to
    /// rounding: $G$ squares the condition number, so components below about
    /// $10^{-7}\sigma_1$ are not resolved and are dropped) in $O(N^2 + kD)$ memory beyond
    /// the input, where the thin SVD holds several $N\times D$ copies. `kept` is the
    /// number of directions returned ($\le k$); `singular_values` has them all, so
    /// [`Self::explained`] stays relative to the whole spectrum.
    pub fn fit_wide(mut z: Vec<f64>, cols: usize, k: usize) -> Result<Self, PcaError> {
        if cols == 0 || !z.len().is_multiple_of(cols) || z.len() / cols < 2 {
            return Err(PcaError::Shape { values: z.len(), cols });
        }
        let rows = z.len() / cols;
        let (mean, _) = crate::stats::mean_std(&z, cols);
        z.chunks_exact_mut(cols).for_each(|r| r.iter_mut().zip(&mean).for_each(|(v, m)| *v -= m));
        // Row-major N × D is column-major D × N: A = Z̃ᵀ, G = AᵀA.
        let a = faer::MatRef::from_column_major_slice(&z, cols, rows);
        let mut g = faer::Mat::<f64>::zeros(rows, rows);
        faer::linalg::matmul::matmul(g.as_mut(), faer::Accum::Replace, a.transpose(), a, 1.0, faer::Par::Seq);
        let total: f64 = (0..rows).map(|i| g[(i, i)]).sum();
        if total <= 0.0 {
            return Err(PcaError::NoVariance);
        }
        let evd = g.self_adjoint_eigen(faer::Side::Lower).map_err(|_| PcaError::NoConvergence)?;
        let (lambda, u) = (evd.S().column_vector(), evd.U());
        // Descending; eigenvalues below the Gram matrix's rounding level are noise.
        let tiny = lambda[rows - 1] * 1e-14 * rows as f64;
        let order: Vec<usize> = (0..rows).rev().take_while(|&i| lambda[i] > tiny).collect();
        let singular_values: Vec<f64> = order.iter().map(|&i| lambda[i].sqrt()).collect();
        let kept = k.min(order.len());
        let mut directions = Vec::with_capacity(kept * cols);
        for (&i, s) in order.iter().zip(&singular_values).take(kept) {
            let mut v = vec![0.0; cols];
            for (j, row) in z.chunks_exact(cols).enumerate() {
                let w = u[(j, i)] / s;
                v.iter_mut().zip(row).for_each(|(v, r)| *v += w * r);
            }
            largest_positive(&mut v);
            directions.extend(v);
        }
        Ok(Self { mean, directions, singular_values, total, kept, cols })
    }

    /// Number of columns D.
    pub fn dim(&self) -> usize {
        self.cols
    }

    /// $\sigma_i^2 / \lVert\tilde Z\rVert_F^2$ for every component.
    pub fn explained(&self) -> Vec<f64> {
        self.singular_values.iter().map(|s| s * s / self.total).collect()
    }

    /// $v(d)$ for $d = 1 … r$: non-decreasing, ending at 1.
    pub fn cumulative_explained(&self) -> Vec<f64> {
        self.explained()
            .iter()
            .scan(0.0, |acc, e| {
                *acc += e;
                Some(*acc)
            })
            .collect()
    }

    /// Coordinates of one sample in the first `d` components: $y = V_d^\top (z - \bar z)$.
    pub fn project(&self, z: &[f64], d: usize) -> Vec<f64> {
        (0..d.min(self.singular_values.len()))
            .map(|i| {
                let dir = &self.directions[i * self.cols..(i + 1) * self.cols];
                dir.iter().zip(z).zip(&self.mean).map(|((v, z), m)| v * (z - m)).sum()
            })
            .collect()
    }

    /// The sample for coordinates `y` (length `d`): $\bar z + V_d y$.
    pub fn reconstruct(&self, y: &[f64]) -> Vec<f64> {
        let mut z = self.mean.clone();
        for (i, yi) in y.iter().enumerate() {
            let dir = &self.directions[i * self.cols..(i + 1) * self.cols];
            z.iter_mut().zip(dir).for_each(|(z, v)| *z += yi * v);
        }
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A rank-k matrix: N samples = mean + Σ_j a_ij u_j with k random directions.
    fn rank_k(n: usize, d: usize, k: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let dirs: Vec<f64> = (0..k * d).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let mean: Vec<f64> = (0..d).map(|_| rng.gen_range(-5.0..5.0)).collect();
        (0..n)
            .flat_map(|_| {
                let a: Vec<f64> = (0..k).map(|j| rng.gen_range(-1.0..1.0) * (k - j) as f64).collect();
                (0..d).map(|c| mean[c] + (0..k).map(|j| a[j] * dirs[j * d + c]).sum::<f64>()).collect::<Vec<_>>()
            })
            .collect()
    }

    /// The Gram route finds the thin SVD's components of a wide matrix: same singular
    /// values, same directions (same signs), same mean and total, `kept` = the k asked.
    #[test]
    fn fit_wide_agrees_with_the_svd() {
        let (n, d) = (40, 500);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let z: Vec<f64> =
            (0..n * d).map(|i| rng.gen_range(-1.0..1.0) * (1.0 + 5.0 / (1.0 + (i % d) as f64 / 7.0))).collect();
        let svd = Pca::fit(&z, d, &PcaParams { variance: 1.0, min_components: 1, max_components: n }).unwrap();
        let gram = Pca::fit_wide(z, d, 12).unwrap();
        assert_eq!(gram.kept, 12);
        assert_eq!(gram.directions.len(), 12 * d);
        assert_eq!(gram.singular_values.len(), svd.singular_values.len());
        for (a, b) in gram.singular_values.iter().zip(&svd.singular_values) {
            assert!((a - b).abs() < 1e-9 * svd.singular_values[0], "{a} vs {b}");
        }
        for (a, b) in gram.directions.iter().zip(&svd.directions[..12 * d]) {
            assert!((a - b).abs() < 1e-8, "{a} vs {b}");
        }
        assert!((gram.total - svd.total).abs() < 1e-9 * svd.total);
        assert!(gram.mean.iter().zip(&svd.mean).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(matches!(Pca::fit_wide(vec![1.0; 2 * d], d, 3), Err(PcaError::NoVariance)));
        assert!(matches!(Pca::fit_wide(vec![1.0; d], d, 3), Err(PcaError::Shape { .. })));
    }

    /// Shapes tall, wide and square: a rank-k matrix has exactly k nonzero components,
    /// which reconstruct every sample, and explained variance is monotone up to 1.
    #[test]
    fn rank_k_matrix_has_k_components() {
        for (n, d, k) in [(50, 8, 3), (6, 40, 4), (30, 30, 5), (2, 3, 1)] {
            let z = rank_k(n, d, k, 42);
            let pca = Pca::fit(&z, d, &PcaParams { variance: 1.0, min_components: 1, max_components: 99 }).unwrap();
            assert_eq!(pca.singular_values.len(), k, "shape {n}x{d}");
            assert_eq!(pca.kept, k);
            let cum = pca.cumulative_explained();
            assert!(cum.windows(2).all(|w| w[1] >= w[0]));
            assert!((cum[k - 1] - 1.0).abs() < 1e-10);
            for row in z.chunks(d) {
                let back = pca.reconstruct(&pca.project(row, k));
                let err: f64 = back.iter().zip(row).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(err < 1e-9 * (n * d) as f64, "{err}");
            }
        }
    }

    /// Directions are orthonormal and σ² agree with the variance of the coordinates.
    #[test]
    fn directions_are_orthonormal_and_match_coordinates() {
        let d = 10;
        let z = rank_k(200, d, 6, 7);
        let pca = Pca::fit(&z, d, &PcaParams::default()).unwrap();
        let r = pca.singular_values.len();
        for a in 0..r {
            for b in 0..r {
                let dot: f64 = (0..d).map(|c| pca.directions[a * d + c] * pca.directions[b * d + c]).sum();
                assert!((dot - f64::from(u8::from(a == b))).abs() < 1e-10);
            }
            let ss: f64 = z.chunks(d).map(|row| pca.project(row, r)[a].powi(2)).sum();
            assert!((ss.sqrt() - pca.singular_values[a]).abs() < 1e-8 * pca.singular_values[0]);
        }
        let cum = pca.cumulative_explained();
        assert!(cum[pca.kept - 1] >= 0.85 && (pca.kept == 1 || cum[pca.kept - 2] < 0.85));
    }

    /// An exact answer: samples ±a e_1 and ±b e_2 (a > b) give σ = (√2 a, √2 b) along e_1, e_2.
    #[test]
    fn known_axes() {
        let (a, b) = (3.0, 1.0);
        let z = [a, 0.0, -a, 0.0, 0.0, b, 0.0, -b];
        let pca = Pca::fit(&z, 2, &PcaParams { variance: 0.5, min_components: 1, max_components: 2 }).unwrap();
        assert!((pca.singular_values[0] - 2f64.sqrt() * a).abs() < 1e-12);
        assert!((pca.singular_values[1] - 2f64.sqrt() * b).abs() < 1e-12);
        assert!((pca.directions[0] - 1.0).abs() < 1e-12 && (pca.directions[3] - 1.0).abs() < 1e-12);
        assert_eq!(pca.kept, 1);
        assert!((pca.explained()[0] - 0.9).abs() < 1e-12);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(Pca::fit(&[1.0, 2.0], 2, &PcaParams::default()), Err(PcaError::Shape { .. })));
        assert_eq!(Pca::fit(&[1.0, 2.0, 1.0, 2.0], 2, &PcaParams::default()), Err(PcaError::NoVariance));
        let bad = PcaParams { variance: 1.5, ..PcaParams::default() };
        assert!(matches!(Pca::fit(&[1.0, 2.0, 3.0, 4.0], 2, &bad), Err(PcaError::Params(_))));
    }
}

/// The design card's PCA (linfa-reduction) agrees with ours on a well-conditioned
/// matrix, where its iterative solver is reliable.
#[cfg(test)]
mod linfa_cross_check {
    use linfa::traits::Fit;
    use linfa::DatasetBase;
    use rand::{Rng, SeedableRng};

    use super::*;

    #[test]
    fn singular_values_and_directions_agree_with_linfa_reduction() {
        let (n, d) = (120, 6);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let scales = [6.0, 4.0, 2.5, 1.5, 1.0, 0.5];
        let z: Vec<f64> = (0..n * d).map(|i| rng.gen_range(-1.0..1.0) * scales[i % d]).collect();
        let ours = Pca::fit(&z, d, &PcaParams { variance: 1.0, min_components: 1, max_components: d }).unwrap();
        let records = ndarray::Array2::from_shape_vec((n, d), z).unwrap();
        let theirs = linfa_reduction::Pca::params(3).fit(&DatasetBase::from(records)).unwrap();
        let sv = theirs.singular_values();
        for i in 0..3 {
            assert!(
                (sv[i] - ours.singular_values[i]).abs() < 1e-6 * ours.singular_values[0],
                "{i}: {sv} vs {:?}",
                ours.singular_values
            );
            let comp = theirs.components().row(i).to_vec();
            let dot: f64 = comp.iter().zip(&ours.directions[i * d..(i + 1) * d]).map(|(a, b)| a * b).sum();
            assert!((dot.abs() - 1.0).abs() < 1e-6, "direction {i}: |dot| = {}", dot.abs());
        }
    }
}
