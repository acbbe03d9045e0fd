//! Keyframe tracks and their sampling, following the glTF 2.0 interpolation rules.
//!
//! * `LINEAR`: slerp for rotation quaternions (shortest path), lerp for everything else.
//! * `STEP`: the value of the last key at or before `t`.
//! * `CUBICSPLINE`: cubic Hermite per component with the in/out tangents scaled by the key
//!   interval `t_{k+1} - t_k`; quaternions are normalised afterwards.
//! * Before the first key the first value is held, after the last key the last value.

use glam::DQuat;

use crate::rotation::slerp;

/// A sampler's interpolation mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interp {
    Linear,
    Step,
    CubicSpline,
}

impl From<gltf::animation::Interpolation> for Interp {
    fn from(i: gltf::animation::Interpolation) -> Self {
        match i {
            gltf::animation::Interpolation::Linear => Interp::Linear,
            gltf::animation::Interpolation::Step => Interp::Step,
            gltf::animation::Interpolation::CubicSpline => Interp::CubicSpline,
        }
    }
}

/// One animation sampler as numbers: key times (seconds) and per-key values.
#[derive(Debug, Clone)]
pub struct Track {
    times: Vec<f64>,
    /// `stride` numbers per element. LINEAR/STEP: one element per key. CUBICSPLINE: three
    /// per key, in the glTF order (in-tangent, value, out-tangent).
    values: Vec<f64>,
    stride: usize,
    interp: Interp,
    /// Elements are quaternions (x, y, z, w): slerp / normalise.
    quaternion: bool,
}

impl Track {
    /// Checks counts and that times do not decrease.
    pub fn new(
        times: Vec<f64>,
        values: Vec<f64>,
        stride: usize,
        interp: Interp,
        quaternion: bool,
    ) -> Result<Self, String> {
        if times.is_empty() {
            return Err("no keyframes".into());
        }
        if stride == 0 || (quaternion && stride != 4) {
            return Err(format!("bad element width {stride}"));
        }
        let per_key = if interp == Interp::CubicSpline { 3 } else { 1 };
        let want = times.len() * per_key * stride;
        if values.len() != want {
            return Err(format!(
                "{} output numbers for {} keys ({:?}, {} per element): expected {want}",
                values.len(),
                times.len(),
                interp,
                stride
            ));
        }
        if times.iter().chain(&values).any(|x| !x.is_finite()) {
            return Err("non-finite key time or value".into());
        }
        if let Some(k) = times.windows(2).position(|w| w[1] < w[0]) {
            return Err(format!("key times decrease at key {}: {} then {}", k + 1, times[k], times[k + 1]));
        }
        Ok(Self { times, values, stride, interp, quaternion })
    }

    pub fn times(&self) -> &[f64] {
        &self.times
    }

    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Time of the last key (seconds).
    pub fn end_time(&self) -> f64 {
        *self.times.last().expect("non-empty")
    }

    fn element(&self, e: usize) -> &[f64] {
        &self.values[e * self.stride..(e + 1) * self.stride]
    }

    fn value(&self, k: usize) -> &[f64] {
        match self.interp {
            Interp::CubicSpline => self.element(3 * k + 1),
            _ => self.element(k),
        }
    }

    /// Writes the track's value at time `t` (seconds) into `out` (`stride` numbers).
    pub fn sample(&self, t: f64, out: &mut [f64]) {
        let out = &mut out[..self.stride];
        let n = self.times.len();
        if t <= self.times[0] {
            out.copy_from_slice(self.value(0));
            return;
        }
        if t >= self.times[n - 1] {
            out.copy_from_slice(self.value(n - 1));
            return;
        }
        // times[i] <= t < times[i + 1]
        let i = self.times.partition_point(|&x| x <= t) - 1;
        let dt = self.times[i + 1] - self.times[i];
        let u = (t - self.times[i]) / dt;
        match self.interp {
            Interp::Step => out.copy_from_slice(self.value(i)),
            Interp::Linear if self.quaternion => {
                let q = slerp(quat(self.value(i)), quat(self.value(i + 1)), u);
                out.copy_from_slice(&q.to_array());
            }
            Interp::Linear => {
                let (a, b) = (self.value(i), self.value(i + 1));
                for c in 0..self.stride {
                    out[c] = a[c] + (b[c] - a[c]) * u;
                }
            }
            Interp::CubicSpline => {
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                let v0 = self.element(3 * i + 1);
                let b0 = self.element(3 * i + 2); // out-tangent of key i
                let v1 = self.element(3 * (i + 1) + 1);
                let a1 = self.element(3 * (i + 1)); // in-tangent of key i + 1
                for c in 0..self.stride {
                    out[c] = h00 * v0[c] + h10 * dt * b0[c] + h01 * v1[c] + h11 * dt * a1[c];
                }
                if self.quaternion {
                    let q = quat(out).normalize();
                    out.copy_from_slice(&q.to_array());
                }
            }
        }
    }
}

fn quat(v: &[f64]) -> DQuat {
    DQuat::from_xyzw(v[0], v[1], v[2], v[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn at(track: &Track, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; track.stride()];
        track.sample(t, &mut out);
        out
    }

    fn close(a: &[f64], b: &[f64]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn linear_step_and_hold() {
        let lin = Track::new(vec![1.0, 2.0, 4.0], vec![0.0, 10.0, 30.0], 1, Interp::Linear, false).unwrap();
        assert!(close(&at(&lin, 0.0), &[0.0])); // before the first key: hold
        assert!(close(&at(&lin, 1.5), &[5.0]));
        assert!(close(&at(&lin, 3.0), &[20.0]));
        assert!(close(&at(&lin, 9.0), &[30.0])); // after the last key: hold
        let step = Track::new(vec![1.0, 2.0, 4.0], vec![0.0, 10.0, 30.0], 1, Interp::Step, false).unwrap();
        assert!(close(&at(&step, 1.99), &[0.0]));
        assert!(close(&at(&step, 2.0), &[10.0]));
        assert!(close(&at(&step, 3.9), &[10.0]));
    }

    #[test]
    fn linear_rotation_slerps() {
        // 0° → 120° about x over one second: at t = 0.25 the rotation is 30°.
        let a = DQuat::IDENTITY.to_array();
        let b = DQuat::from_rotation_x(2.0 * PI / 3.0).to_array();
        let tr = Track::new(vec![0.0, 1.0], [a, b].concat(), 4, Interp::Linear, true).unwrap();
        let q = quat(&at(&tr, 0.25));
        assert!(q.dot(DQuat::from_rotation_x(PI / 6.0)).abs() > 1.0 - 1e-12);
        // stored with the opposite sign: still the short way
        let neg_b = (-DQuat::from_rotation_x(2.0 * PI / 3.0)).to_array();
        let tr = Track::new(vec![0.0, 1.0], [a, neg_b].concat(), 4, Interp::Linear, true).unwrap();
        let q = quat(&at(&tr, 0.25));
        assert!(q.dot(DQuat::from_rotation_x(PI / 6.0)).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn cubic_spline_hermite_with_scaled_tangents() {
        // Keys at t = 0 and t = 2, values 0 → 0, out-tangent of key 0 is 1, others 0.
        // p(u) = h10(u) · Δt · 1 = 2(u³ − 2u² + u); at u = ½ (t = 1): 0.25; at u = ¼: 0.28125.
        let vals = vec![
            0.0, 0.0, 1.0, // key 0: in, value, out
            0.0, 0.0, 0.0, // key 1
        ];
        let tr = Track::new(vec![0.0, 2.0], vals, 1, Interp::CubicSpline, false).unwrap();
        assert!(close(&at(&tr, 1.0), &[0.25]));
        assert!(close(&at(&tr, 0.5), &[0.28125]));
        // zero tangents: smoothstep between the values
        let vals = vec![9.0, 0.0, 9.0, -9.0, 1.0, -9.0];
        let tr = Track::new(vec![0.0, 1.0], vals, 1, Interp::CubicSpline, false).unwrap();
        let vals0 = vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let tr0 = Track::new(vec![0.0, 1.0], vals0, 1, Interp::CubicSpline, false).unwrap();
        assert!(close(&at(&tr0, 0.25), &[0.15625]));
        // hold outside uses the value, never a tangent
        assert!(close(&at(&tr, -1.0), &[0.0]));
        assert!(close(&at(&tr, 5.0), &[1.0]));
    }

    #[test]
    fn cubic_spline_quaternions_are_normalised() {
        let a = DQuat::IDENTITY.to_array();
        let b = DQuat::from_rotation_y(PI / 2.0).to_array();
        let z = [0.0; 4];
        let vals = [z, a, z, z, b, z].concat();
        let tr = Track::new(vec![0.0, 1.0], vals, 4, Interp::CubicSpline, true).unwrap();
        let q = quat(&at(&tr, 0.5));
        assert!((q.length() - 1.0).abs() < 1e-12);
        // symmetric blend of identity and 90° about y, normalised: exactly 45° about y
        assert!(q.dot(DQuat::from_rotation_y(PI / 4.0)).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn rejects_bad_tracks() {
        assert!(Track::new(vec![], vec![], 1, Interp::Linear, false).is_err());
        assert!(Track::new(vec![0.0, 1.0], vec![0.0], 1, Interp::Linear, false).is_err());
        assert!(Track::new(vec![1.0, 0.0], vec![0.0, 1.0], 1, Interp::Linear, false).is_err());
        assert!(Track::new(vec![0.0, 1.0], vec![0.0; 2], 1, Interp::CubicSpline, false).is_err());
    }
}
