//! Semi-supervised manifold alignment (Ham, Lee and Saul 2005), the paper's initialisation
//! of the shared latents (Bouaziz and Pauly, "Implementation").
//!
//! Each observation space $s$ gets a symmetrised $k$-nearest-neighbour graph over its rows
//! (weight 1 on an edge when either point is among the other's $k$ nearest), with degree
//! $D_s$ and Laplacian $L_s = D_s - W_s$. Ham et al. align two such graphs by minimising
//! $$C(f, g) = \mu\sum_{i \in \text{labelled}} (f_i - g_i)^2 + f^\top L_X f + g^\top L_Y g$$
//! under a scale constraint; in the limit $\mu \to \infty$ a labelled pair becomes one node,
//! which is exactly the shared latent row both spaces own. So with $P_s$ the 0/1 matrix
//! placing space $s$'s rows on their latent rows, the joint Laplacian and degree are
//! $$L = \sum_s P_s^\top L_s P_s, \qquad D = \sum_s P_s^\top D_s P_s,$$
//! and the latent coordinates are the bottom nontrivial generalised eigenvectors
//! $L v = \lambda D v$ (Laplacian eigenmaps of the joint graph): $v_1 \dots v_q$, skipping
//! the constant $v_0$ ($\lambda_0 = 0$). They are found as $D^{-1/2} u$ for the eigenvectors
//! $u$ of the symmetric $D^{-1/2} L D^{-1/2}$. Each $v$ has $v^\top D v = 1$; all are then
//! scaled by one common factor so that the first has unit root mean square (the kernel's
//! initial length scale is 1), which keeps their relative scale.

use faer::{Mat, Side};
use reprise_numerics::gplvm::GplvmError;

use reprise_numerics::pca::{Pca, PcaParams};

use crate::shared::Space;

/// `m` rows of `d` values with the capture noise (variance `noise_var` per value) taken out
/// of their neighbourhoods: the rows projected onto the principal directions whose sample
/// variance $\lambda_i$ exceeds the largest a pure-noise direction reaches, the
/// Marchenko–Pastur edge $\sigma^2 (1 + \sqrt{d/m})^2$, and mapped back (centred). Noise
/// on the discarded directions no longer shuffles the nearest neighbours; the kept
/// directions carry the signal. With no direction above the edge the first is kept.
///
/// # Errors
/// [`GplvmError::Shape`] for fewer than two rows or no variance.
pub fn denoise(data: &[f64], d: usize, noise_var: f64) -> Result<Vec<f64>, GplvmError> {
    let m = data.len().checked_div(d).unwrap_or(0);
    let pca = Pca::fit(data, d, &PcaParams { variance: 1.0, min_components: 1, max_components: d.min(m) })
        .map_err(|e| GplvmError::Shape(format!("denoise: {e}")))?;
    let mean: Vec<f64> = (0..d).map(|j| data.chunks_exact(d).map(|r| r[j]).sum::<f64>() / m as f64).collect();
    let total: f64 =
        data.chunks_exact(d).map(|r| r.iter().zip(&mean).map(|(a, b)| (a - b) * (a - b)).sum::<f64>()).sum::<f64>()
            / m as f64;
    let edge = noise_var * (1.0 + (d as f64 / m as f64).sqrt()).powi(2);
    let keep = pca.explained().iter().take_while(|&&e| e * total > edge).count().max(1);
    Ok(data
        .chunks_exact(d)
        .flat_map(|r| {
            let c = pca.project(r, keep);
            pca.reconstruct(&c).into_iter().zip(&mean).map(|(a, b)| a - b).collect::<Vec<_>>()
        })
        .collect())
}

/// The symmetrised $k$-NN adjacency of `m` points of `d` values: per point, its neighbours
/// (sorted, no duplicates, never itself).
pub fn knn_graph(data: &[f64], d: usize, k: usize) -> Vec<Vec<usize>> {
    let m = data.len().checked_div(d).unwrap_or(0);
    let row = |i: usize| &data[i * d..(i + 1) * d];
    let mut adj = vec![Vec::new(); m];
    for i in 0..m {
        let mut others: Vec<(f64, usize)> = (0..m)
            .filter(|&j| j != i)
            .map(|j| (row(i).iter().zip(row(j)).map(|(a, b)| (a - b) * (a - b)).sum::<f64>(), j))
            .collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, j) in others.iter().take(k) {
            adj[i].push(j);
            adj[j].push(i);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    adj
}

/// Joint latent coordinates (`n × q`, row-major) of `n` latent rows owned by `spaces`
/// (labelled rows owned by several), by Ham et al.'s alignment with `k` neighbours per
/// space (see the module's note for the math).
///
/// # Errors
/// [`GplvmError::Shape`] for a latent row no space owns, a row out of range, fewer than
/// `q + 1` latents, or an eigensolver that does not converge.
pub fn align(spaces: &[Space<'_>], n: usize, q: usize, k: usize) -> Result<Vec<f64>, GplvmError> {
    if n < q + 1 || q == 0 {
        return Err(GplvmError::Shape(format!("alignment: {n} latents cannot give {q} nontrivial coordinates")));
    }
    let mut l = Mat::<f64>::zeros(n, n);
    for (s, sp) in spaces.iter().enumerate() {
        if sp.rows.iter().any(|&r| r >= n) || sp.dim == 0 || sp.data.len() != sp.rows.len() * sp.dim {
            return Err(GplvmError::Shape(format!("alignment: space {s} does not match its rows")));
        }
        let adj = knn_graph(sp.data, sp.dim, k.min(sp.rows.len().saturating_sub(1)));
        for (i, nb) in adj.iter().enumerate() {
            let a = sp.rows[i];
            for &j in nb {
                let b = sp.rows[j];
                // W contributes −1 off the diagonal and +1 to the degree, per edge end.
                l[(a, a)] += 1.0;
                l[(a, b)] -= 1.0;
            }
        }
    }
    let deg: Vec<f64> = (0..n).map(|i| l[(i, i)]).collect();
    if let Some(i) = deg.iter().position(|&v| v <= 0.0) {
        return Err(GplvmError::Shape(format!("alignment: latent row {i} has no neighbour in any space")));
    }
    let s: Vec<f64> = deg.iter().map(|v| 1.0 / v.sqrt()).collect();
    let sym = Mat::from_fn(n, n, |i, j| s[i] * l[(i, j)] * s[j]);
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| GplvmError::Shape("alignment: the eigensolver did not converge".into()))?;
    let u = evd.U();
    let mut z = vec![0.0; n * q];
    for c in 0..q {
        for i in 0..n {
            z[i * q + c] = s[i] * u[(i, c + 1)];
        }
    }
    let rms = (z.iter().step_by(q).map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    if rms > 0.0 {
        z.iter_mut().for_each(|v| *v /= rms);
    }
    Ok(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spearman's rank correlation of two equally long samples (no ties).
    fn rank_correlation(a: &[f64], b: &[f64]) -> f64 {
        let ranks = |v: &[f64]| {
            let mut idx: Vec<usize> = (0..v.len()).collect();
            idx.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
            let mut r = vec![0.0; v.len()];
            for (k, &i) in idx.iter().enumerate() {
                r[i] = k as f64;
            }
            r
        };
        let (ra, rb) = (ranks(a), ranks(b));
        let m = (a.len() as f64 - 1.0) / 2.0;
        let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - m) * (y - m)).sum();
        let var: f64 = ra.iter().map(|x| (x - m) * (x - m)).sum();
        cov / var
    }

    #[test]
    fn the_alignment_recovers_the_shared_parameter_of_two_curves() {
        // A hidden t ∈ [0, 1]: the source sees it on a helix in 3-D, the target on a parabola
        // in 2-D. 4 labelled pairs, 30 source-only and 30 target-only rows at other t.
        let t_of = |r: usize| -> f64 {
            match r {
                0..4 => [0.1, 0.4, 0.6, 0.9][r],
                4..34 => (r - 4) as f64 / 29.0,
                _ => (r - 34) as f64 / 29.0 + 0.5 / 29.0,
            }
        };
        let n = 64;
        let x_rows: Vec<usize> = (0..34).collect();
        let y_rows: Vec<usize> = (0..4).chain(34..64).collect();
        let x: Vec<f64> = x_rows
            .iter()
            .flat_map(|&r| {
                let s = 3.0 * t_of(r);
                [s.cos(), s.sin(), 0.5 * s]
            })
            .collect();
        let y: Vec<f64> = y_rows.iter().flat_map(|&r| [t_of(r) * 5.0, (t_of(r) * 5.0 - 2.0).powi(2)]).collect();
        let spaces = [Space { data: &x, dim: 3, rows: x_rows }, Space { data: &y, dim: 2, rows: y_rows }];
        let z = align(&spaces, n, 1, 4).unwrap();
        let t: Vec<f64> = (0..n).map(t_of).collect();
        // Up to sign and a monotone rescaling, the coordinate is t, on both spaces' rows.
        let rho = rank_correlation(&z, &t);
        assert!(rho.abs() > 0.99, "rank correlation {rho}");
        let rms = (z.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
        assert!((rms - 1.0).abs() < 1e-9, "unit RMS: {rms}");
        // Without the ties (target rows apart from the source's) the two graphs separate:
        // the first coordinate is then which space a row is in, not t.
        let y_apart: Vec<usize> = (34..68).collect();
        let apart = [spaces[0].clone(), Space { data: &y, dim: 2, rows: y_apart }];
        let z2 = align(&apart, 68, 1, 4).unwrap();
        let (a, b) = (z2[0], z2[40]);
        assert!((a - b).abs() > 0.5, "{a} vs {b}");
        assert!(z2[..34].iter().all(|v| (v - a).abs() < 1e-6) && z2[34..].iter().all(|v| (v - b).abs() < 1e-6));
    }

    #[test]
    fn denoising_keeps_a_plane_and_drops_isotropic_noise() {
        // 80 points on a plane in 20-D (variances 4 and 1) plus noise of variance 0.01: the
        // edge is 0.01 (1 + 0.5)² = 0.0225, so exactly the plane's two directions stay, and
        // the residual to the clean points drops from the noise's 20 × 0.01 to about 2 × 0.01.
        let (m, d) = (80usize, 20usize);
        let mut state = 12345u64;
        let mut gauss = move || {
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u1, u2) = (u(), u());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let mut clean = Vec::new();
        for _ in 0..m {
            let (a, b) = (2.0 * gauss(), gauss());
            clean.extend((0..d).map(|j| {
                if j == 0 {
                    a
                } else if j == 1 {
                    b
                } else {
                    0.0
                }
            }));
        }
        let noisy: Vec<f64> = clean.iter().map(|v| v + 0.1 * gauss()).collect();
        let out = denoise(&noisy, d, 0.01).unwrap();
        let centred = |v: &[f64]| -> Vec<f64> {
            let mean: Vec<f64> = (0..d).map(|j| v.chunks_exact(d).map(|r| r[j]).sum::<f64>() / m as f64).collect();
            v.chunks_exact(d).flat_map(|r| r.iter().zip(&mean).map(|(a, b)| a - b).collect::<Vec<_>>()).collect()
        };
        let err =
            |v: &[f64]| centred(v).iter().zip(centred(&clean)).map(|(a, b)| (a - b) * (a - b)).sum::<f64>() / m as f64;
        let (before, after) = (err(&noisy), err(&out));
        assert!((before - 0.2).abs() < 0.05, "noise per row {before}");
        assert!(after < 0.04, "after {after}");
    }

    #[test]
    fn a_row_of_no_space_is_an_error() {
        let x = [0.0, 1.0, 2.0];
        let spaces = [Space { data: &x, dim: 1, rows: vec![0, 1, 2] }];
        assert!(align(&spaces, 4, 1, 1).is_err());
        assert!(align(&spaces, 3, 1, 1).is_ok());
    }
}
