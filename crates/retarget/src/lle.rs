//! The locally-linear-embedding prior (Bouaziz and Pauly, Eq. 5–8).
//!
//! Each point $u_i$ of an observation space is reconstructed from its $k$ nearest
//! neighbours $N_i$ by weights summing to one,
//! $$w_i = \arg\min_w \Big\lVert u_i - \sum_{j \in N_i} w_j u_j \Big\rVert^2
//! \quad\text{s.t.}\quad \sum_j w_j = 1,$$
//! solved in closed form from the local Gram matrix $G_{jk} = (u_i - u_j)\cdot(u_i - u_k)$:
//! $G w = \mathbf 1$, then $w \leftarrow w / \sum w$. $G$ is singular when $k$ exceeds the
//! local dimension, so it is regularised by $\epsilon\,\mathrm{tr}(G)/k$ on its diagonal
//! (Roweis and Saul's remedy; [`REGULARIZATION`]).
//!
//! The prior over latents $Z$ ($N \times q$) is, up to a constant,
//! $-\log P(Z) = \tfrac12\mathrm{tr}(L Z Z^\top)$ with $L = M^\top M + I$, one row of $M$ per
//! reconstruction constraint: row $i$ of $(I - C)$ placed on the columns of the latents its
//! space's points own.

use faer::prelude::Solve;
use faer::{Mat, Side};

/// $\epsilon$ of the local Gram matrix's regularisation.
pub const REGULARIZATION: f64 = 1e-3;

/// Why weights cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LleError {
    /// Fewer points than neighbours + 1, or `k` = 0.
    #[error("{points} points cannot each have {k} neighbours (need at least k + 1 points, k >= 1)")]
    TooFew {
        /// Points given.
        points: usize,
        /// Neighbours asked.
        k: usize,
    },
    /// A value is NaN or infinite.
    #[error("point {row}, value {col} is not finite")]
    NonFinite {
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
    },
}

/// Each point's neighbours and weights: `(neighbours, weights)` per row, `k` each.
#[derive(Debug, Clone, PartialEq)]
pub struct Weights {
    /// Per point, its `k` nearest others (nearest first; lower index on ties).
    pub neighbours: Vec<Vec<usize>>,
    /// Per point, the reconstruction weights of its neighbours (sum 1).
    pub weights: Vec<Vec<f64>>,
}

fn sq(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// LLE weights of `n` points of `d` values with `k` neighbours each (Eq. 7–8).
///
/// # Errors
/// [`LleError::TooFew`], [`LleError::NonFinite`].
pub fn weights(u: &[f64], d: usize, k: usize) -> Result<Weights, LleError> {
    let n = u.len().checked_div(d).unwrap_or(0);
    if k == 0 || n < k + 1 {
        return Err(LleError::TooFew { points: n, k });
    }
    if let Some(i) = u.iter().position(|v| !v.is_finite()) {
        return Err(LleError::NonFinite { row: i / d, col: i % d });
    }
    let row = |i: usize| &u[i * d..(i + 1) * d];
    let mut out = Weights { neighbours: Vec::with_capacity(n), weights: Vec::with_capacity(n) };
    for i in 0..n {
        let mut others: Vec<(f64, usize)> = (0..n).filter(|&j| j != i).map(|j| (sq(row(i), row(j)), j)).collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let nb: Vec<usize> = others.iter().take(k).map(|&(_, j)| j).collect();
        let diff = |j: usize| -> Vec<f64> { row(i).iter().zip(row(j)).map(|(a, b)| a - b).collect() };
        let diffs: Vec<Vec<f64>> = nb.iter().map(|&j| diff(j)).collect();
        let mut g = Mat::from_fn(k, k, |a, b| diffs[a].iter().zip(&diffs[b]).map(|(x, y)| x * y).sum::<f64>());
        let trace: f64 = (0..k).map(|a| g[(a, a)]).sum();
        // A point equal to all its neighbours has a zero Gram matrix: any weights summing to
        // one reconstruct it, and the regularised system gives equal ones.
        let reg = REGULARIZATION * if trace > 0.0 { trace / k as f64 } else { 1.0 };
        for a in 0..k {
            g[(a, a)] += reg;
        }
        let mut rhs = Mat::from_fn(k, 1, |_, _| 1.0);
        match g.llt(Side::Lower) {
            Ok(f) => f.solve_in_place(rhs.as_mut()),
            Err(_) => g.lblt(Side::Lower).solve_in_place(rhs.as_mut()),
        }
        let total: f64 = (0..k).map(|a| rhs[(a, 0)]).sum();
        out.weights.push((0..k).map(|a| rhs[(a, 0)] / total).collect());
        out.neighbours.push(nb);
    }
    Ok(out)
}

/// $L = M^\top M + I$ over `total` latents, from one or more spaces' weights, each with
/// the latent index of its points (`owners[i]` is the latent of the space's point `i`).
pub fn prior_matrix(spaces: &[(&Weights, &[usize])], total: usize) -> Mat<f64> {
    let mut l = Mat::<f64>::identity(total, total);
    for (w, owners) in spaces {
        for (i, (nb, ws)) in w.neighbours.iter().zip(&w.weights).enumerate() {
            // Row of M: +1 at owners[i], −w_j at owners[nb_j].
            let mut entries: Vec<(usize, f64)> = vec![(owners[i], 1.0)];
            entries.extend(nb.iter().zip(ws).map(|(&j, &wj)| (owners[j], -wj)));
            for &(a, va) in &entries {
                for &(b, vb) in &entries {
                    l[(a, b)] += va * vb;
                }
            }
        }
    }
    l
}

/// $\tfrac12\mathrm{tr}(L Z Z^\top)$ and its gradient $L Z$, for latents `z` (`total × q`).
pub fn prior(l: &Mat<f64>, z: &[f64], q: usize) -> (f64, Vec<f64>) {
    let n = l.nrows();
    let zm = Mat::from_fn(n, q, |i, j| z[i * q + j]);
    let lz = l * &zm;
    let value =
        0.5 * (0..n).flat_map(|i| (0..q).map(move |j| (i, j))).map(|(i, j)| zm[(i, j)] * lz[(i, j)]).sum::<f64>();
    (value, (0..n).flat_map(|i| (0..q).map(move |j| (i, j))).map(|(i, j)| lz[(i, j)]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_inside_its_neighbours_is_reconstructed_exactly() {
        // A square's centre and corners, in 3-D with z = 0: the centre is the corners' mean.
        let u = [0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
        let w = weights(&u, 3, 4).unwrap();
        assert_eq!(w.neighbours[0], vec![1, 2, 3, 4]);
        for &wi in &w.weights[0] {
            assert!((wi - 0.25).abs() < 1e-9, "{:?}", w.weights[0]);
        }
        // On a line, a point between two neighbours at distances 1 and 3 gets 3/4 and 1/4.
        let line = [0.0, 1.0, 4.0, 10.0];
        let w = weights(&line, 1, 2).unwrap();
        assert_eq!(w.neighbours[1], vec![0, 2]);
        assert!((w.weights[1][0] - 0.75).abs() < 1e-3 && (w.weights[1][1] - 0.25).abs() < 1e-3, "{:?}", w.weights[1]);
        for ws in &w.weights {
            assert!((ws.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn too_few_points_or_a_nan_is_an_error() {
        assert_eq!(weights(&[0.0, 1.0], 1, 2), Err(LleError::TooFew { points: 2, k: 2 }));
        assert_eq!(weights(&[0.0, f64::NAN, 2.0], 1, 1), Err(LleError::NonFinite { row: 1, col: 0 }));
    }

    #[test]
    fn the_prior_is_symmetric_and_its_gradient_matches_differences() {
        let line = [0.0, 1.0, 4.0, 10.0, 11.0];
        let w = weights(&line, 1, 2).unwrap();
        // The space's points own latents 0, 2, 3, 5, 6 of 7 (1 and 4 belong to the other space).
        let owners = [0, 2, 3, 5, 6];
        let l = prior_matrix(&[(&w, &owners)], 7);
        // Symmetric, and ≥ I (positive definite).
        for a in 0..7 {
            for b in 0..7 {
                assert!((l[(a, b)] - l[(b, a)]).abs() < 1e-12);
            }
        }
        assert_eq!(l[(1, 1)], 1.0, "a latent of no constraint keeps only the identity");
        let q = 2;
        let z: Vec<f64> = (0..14).map(|i| (f64::from(i) * 0.37).sin()).collect();
        let (v, g) = prior(&l, &z, q);
        assert!(v > 0.0);
        let h = 1e-6;
        for i in 0..z.len() {
            let mut zp = z.clone();
            zp[i] += h;
            let mut zm = z.clone();
            zm[i] -= h;
            let fd = (prior(&l, &zp, q).0 - prior(&l, &zm, q).0) / (2.0 * h);
            assert!((fd - g[i]).abs() < 1e-6 * (1.0 + g[i].abs()), "∂/∂z[{i}]: {fd} vs {}", g[i]);
        }
    }
}
