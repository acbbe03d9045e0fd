//! Small 3-vector and rigid/affine transform helpers (f64, centimetres, degrees at the API).

pub(crate) type V3 = [f64; 3];

pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) fn dist(a: V3, b: V3) -> f64 {
    norm(sub(a, b))
}

/// `a / |a|`, or `fallback` when `|a|` is (nearly) zero.
pub(crate) fn normalize_or(a: V3, fallback: V3) -> V3 {
    let n = norm(a);
    if n > 1e-12 {
        scale(a, 1.0 / n)
    } else {
        fallback
    }
}

pub(crate) fn normalize(a: V3) -> V3 {
    normalize_or(a, [0.0, 0.0, 1.0])
}

pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Cubic smoothstep: 0 below `e0`, 1 above `e1`, `3u² − 2u³` between (works for e0 > e1 too).
pub(crate) fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let u = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Compact smooth falloff `(1 − (d/r)²)²` for `d < r`, else 0. Value 1 at the centre, C¹ at `r`.
pub(crate) fn falloff(d: f64, r: f64) -> f64 {
    if d >= r {
        0.0
    } else {
        let q = 1.0 - (d / r) * (d / r);
        q * q
    }
}

/// A 3×4 affine transform `p ↦ M[:, :3] p + M[:, 3]` (rows stored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Affine(pub [[f64; 4]; 3]);

impl Affine {
    pub(crate) const IDENTITY: Affine = Affine([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]]);

    /// Rotation `R = Rz(rz) · Ry(ry) · Rx(rx)` (angles in degrees, right-handed, applied x first).
    pub(crate) fn rotation_deg(rx: f64, ry: f64, rz: f64) -> Affine {
        let (sx, cx) = rx.to_radians().sin_cos();
        let (sy, cy) = ry.to_radians().sin_cos();
        let (sz, cz) = rz.to_radians().sin_cos();
        Affine([
            [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx, 0.0],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx, 0.0],
            [-sy, cy * sx, cy * cx, 0.0],
        ])
    }

    /// `T(pivot + t) · R · T(−pivot)`: rotate about `pivot`, then translate by `t`.
    pub(crate) fn about_pivot(pivot: V3, rot: &Affine, t: V3) -> Affine {
        let mut m = *rot;
        let rp = rot.apply_linear(pivot);
        for (r, row) in m.0.iter_mut().enumerate() {
            row[3] = pivot[r] + t[r] - rp[r];
        }
        m
    }

    /// Composition `self · o` (apply `o` first).
    pub(crate) fn mul(&self, o: &Affine) -> Affine {
        let a = &self.0;
        let b = &o.0;
        let mut m = [[0.0; 4]; 3];
        for r in 0..3 {
            for c in 0..4 {
                let mut s = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
                if c == 3 {
                    s += a[r][3];
                }
                m[r][c] = s;
            }
        }
        Affine(m)
    }

    pub(crate) fn apply(&self, p: V3) -> V3 {
        let m = &self.0;
        [
            m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2] + m[0][3],
            m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2] + m[1][3],
            m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2] + m[2][3],
        ]
    }

    pub(crate) fn apply_linear(&self, p: V3) -> V3 {
        let m = &self.0;
        [
            m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2],
            m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2],
            m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2],
        ]
    }

    /// Inverse of a rigid transform (orthonormal linear part): `Rᵀ (p − t)`.
    pub(crate) fn apply_rigid_inverse(&self, p: V3) -> V3 {
        let m = &self.0;
        let q = [p[0] - m[0][3], p[1] - m[1][3], p[2] - m[2][3]];
        [
            m[0][0] * q[0] + m[1][0] * q[1] + m[2][0] * q[2],
            m[0][1] * q[0] + m[1][1] * q[1] + m[2][1] * q[2],
            m[0][2] * q[0] + m[1][2] * q[1] + m[2][2] * q[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_conventions() {
        // +90° about y maps +z (forward) to +x (character's left).
        let r = Affine::rotation_deg(0.0, 90.0, 0.0);
        let p = r.apply([0.0, 0.0, 1.0]);
        assert!(dist(p, [1.0, 0.0, 0.0]) < 1e-12, "{p:?}");
        // +90° about x maps +z to −y (pitch down).
        let r = Affine::rotation_deg(90.0, 0.0, 0.0);
        let p = r.apply([0.0, 0.0, 1.0]);
        assert!(dist(p, [0.0, -1.0, 0.0]) < 1e-12, "{p:?}");
        // Pivot rotation leaves the pivot fixed and rigid inverse undoes it.
        let pivot = [1.0, 2.0, 3.0];
        let m = Affine::about_pivot(pivot, &Affine::rotation_deg(10.0, 20.0, 30.0), [0.5, 0.0, 0.0]);
        assert!(dist(m.apply(pivot), [1.5, 2.0, 3.0]) < 1e-12);
        let q = [4.0, -1.0, 2.0];
        assert!(dist(m.apply_rigid_inverse(m.apply(q)), q) < 1e-12);
    }
}
