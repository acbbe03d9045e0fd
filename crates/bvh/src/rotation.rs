//! Rotations: Euler channels to quaternions, quaternion slerp, quaternions to continuous
//! rotation vectors, and rotation vectors to matrices.
//!
//! Quaternions are `[w, x, y, z]`, unit length. A rotation vector is axis · angle in
//! radians (the log map). Matrices are row-major 3×3 acting on column vectors.

use std::f64::consts::PI;

/// A unit quaternion `[w, x, y, z]`.
pub type Quat = [f64; 4];

/// The identity rotation.
pub const IDENTITY: Quat = [1.0, 0.0, 0.0, 0.0];

/// Hamilton product `a · b` (apply `b` first, then `a`).
pub fn mul(a: Quat, b: Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// Rotation by `degrees` about the coordinate axis `axis` (0 = X, 1 = Y, 2 = Z).
pub fn axis_rotation(axis: usize, degrees: f64) -> Quat {
    let half = degrees.to_radians() * 0.5;
    let mut q = [half.cos(), 0.0, 0.0, 0.0];
    q[1 + axis] = half.sin();
    q
}

/// The rotation of a sequence of Euler channels `(axis, degrees)` in declared order:
/// `R = R_first · R_second · …` (intrinsic, BVH convention).
pub fn euler(channels: impl IntoIterator<Item = (usize, f64)>) -> Quat {
    channels.into_iter().fold(IDENTITY, |q, (axis, degrees)| mul(q, axis_rotation(axis, degrees)))
}

fn dot(a: Quat, b: Quat) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

fn norm4(q: Quat) -> f64 {
    dot(q, q).sqrt()
}

/// Spherical linear interpolation from `a` (t = 0) to `b` (t = 1) along the shorter arc.
pub fn slerp(a: Quat, b: Quat, t: f64) -> Quat {
    let b = if dot(a, b) < 0.0 { b.map(|v| -v) } else { b };
    // Angle between the two 4-vectors, computed stably: 2·atan2(|a−b|, |a+b|).
    let diff = norm4([a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]);
    let sum = norm4([a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]);
    let omega = 2.0 * diff.atan2(sum);
    let (wa, wb) = if omega < 1e-9 {
        (1.0 - t, t)
    } else {
        let s = omega.sin();
        (((1.0 - t) * omega).sin() / s, (t * omega).sin() / s)
    };
    let q = [0, 1, 2, 3].map(|i| wa * a[i] + wb * b[i]);
    let n = norm4(q);
    q.map(|v| v / n)
}

/// The rotation vector (axis · angle, angle in [0, π]) of a unit quaternion.
pub fn log(q: Quat) -> [f64; 3] {
    let q = if q[0] < 0.0 { q.map(|v| -v) } else { q };
    let s = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    // angle = 2·atan2(s, w); the factor angle / s tends to 2 / w as s → 0.
    let factor = if s < 1e-12 { 2.0 / q[0] } else { 2.0 * s.atan2(q[0]) / s };
    [q[1] * factor, q[2] * factor, q[3] * factor]
}

/// The rotation vector of `q` that continues `prev` (the previous frame's vector).
///
/// Among the equivalent vectors `v + 2πk·v̂` (k any integer) the one nearest to `prev`
/// is returned. This includes the choice of the quaternion's sign (`q · q_prev ≥ 0`):
/// `−q` is the vector `v − 2π·v̂`, one of the candidates. The first frame of a curve
/// passes `prev = [0, 0, 0]` (the default), which gives the angle in [0, π].
pub fn continuous_log(q: Quat, prev: [f64; 3]) -> [f64; 3] {
    let v = log(q);
    let angle = norm3(v);
    let prev_norm = norm3(prev);
    // The axis: v's own, or for (near) identity the previous axis, since 2πk·â is the
    // identity for any unit â.
    let axis = if angle > 1e-12 {
        v.map(|c| c / angle)
    } else if prev_norm > 1e-12 {
        prev.map(|c| c / prev_norm)
    } else {
        return v;
    };
    // |(angle + 2πk)·â − prev|² is smallest for angle + 2πk nearest to â·prev.
    let along = axis[0] * prev[0] + axis[1] * prev[1] + axis[2] * prev[2];
    let k = ((along - angle) / (2.0 * PI)).round();
    let angle = angle + 2.0 * PI * k;
    axis.map(|c| c * angle)
}

fn norm3(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The unit quaternion of a rotation vector (any length; angles beyond π are fine).
pub fn exp(v: [f64; 3]) -> Quat {
    let angle = norm3(v);
    let half = 0.5 * angle;
    // sin(angle/2) / angle, with its series near zero.
    let factor = if angle < 1e-4 { 0.5 - angle * angle / 48.0 } else { half.sin() / angle };
    [half.cos(), v[0] * factor, v[1] * factor, v[2] * factor]
}

/// The row-major rotation matrix of a unit quaternion.
pub fn matrix(q: Quat) -> [f64; 9] {
    let [w, x, y, z] = q;
    [
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn exp_log_round_trip() {
        for v in [[0.0, 0.0, 0.0], [1e-9, -2e-9, 0.0], [0.3, -0.2, 0.1], [0.0, PI - 1e-6, 0.0], [1.0, 2.0, -0.5]] {
            let q = exp(v);
            let back = exp(log(q));
            // Compare rotations (matrices), since log wraps angles into [0, π].
            assert!(close(&matrix(q), &matrix(back), 1e-12), "{v:?}");
        }
        let v = [0.3, -0.2, 0.1];
        assert!(close(&log(exp(v)), &v, 1e-15));
    }

    #[test]
    fn slerp_halfway_about_one_axis() {
        let a = axis_rotation(2, 10.0);
        let b = axis_rotation(2, 50.0);
        assert!(close(&slerp(a, b, 0.5), &axis_rotation(2, 30.0), 1e-15));
        assert!(close(&slerp(a, b, 0.0), &a, 1e-15));
        assert!(close(&slerp(a, b, 1.0), &b, 1e-15));
        // Shorter arc even when b is given with the opposite sign.
        assert!(close(&slerp(a, b.map(|v| -v), 0.5), &axis_rotation(2, 30.0), 1e-15));
    }

    #[test]
    fn continuous_log_prefers_the_nearest_equivalent() {
        // 190° about Y after 180° about Y continues to 190°, not −170°.
        let prev = [0.0, PI, 0.0];
        let v = continuous_log(axis_rotation(1, 190.0), prev);
        assert!(close(&v, &[0.0, 190f64.to_radians(), 0.0], 1e-12), "{v:?}");
        // Identity after a full turn stays at 2π.
        let v = continuous_log(IDENTITY, [0.0, 2.0 * PI - 0.01, 0.0]);
        assert!(close(&v, &[0.0, 2.0 * PI, 0.0], 1e-12), "{v:?}");
    }
}
