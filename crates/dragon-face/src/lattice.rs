//! Final layer: a 4×4×4 Bernstein free-form-deformation (FFD) lattice bound to the head bone.
//!
//! The lattice box `[lo, lo + size]` is the rest head's bounding box plus 1 cm, in the head
//! bone's frame. For a skinned vertex `p`, its head-local position `q = G_head⁻¹ p` gets
//! lattice coordinates `(s, t, u) = clamp((q − lo) / size, 0, 1)`. The lattice points are
//! `P_ijk = lo + (i, j, k)/3 · size + Δ_ijk` with offsets `Δ_ijk` (cm) from the `lattice_ijk_t*`
//! controls; since cubic Bernstein polynomials reproduce the undeformed grid exactly, the
//! FFD image is `q' = q + Σ_ijk B_i(s) B_j(t) B_k(u) Δ_ijk` with `B_0 = (1−s)³`,
//! `B_1 = 3s(1−s)²`, `B_2 = 3s²(1−s)`, `B_3 = s³`, mapped back as `p' = p + R_head Σ…`.
//! Only the points with a non-zero offset are visited; all-zero offsets skip the layer.

use crate::controls::{lattice_name, LATTICE_N};
use crate::math::*;
use crate::mesh::Mesh;

#[derive(Clone, Debug)]
pub(crate) struct Lattice {
    lo: V3,
    inv_size: V3,
    /// Control indices (x, y, z offsets) and defaults of each point, in (i, j, k) order.
    points: Vec<([usize; 3], [f64; 3], [usize; 3])>,
}

#[inline]
fn bernstein(s: f64) -> [f64; 4] {
    let r = 1.0 - s;
    [r * r * r, 3.0 * s * r * r, 3.0 * s * s * r, s * s * s]
}

impl Lattice {
    pub(crate) fn new(mesh: &Mesh, ctl: &dyn Fn(&str) -> (usize, f64)) -> Lattice {
        let mut lo = [f64::MAX; 3];
        let mut hi = [f64::MIN; 3];
        for p in &mesh.pos[..mesh.head_count] {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] - 1.0);
                hi[a] = hi[a].max(p[a] + 1.0);
            }
        }
        let inv_size = [1.0 / (hi[0] - lo[0]), 1.0 / (hi[1] - lo[1]), 1.0 / (hi[2] - lo[2])];
        let mut points = Vec::new();
        for i in 0..LATTICE_N {
            for j in 0..LATTICE_N {
                for k in 0..LATTICE_N {
                    let c: [(usize, f64); 3] = [0, 1, 2].map(|a| ctl(&lattice_name(i, j, k, a)));
                    points.push((c.map(|x| x.0), c.map(|x| x.1), [i, j, k]));
                }
            }
        }
        Lattice { lo, inv_size, points }
    }

    /// Apply the FFD in place; `head` is the head bone's global (rigid) transform.
    pub(crate) fn apply(&self, controls: &[f64], head: &Affine, pos: &mut [f64]) {
        let active: Vec<([usize; 3], V3)> = self
            .points
            .iter()
            .filter_map(|(c, d, ijk)| {
                let off = [controls[c[0]] - d[0], controls[c[1]] - d[1], controls[c[2]] - d[2]];
                (off != [0.0; 3]).then_some((*ijk, off))
            })
            .collect();
        if active.is_empty() {
            return;
        }
        // Vertices in chunks, structure-of-arrays so the inner loops vectorise.
        const CH: usize = 64;
        let mut w = [[[0.0f64; CH]; LATTICE_N]; 3]; // [axis][basis][vertex]
        let mut d = [[0.0f64; CH]; 3];
        for chunk in pos.chunks_mut(3 * CH) {
            let m = chunk.len() / 3;
            for (v, p) in chunk.chunks_exact(3).enumerate() {
                let q = head.apply_rigid_inverse([p[0], p[1], p[2]]);
                for a in 0..3 {
                    let s = ((q[a] - self.lo[a]) * self.inv_size[a]).clamp(0.0, 1.0);
                    for (n, b) in bernstein(s).into_iter().enumerate() {
                        w[a][n][v] = b;
                    }
                }
            }
            d.iter_mut().for_each(|x| x.fill(0.0));
            for &([i, j, k], off) in &active {
                let (bs, bt, bu) = (&w[0][i], &w[1][j], &w[2][k]);
                let [dx, dy, dz] = &mut d;
                for v in 0..CH {
                    let b = bs[v] * bt[v] * bu[v];
                    dx[v] += b * off[0];
                    dy[v] += b * off[1];
                    dz[v] += b * off[2];
                }
            }
            for (v, p) in chunk.chunks_exact_mut(3).enumerate().take(m) {
                let r = head.apply_linear([d[0][v], d[1][v], d[2][v]]);
                p[0] += r[0];
                p[1] += r[1];
                p[2] += r[2];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::bernstein;

    #[test]
    fn bernstein_partition_of_unity_and_linear_precision() {
        for s in [0.0, 0.2, 0.5, 0.93, 1.0] {
            let b = bernstein(s);
            assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let lin: f64 = b.iter().enumerate().map(|(i, w)| w * i as f64 / 3.0).sum();
            assert!((lin - s).abs() < 1e-12);
        }
    }
}
