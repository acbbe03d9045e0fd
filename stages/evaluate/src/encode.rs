//! The player's mesh encoding: a mesh-space PCA basis fitted to the frames the page shows,
//! and per frame its coordinates quantised to int16. This module measures the encoding
//! (its reconstruction error over every encoded frame); the player ([`crate::player`])
//! decides which frames to encode and the page (`html`) embeds the bytes.
//!
//! A frame's mesh $m \in \mathbb{R}^{3V}$ is stored as $c = \mathrm{round}(U_K^\top(m -
//! \bar m) / s)$ with per-component scales $s_i = \max_t |y_{ti}| / 32767$, and drawn as
//! $\hat m = \bar m + U_K (s \odot c)$. $\bar m$ is stored as float32, $U_K$ as int16 with
//! one scale per row (its entries are $O(1/\sqrt{3V})$, so the step is $\sim 3\cdot10^{-5}$
//! of the largest). $K$ is
//! the smallest count whose mean per-frame RMS vertex error is at most the target
//! ([`Encoded::target`]), capped at [`MAX_COMPONENTS`].

use reprise_numerics::pca::Pca;
use reprise_stagekit::StageResult;

/// At most this many basis vectors.
pub const MAX_COMPONENTS: usize = 128;

/// The basis is fitted to at most this many frames (evenly strided over the shown ones);
/// the error is measured on all of them.
pub const FIT_FRAMES: usize = 1200;

/// Meshes encoded for the page.
#[derive(Debug, Clone)]
pub struct Encoded {
    /// Components kept, $K$.
    pub k: usize,
    /// Mesh values per frame, $3V$.
    pub dim: usize,
    /// Mean mesh $\bar m$ (`3V`).
    pub mean: Vec<f32>,
    /// Basis, row-major `K × 3V` (orthonormal rows), quantised per row: entry $(i, j)$ is
    /// `basis[i·3V + j] · basis_scale[i]`.
    pub basis: Vec<i16>,
    /// Per-row dequantisation scale of the basis (`K`).
    pub basis_scale: Vec<f32>,
    /// Per-component dequantisation scale $s$ (`K`).
    pub scale: Vec<f32>,
    /// Quantised coordinates, `frames × K`.
    pub codes: Vec<i16>,
    /// The error target: mean per-frame RMS vertex error (mesh units).
    pub target: f64,
    /// Mean over frames of the RMS vertex error of $\hat m$ (after quantisation).
    pub mean_error: f64,
    /// Largest per-frame RMS vertex error.
    pub max_error: f64,
}

impl Encoded {
    /// Bytes of the binary payload (before base64).
    pub fn bytes(&self) -> usize {
        4 * (self.mean.len() + self.basis_scale.len() + self.scale.len()) + 2 * (self.basis.len() + self.codes.len())
    }

    /// The decoded mesh of frame `t` (what the page draws).
    pub fn decode(&self, t: usize) -> Vec<f64> {
        let mut m: Vec<f64> = self.mean.iter().map(|v| f64::from(*v)).collect();
        for i in 0..self.k {
            let c = f64::from(self.codes[t * self.k + i]) * f64::from(self.scale[i]) * f64::from(self.basis_scale[i]);
            let row = &self.basis[i * self.dim..(i + 1) * self.dim];
            m.iter_mut().zip(row).for_each(|(m, u)| *m += c * f64::from(*u));
        }
        m
    }
}

/// Frames are handed over in batches of this many (meshes are `3V` doubles each).
pub const BATCH: usize = 256;

/// Meshes of the frames with the given indices, concatenated (`indices × 3V`).
pub type MeshSource<'a> = dyn Fn(&[usize]) -> StageResult<Vec<f64>> + 'a;

/// Encodes `frames` meshes of `dim` values (fetched in batches from `meshes`) to a mean
/// per-frame RMS vertex error of at most `target` mesh units where [`MAX_COMPONENTS`]
/// allow. `None` without frames.
pub fn encode(frames: usize, dim: usize, meshes: &MeshSource<'_>, target: f64) -> StageResult<Option<Encoded>> {
    if frames == 0 || dim == 0 {
        return Ok(None);
    }
    let stride = frames.div_ceil(FIT_FRAMES).max(1);
    let fit = meshes(&(0..frames).step_by(stride).collect::<Vec<_>>())?;
    let first = fit[..dim].to_vec();
    // The Gram route: the fit frames are few (≤ FIT_FRAMES) and wide (3V values).
    let (mean, directions, r) = match Pca::fit_wide(fit, dim, MAX_COMPONENTS) {
        Ok(p) => (p.mean, p.directions, p.kept),
        // One distinct frame (or fewer than two fit rows): the mean alone.
        Err(_) => (first, Vec::new(), 0),
    };
    // Per frame: coordinates in all r directions and the squared distance to the mean.
    let mut coords: Vec<Vec<f64>> = Vec::with_capacity(frames);
    let mut total: Vec<f64> = Vec::with_capacity(frames);
    for batch in batches(frames) {
        for m in meshes(&batch)?.chunks_exact(dim) {
            let y = (0..r)
                .map(|i| {
                    directions[i * dim..(i + 1) * dim].iter().zip(m).zip(&mean).map(|((u, m), a)| u * (m - a)).sum()
                })
                .collect();
            coords.push(y);
            total.push(m.iter().zip(&mean).map(|(a, b)| (a - b).powi(2)).sum());
        }
    }
    let k = choose_k(dim, &coords, &total, r, target);
    let scale: Vec<f64> = (0..k).map(|i| quantum(coords.iter().map(|y| y[i]))).collect();
    let codes: Vec<i16> = coords.iter().flat_map(|y| (0..k).map(|i| quantise(y[i], scale[i]))).collect();
    let rows: Vec<&[f64]> = directions.chunks_exact(dim).take(k).collect();
    let basis_scale: Vec<f64> = rows.iter().map(|row| quantum(row.iter().copied())).collect();
    let basis: Vec<i16> =
        rows.iter().zip(&basis_scale).flat_map(|(row, s)| row.iter().map(|u| quantise(*u, *s))).collect();
    let mut e = Encoded {
        k,
        dim,
        mean: mean.iter().map(|v| *v as f32).collect(),
        basis,
        basis_scale: basis_scale.iter().map(|v| *v as f32).collect(),
        scale: scale.iter().map(|v| *v as f32).collect(),
        codes,
        target,
        mean_error: 0.0,
        max_error: 0.0,
    };
    let mut errors = Vec::with_capacity(frames);
    for batch in batches(frames) {
        for (t, m) in batch.iter().zip(meshes(&batch)?.chunks_exact(dim)) {
            errors.push(reprise_stagekit::rig::mesh_rmse(&e.decode(*t), m));
        }
    }
    e.mean_error = errors.iter().sum::<f64>() / frames as f64;
    e.max_error = errors.iter().copied().fold(0.0, f64::max);
    Ok(Some(e))
}

/// Frame indices `0..frames` in batches of [`BATCH`].
pub fn batches(frames: usize) -> impl Iterator<Item = Vec<usize>> {
    (0..frames).step_by(BATCH).map(move |s| (s..(s + BATCH).min(frames)).collect())
}

/// The int16 step of values `v`: their largest magnitude / 32767.
fn quantum(v: impl Iterator<Item = f64>) -> f64 {
    v.map(f64::abs).fold(0.0, f64::max).max(1e-30) / 32767.0
}

/// `v` in steps of `q`, as int16.
fn quantise(v: f64, q: f64) -> i16 {
    (v / q).round().clamp(-32767.0, 32767.0) as i16
}

/// The smallest $K \le r$ whose mean per-frame RMS vertex error (unquantised, from the
/// orthonormal residual $\lVert m - \bar m\rVert^2 - \sum_{i<K} y_i^2$, `total` and `coords`
/// per frame) is at most `target`.
fn choose_k(dim: usize, coords: &[Vec<f64>], total: &[f64], r: usize, target: f64) -> usize {
    let vertices = (dim / 3).max(1) as f64;
    let mean_error = |k: usize| {
        let s: f64 = coords
            .iter()
            .zip(total)
            .map(|(y, t)| ((t - y[..k].iter().map(|v| v * v).sum::<f64>()).max(0.0) / vertices).sqrt())
            .sum();
        s / coords.len().max(1) as f64
    };
    (0..=r).find(|&k| mean_error(k) <= target).unwrap_or(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Meshes on a 3-dimensional affine subspace are encoded with 3 components and
    /// reproduced to the quantisation error; a looser target keeps fewer.
    #[test]
    fn a_rank_three_family_takes_three_components() {
        let dim = 30;
        let dirs: Vec<Vec<f64>> =
            (0..3).map(|i| (0..dim).map(|j| ((i + 1) * (j + 2)) as f64 % 7.0 - 3.0).collect()).collect();
        let meshes: Vec<f64> = (0..200)
            .flat_map(|t| {
                let t = t as f64 / 10.0;
                let c = [t.sin(), (0.7 * t).cos(), 0.3 * (1.3 * t).sin()];
                let dirs = &dirs;
                (0..dim).map(move |j| 1.0 + (0..3).map(|i| c[i] * dirs[i][j]).sum::<f64>())
            })
            .collect();
        let source = |idx: &[usize]| -> StageResult<Vec<f64>> {
            Ok(idx.iter().flat_map(|&t| meshes[t * dim..(t + 1) * dim].to_vec()).collect())
        };
        let e = encode(200, dim, &source, 1e-4).unwrap().unwrap();
        assert_eq!(e.k, 3);
        assert!(e.max_error < 1e-3, "{}", e.max_error);
        assert_eq!(e.bytes(), 4 * (dim + 3 + 3) + 2 * (3 * dim + 200 * 3));
        let loose = encode(200, dim, &source, 10.0).unwrap().unwrap();
        assert!(loose.k < 3, "{}", loose.k);
    }
}
