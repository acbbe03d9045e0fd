//! Rotation vectors (axis · angle, radians) and unit quaternions.
//!
//! Convention used across the crate: a node's local rotation is `R = R_rest · exp([v]×)`,
//! where `R_rest` is the node's rest rotation from the file and `v` is the rotation vector
//! stored in the `<node>.rx/.ry/.rz` controls. In quaternions: `q = q_rest * exp(v)`, and
//! `v = log(q_rest⁻¹ * q)`. Quaternions are glam's `DQuat` (x, y, z, w), Hamilton product.

use glam::{DQuat, DVec3};
use std::f64::consts::TAU;

/// Rotation vector → unit quaternion (`exp(v) = (sin(|v|/2)·v̂, cos(|v|/2))`).
pub fn exp(v: DVec3) -> DQuat {
    let angle = v.length();
    if angle < 1e-12 {
        DQuat::from_xyzw(0.5 * v.x, 0.5 * v.y, 0.5 * v.z, 1.0).normalize()
    } else {
        DQuat::from_axis_angle(v / angle, angle)
    }
}

/// Unit quaternion → rotation vector with angle `2·atan2(|xyz|, w)` ∈ [0, 2π].
/// `log(q)` and `log(-q)` differ by `2π` along the axis; both satisfy `exp(log(q)) ≅ q`.
pub fn log(q: DQuat) -> DVec3 {
    let xyz = DVec3::new(q.x, q.y, q.z);
    let s = xyz.length();
    if s < 1e-12 {
        // First order; also right for w ≈ -1, where -q is the identity's small neighbour.
        return 2.0 * xyz / q.w;
    }
    2.0 * s.atan2(q.w) * xyz / s
}

/// Among the rotation vectors of one rotation, `v + 2πk·v̂` (k ∈ ℤ), the one nearest `prev`.
/// For `v ≈ 0` the axis is taken from `prev` (every `2πk·û` is the identity).
pub fn nearest_equivalent(v: DVec3, prev: DVec3) -> DVec3 {
    let len = v.length();
    let axis = if len > 1e-12 {
        v / len
    } else if prev.length() > 1e-12 {
        prev.normalize()
    } else {
        return v;
    };
    let k_star = (prev - v).dot(axis) / TAU;
    let a = v + TAU * k_star.floor() * axis;
    let b = v + TAU * k_star.ceil() * axis;
    if a.distance_squared(prev) <= b.distance_squared(prev) {
        a
    } else {
        b
    }
}

/// Turns a sequence of quaternions into a continuous sequence of rotation vectors:
/// each quaternion's sign is chosen so `q·q_prev ≥ 0`, then among the equivalent rotation
/// vectors the one nearest the previous frame's is kept. The first frame gets the principal
/// value (angle ≤ π).
#[derive(Debug, Clone, Default)]
pub struct ContinuousLog {
    prev: Option<(DQuat, DVec3)>,
}

impl ContinuousLog {
    pub fn new() -> Self {
        Self::default()
    }

    /// The rotation vector of `q` continuing the sequence so far.
    pub fn next(&mut self, q: DQuat) -> DVec3 {
        let (q, v) = match self.prev {
            None => {
                let q = if q.w < 0.0 { -q } else { q };
                (q, log(q))
            }
            Some((q_prev, v_prev)) => {
                let q = if q.dot(q_prev) < 0.0 { -q } else { q };
                (q, nearest_equivalent(log(q), v_prev))
            }
        };
        self.prev = Some((q, v));
        v
    }
}

/// Spherical linear interpolation as in the glTF 2.0 specification (Appendix: Interpolation):
/// shortest path (`b` negated when `a·b < 0`), result normalised; linear fallback for
/// nearly equal quaternions.
pub fn slerp(a: DQuat, b: DQuat, t: f64) -> DQuat {
    let mut d = a.dot(b);
    let b = if d < 0.0 {
        d = -d;
        -b
    } else {
        b
    };
    if d > 1.0 - 1e-12 {
        return (a + (b - a) * t).normalize();
    }
    let theta = d.min(1.0).acos();
    let s = theta.sin();
    (a * (((1.0 - t) * theta).sin() / s) + b * ((t * theta).sin() / s)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn same_rotation(a: DQuat, b: DQuat) -> bool {
        a.dot(b).abs() > 1.0 - 1e-12
    }

    #[test]
    fn log_exp_round_trip() {
        let vs = [
            DVec3::new(0.1, -0.2, 0.3),
            DVec3::new(0.0, 0.0, 3.0),
            DVec3::new(1e-9, 0.0, -2e-9),
            DVec3::new(-2.0, 1.0, 0.5),
            DVec3::ZERO,
            DVec3::new(0.0, PI - 1e-6, 0.0),
        ];
        for v in vs {
            let q = exp(v);
            assert!((q.length() - 1.0).abs() < 1e-12);
            let back = log(q);
            assert!(back.distance(v) < 1e-9, "{v} -> {back}");
        }
        // quaternion → vector → quaternion, including w < 0 (angle > π)
        for q in [
            DQuat::from_xyzw(0.3, -0.5, 0.1, -0.8).normalize(),
            DQuat::from_xyzw(-0.01, 0.02, 0.0, -1.0).normalize(),
            DQuat::from_xyzw(0.7, 0.1, 0.1, 0.1).normalize(),
        ] {
            assert!(same_rotation(exp(log(q)), q), "{q}");
            assert!(same_rotation(exp(log(-q)), q), "{q}");
        }
        // a known value: 90° about y
        let q = DQuat::from_rotation_y(PI / 2.0);
        assert!(log(q).distance(DVec3::new(0.0, PI / 2.0, 0.0)) < 1e-12);
    }

    #[test]
    fn continuity_through_350_degrees() {
        // A steady spin about a tilted axis from 0° to 350°, 5° a step; quaternion signs
        // are flipped at random-looking frames as a file may store them.
        let axis = DVec3::new(0.2, 1.0, -0.3).normalize();
        let mut track = ContinuousLog::new();
        let mut prev: Option<DVec3> = None;
        for k in 0..=70 {
            let angle = (5.0 * k as f64).to_radians();
            let mut q = DQuat::from_axis_angle(axis, angle);
            if k % 3 == 1 || k % 7 == 0 {
                q = -q;
            }
            let v = track.next(q);
            assert!(same_rotation(exp(v), q));
            // continuous: steps of 5°, never the jump from ~π to ~-π
            if let Some(p) = prev {
                assert!(v.distance(p) < 5.0_f64.to_radians() + 1e-9, "frame {k}: {p} -> {v}");
            }
            // and it actually unwraps: the vector keeps growing along the axis past π
            assert!((v - axis * angle).length() < 1e-9, "frame {k}: {v} vs {}", axis * angle);
            prev = Some(v);
        }
        assert!((prev.unwrap().length() - 350.0_f64.to_radians()).abs() < 1e-9);
    }

    #[test]
    fn nearest_equivalent_picks_the_branch() {
        let v = DVec3::new(0.0, 0.0, -3.0);
        let prev = DVec3::new(0.0, 0.0, 3.1);
        let w = nearest_equivalent(v, prev);
        assert!(w.distance(DVec3::new(0.0, 0.0, TAU - 3.0)) < 1e-12);
        // identity after a full turn stays at 2π
        let w = nearest_equivalent(DVec3::ZERO, DVec3::new(0.0, 6.2, 0.0));
        assert!(w.distance(DVec3::new(0.0, TAU, 0.0)) < 1e-12);
    }

    #[test]
    fn slerp_known_answers() {
        let a = DQuat::IDENTITY;
        let b = DQuat::from_rotation_z(PI / 2.0);
        let m = slerp(a, b, 0.5);
        assert!(same_rotation(m, DQuat::from_rotation_z(PI / 4.0)));
        let q = slerp(a, b, 0.25);
        assert!(same_rotation(q, DQuat::from_rotation_z(PI / 8.0)));
        // shortest path: -b is the same rotation, the answer must not change
        assert!(same_rotation(slerp(a, -b, 0.5), m));
        // endpoints
        assert!(same_rotation(slerp(a, b, 0.0), a));
        assert!(same_rotation(slerp(a, b, 1.0), b));
    }
}
