//! Frames of a mesh as a mean plus morph targets. With the frames of every track stacked
//! as rows of $F$ ($N \times 3V$) and their mean $\bar f$, the targets are the first $K$
//! principal directions $v_k$ of $F - \mathbf 1\bar f^\top$, and frame $i$'s weights are
//! $w_{ik} = v_k^\top (f_i - \bar f)$, so $\hat f_i = \bar f + \sum_k w_{ik} v_k$ is the
//! best rank-$K$ reconstruction in the least-squares sense.

use reprise_numerics::pca::Pca;

/// Most frames the morph targets are fitted on (every frame is projected on them).
pub const MAX_FIT_FRAMES: usize = 2_000;

/// Why frames could not be baked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError {
    /// The frames are not whole meshes of the stated vertex count, or there are none.
    #[error("{values} values are not whole frames of {vertices} vertices (or there are none)")]
    Shape {
        /// Values given (all tracks).
        values: usize,
        /// Vertices per frame.
        vertices: usize,
    },
    /// A non-finite vertex coordinate.
    #[error("track {track}, frame {frame}: a vertex coordinate is not finite")]
    NotFinite {
        /// The track.
        track: usize,
        /// The frame.
        frame: usize,
    },
}

/// Baked tracks.
#[derive(Debug, Clone, PartialEq)]
pub struct Baked {
    /// Vertices per frame.
    pub vertices: usize,
    /// The mean mesh $\bar f$, `3V`.
    pub mean: Vec<f64>,
    /// The morph targets $v_k$ (unit vectors, vertex offsets), row-major `K × 3V`.
    pub targets: Vec<f64>,
    /// Per track, its weights `frames × K`, row-major.
    pub weights: Vec<Vec<f64>>,
    /// RMS over every frame and vertex of $\lVert f_i - \hat f_i\rVert$, length unit.
    pub rms_error: f64,
}

impl Baked {
    /// Morph targets $K$.
    pub fn k(&self) -> usize {
        self.targets.len() / (3 * self.vertices).max(1)
    }

    /// Frame `i` of track `t`, reconstructed.
    pub fn frame(&self, t: usize, i: usize) -> Vec<f64> {
        let (k, m) = (self.k(), 3 * self.vertices);
        let mut f = self.mean.clone();
        for (w, v) in self.weights[t][i * k..(i + 1) * k].iter().zip(self.targets.chunks_exact(m)) {
            f.iter_mut().zip(v).for_each(|(f, v)| *f += w * v);
        }
        f
    }
}

/// Bakes `tracks` (each `frames × 3V`) of a mesh of `vertices` vertices to at most
/// `max_targets` morph targets, shared by all tracks, fitted on at most
/// [`MAX_FIT_FRAMES`] of the frames spread evenly. (The PCA centres on the sample's mean;
/// the weights are taken about every frame's mean, so the reconstruction is the best in
/// the targets' span either way.)
///
/// # Errors
/// [`BakeError`] for frames that are not whole meshes, no frames, or a non-finite value.
pub fn bake(tracks: &[&[f64]], vertices: usize, max_targets: usize) -> Result<Baked, BakeError> {
    let m = 3 * vertices;
    let values: usize = tracks.iter().map(|t| t.len()).sum();
    if m == 0 || values == 0 || tracks.iter().any(|t| !t.len().is_multiple_of(m)) {
        return Err(BakeError::Shape { values, vertices });
    }
    for (t, track) in tracks.iter().enumerate() {
        if let Some(i) = track.iter().position(|v| !v.is_finite()) {
            return Err(BakeError::NotFinite { track: t, frame: i / m });
        }
    }
    let n = values / m;
    let frames = || tracks.iter().flat_map(|t| t.chunks_exact(m));
    let mut mean = vec![0.0; m];
    for f in frames() {
        mean.iter_mut().zip(f).for_each(|(a, b)| *a += b / n as f64);
    }
    // The targets are fitted on at most MAX_FIT_FRAMES frames spread evenly (the Gram
    // matrix of the fit is frames²), then every frame is projected on them.
    let step = n.div_ceil(MAX_FIT_FRAMES).max(1);
    let sample: Vec<f64> = frames().step_by(step).flatten().copied().collect();
    // Frames that never move have no direction to keep.
    let targets = if sample.len() / m > 1 && max_targets > 0 {
        match Pca::fit_wide(sample, m, max_targets) {
            Ok(p) => p.directions[..p.kept * m].to_vec(),
            Err(_) => Vec::new(),
        }
    } else {
        Vec::new()
    };
    let k = targets.len() / m;
    let weights: Vec<Vec<f64>> = tracks
        .iter()
        .map(|t| {
            t.chunks_exact(m)
                .flat_map(|f| {
                    targets
                        .chunks_exact(m)
                        .map(|v| v.iter().zip(f).zip(&mean).map(|((v, f), c)| v * (f - c)).sum::<f64>())
                        .collect::<Vec<_>>()
                })
                .collect()
        })
        .collect();
    let mut baked = Baked { vertices, mean, targets, weights, rms_error: 0.0 };
    let mut sq = 0.0;
    for (t, track) in tracks.iter().enumerate() {
        for (i, f) in track.chunks_exact(m).enumerate() {
            sq += baked.frame(t, i).iter().zip(f).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        }
    }
    debug_assert_eq!(baked.k(), k);
    baked.rms_error = (sq / (n * vertices) as f64).sqrt();
    Ok(baked)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two vertices moved along two fixed offsets by two curves, in two tracks.
    fn tracks() -> (Vec<f64>, Vec<f64>) {
        let frame = |t: f64| {
            let (a, b) = (t.sin(), (2.0 * t).cos());
            vec![1.0 + a, 0.0, 2.0 * b, -1.0, a + b, 0.5]
        };
        let one: Vec<f64> = (0..20).flat_map(|i| frame(f64::from(i) * 0.3)).collect();
        let two: Vec<f64> = (0..7).flat_map(|i| frame(f64::from(i) * 0.7 + 0.1)).collect();
        (one, two)
    }

    #[test]
    fn two_targets_reconstruct_a_rank_two_animation_exactly() {
        let (one, two) = tracks();
        let b = bake(&[&one, &two], 2, 8).unwrap();
        assert_eq!(b.k(), 2, "the offsets span two directions");
        assert!(b.rms_error < 1e-9, "{}", b.rms_error);
        let back = b.frame(1, 3);
        assert!(back.iter().zip(&two[18..24]).all(|(a, c)| (a - c).abs() < 1e-9));
        // One target leaves an error.
        assert!(bake(&[&one, &two], 2, 1).unwrap().rms_error > 1e-3);
        // A take longer than the fit's sample is still reconstructed exactly from it.
        let long: Vec<f64> = (0..2 * MAX_FIT_FRAMES + 3)
            .flat_map(|i| {
                let t = i as f64 * 0.01;
                vec![t.sin(), 0.0, 2.0 * t.cos(), -1.0, t.sin() + t.cos(), 0.5]
            })
            .collect();
        let b = bake(&[&long], 2, 8).unwrap();
        assert_eq!(b.k(), 2);
        assert!(b.rms_error < 1e-9, "{}", b.rms_error);
    }

    #[test]
    fn a_still_mesh_needs_no_target_and_bad_frames_are_refused() {
        let still = [0.0, 1.0, 2.0].repeat(4);
        let b = bake(&[&still], 1, 4).unwrap();
        assert_eq!(b.k(), 0);
        assert_eq!(b.rms_error, 0.0);
        assert!(matches!(bake(&[&still[..5]], 1, 4), Err(BakeError::Shape { .. })));
        let mut bad = still.clone();
        bad[7] = f64::NAN;
        assert_eq!(bake(&[&bad], 1, 4), Err(BakeError::NotFinite { track: 0, frame: 2 }));
    }
}
