//! The target space: a character's controls scaled by their effect on the mesh (Bailey et
//! al. Eq. 3, the `scales` artifact's weights $w_j$, mesh length per control unit) and
//! reduced by PCA, as the gplvm stage models a label. A pose $p$ has coordinates
//! $c = V_d^\top (w \odot p - \mu)$; coordinates decode to $p_j = (\mu + V_d c)_j / w_j$
//! for every control with $w_j > 0$, and to the poses' mean for the others (they move no
//! vertex, or never moved).

use reprise_numerics::pca::{Pca, PcaError, PcaParams};

/// A fitted target space.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSpace {
    /// $w_j$ per control (0: held at [`TargetSpace::held`]).
    pub weights: Vec<f64>,
    /// The value of each control with $w_j = 0$: its mean over the fitted poses.
    pub held: Vec<f64>,
    /// $\mu$, the scaled poses' mean.
    pub mean: Vec<f64>,
    /// $V_d^\top$, row-major `d × controls`.
    pub directions: Vec<f64>,
    /// Share of the scaled poses' variance the kept components explain.
    pub explained: f64,
}

impl TargetSpace {
    /// Fits the space to `poses` (`n × c`, row-major) with `weights` (`c`), keeping the
    /// fewest components (at most `max_components`) that explain `variance` of the scaled
    /// poses' variance.
    ///
    /// # Errors
    /// Fewer than two poses, mismatched lengths, no variance, or bad parameters.
    pub fn fit(poses: &[f64], weights: &[f64], variance: f64, max_components: usize) -> Result<Self, PcaError> {
        let c = weights.len();
        if c == 0 || !poses.len().is_multiple_of(c) {
            return Err(PcaError::Shape { values: poses.len(), cols: c });
        }
        let n = (poses.len() / c).max(1) as f64;
        let held: Vec<f64> = (0..c).map(|j| poses.chunks_exact(c).map(|p| p[j]).sum::<f64>() / n).collect();
        let scaled: Vec<f64> = poses.chunks_exact(c).flat_map(|p| p.iter().zip(weights).map(|(a, w)| a * w)).collect();
        let pca = Pca::fit(&scaled, c, &PcaParams { variance, min_components: 1, max_components })?;
        let explained = pca.cumulative_explained().get(pca.kept.max(1) - 1).copied().unwrap_or(0.0);
        Ok(Self {
            weights: weights.to_vec(),
            held,
            mean: pca.mean,
            directions: pca.directions[..pca.kept * c].to_vec(),
            explained,
        })
    }

    /// Kept components.
    pub fn d(&self) -> usize {
        self.directions.len() / self.weights.len().max(1)
    }

    /// The coordinates of one pose.
    pub fn encode(&self, pose: &[f64]) -> Vec<f64> {
        let c = self.weights.len();
        self.directions
            .chunks_exact(c)
            .map(|v| {
                v.iter().zip(pose).zip(&self.weights).zip(&self.mean).map(|(((v, p), w), m)| v * (w * p - m)).sum()
            })
            .collect()
    }

    /// The pose of coordinates `coords` (length [`TargetSpace::d`]).
    pub fn decode(&self, coords: &[f64]) -> Vec<f64> {
        let c = self.weights.len();
        let mut z = self.mean.clone();
        for (v, a) in self.directions.chunks_exact(c).zip(coords) {
            z.iter_mut().zip(v).for_each(|(z, v)| *z += a * v);
        }
        z.iter().zip(&self.weights).zip(&self.held).map(|((z, &w), h)| if w > 0.0 { z / w } else { *h }).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_in_the_span_round_trip_and_unweighted_controls_are_held() {
        // Three controls: the first two move together on a line in the scaled space, the
        // third has weight 0 (moves no vertex) and varies anyway.
        let poses: Vec<f64> = (0..10)
            .flat_map(|i| {
                let t = f64::from(i);
                [t, 2.0 - 0.5 * t, (t * 1.3).sin()]
            })
            .collect();
        let s = TargetSpace::fit(&poses, &[2.0, 4.0, 0.0], 0.999, 8).unwrap();
        assert_eq!(s.d(), 1, "one direction explains the scaled poses");
        assert!((s.explained - 1.0).abs() < 1e-12);
        let held = poses.chunks_exact(3).map(|p| p[2]).sum::<f64>() / 10.0;
        for p in poses.chunks_exact(3) {
            let back = s.decode(&s.encode(p));
            assert!((back[0] - p[0]).abs() < 1e-9 && (back[1] - p[1]).abs() < 1e-9, "{back:?} vs {p:?}");
            assert!((back[2] - held).abs() < 1e-12);
        }
        // The coordinate is the scaled distance along the line: one unit of t moves the
        // scaled pose by (2, −2), length √8.
        let a = s.encode(&poses[..3])[0];
        let b = s.encode(&poses[3..6])[0];
        assert!(((a - b).abs() - 8f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn mismatched_lengths_are_errors() {
        assert!(TargetSpace::fit(&[1.0, 2.0, 3.0], &[1.0, 1.0], 0.9, 4).is_err());
    }
}
