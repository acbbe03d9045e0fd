//! Inertialization with critically damped springs (method.md §7.3; Holden's `spring.h`,
//! `inertialize_transition` / `inertialize_update`).
//!
//! Per control, an offset $(o_x, o_v)$ decays as the exact solution of
//! $\ddot x + 2y\dot x + y^2x = 0$ with $y = 2\ln 2/h$ for half-life $h$ (seconds):
//! $$j_1 = v + yx,\quad x(t+\Delta t) = e^{-y\Delta t}(x + j_1\Delta t),\quad
//! v(t+\Delta t) = e^{-y\Delta t}(v - j_1 y\Delta t).$$
//! At a switch from source $(x_s, v_s)$ to destination $(x_d, v_d)$ the offset becomes
//! $o_x \leftarrow (x_s + o_x) - x_d$, $o_v \leftarrow (v_s + o_v) - v_d$, so the output
//! $x_d + o_x$ and its velocity $v_d + o_v$ equal the pre-switch output exactly: the
//! output is $C^1$ in continuous time. Rig controls are blended linearly (rig space), so no
//! quaternion form is needed.

use crate::error::{MatchError, Result};

/// $y = 2\ln2/h$ (1/s); half the reference's `halflife_to_damping`.
pub fn spring_rate(halflife: f64) -> f64 {
    2.0 * std::f64::consts::LN_2 / halflife
}

/// Advances $(x, v)$ of a critically damped spring towards 0 by `dt` seconds (exact).
/// `halflife` must be positive.
pub fn decay_spring(x: &mut f64, v: &mut f64, halflife: f64, dt: f64) {
    let y = spring_rate(halflife);
    let j1 = *v + y * *x;
    let e = (-y * dt).exp();
    *x = e * (*x + j1 * dt);
    *v = e * (*v - j1 * y * dt);
}

/// Per-control offsets decayed by springs; a half-life of 0 means a hard cut (no offset).
#[derive(Debug, Clone, PartialEq)]
pub struct Inertializer {
    halflife: f64,
    offset_x: Vec<f64>,
    offset_v: Vec<f64>,
}

impl Inertializer {
    /// Zero offsets for `dim` controls.
    ///
    /// # Errors
    /// [`MatchError::Param`] if `halflife` is negative or not finite.
    pub fn new(dim: usize, halflife: f64) -> Result<Self> {
        if !(halflife.is_finite() && halflife >= 0.0) {
            return Err(MatchError::Param {
                name: "halflife",
                reason: format!("must be finite and ≥ 0 seconds, got {halflife}"),
            });
        }
        Ok(Self { halflife, offset_x: vec![0.0; dim], offset_v: vec![0.0; dim] })
    }

    /// Records a switch from the source animation's $(x_s, v_s)$ to the destination's
    /// $(x_d, v_d)$ (each of length `dim`).
    pub fn transition(&mut self, src_x: &[f64], src_v: &[f64], dst_x: &[f64], dst_v: &[f64]) {
        if self.halflife == 0.0 {
            return;
        }
        for (o, (s, d)) in self.offset_x.iter_mut().zip(src_x.iter().zip(dst_x)) {
            *o = (s + *o) - d;
        }
        for (o, (s, d)) in self.offset_v.iter_mut().zip(src_v.iter().zip(dst_v)) {
            *o = (s + *o) - d;
        }
    }

    /// Decays every offset by `dt` seconds.
    pub fn update(&mut self, dt: f64) {
        if self.halflife == 0.0 {
            return;
        }
        for (x, v) in self.offset_x.iter_mut().zip(&mut self.offset_v) {
            decay_spring(x, v, self.halflife, dt);
        }
    }

    /// `out = anim + o_x`.
    pub fn apply(&self, anim: &[f64], out: &mut [f64]) {
        for ((o, a), x) in out.iter_mut().zip(anim).zip(&self.offset_x) {
            *o = a + x;
        }
    }

    /// Position offsets $o_x$.
    pub fn offset_x(&self) -> &[f64] {
        &self.offset_x
    }

    /// Velocity offsets $o_v$.
    pub fn offset_v(&self) -> &[f64] {
        &self.offset_v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    fn step(x: f64, v: f64, h: f64, dt: f64) -> (f64, f64) {
        let (mut x, mut v) = (x, v);
        decay_spring(&mut x, &mut v, h, dt);
        (x, v)
    }

    /// §7.6 (c): two steps of Δt equal one of 2Δt; Δt = 0 preserves (x, v); the
    /// trajectory satisfies ẍ + 2yẋ + y²x = 0 by central differences; the pure mode
    /// v = −yx decays as e^{−yt}, i.e. to 1/4 after one half-life h (y = 2 ln 2 / h).
    #[test]
    fn spring_is_the_exact_solution() {
        let h = 0.1;
        for (x0, v0) in [(1.0, 0.0), (-0.3, 4.0), (2.0, -7.5)] {
            let (x1, v1) = step(x0, v0, h, 0.013);
            let (x2, v2) = step(x1, v1, h, 0.013);
            let (x3, v3) = step(x0, v0, h, 0.026);
            assert_abs_diff_eq!(x2, x3, epsilon = 1e-14);
            assert_abs_diff_eq!(v2, v3, epsilon = 1e-13);
            assert_eq!(step(x0, v0, h, 0.0), (x0, v0));
            let y = spring_rate(h);
            let e = 1e-5;
            for t in [0.01, 0.05, 0.2] {
                let (xm, _) = step(x0, v0, h, t - e);
                let (x, v) = step(x0, v0, h, t);
                let (xp, _) = step(x0, v0, h, t + e);
                let acc = (xp - 2.0 * x + xm) / (e * e);
                let vel = (xp - xm) / (2.0 * e);
                assert_abs_diff_eq!(vel, v, epsilon = 1e-6 * (1.0 + v.abs()));
                let scale = y * y * (x0.abs() + v0.abs() / y);
                assert!((acc + 2.0 * y * v + y * y * x).abs() < 1e-4 * scale, "residual at {t}");
            }
        }
        let y = spring_rate(h);
        let (x, _) = step(1.0, -y, h, h);
        assert_abs_diff_eq!(x, 0.25, epsilon = 1e-12);
    }

    /// §7.6 (d) at the switch instant: the output and its velocity are unchanged by a
    /// transition (exactly), also when an earlier offset is still decaying.
    #[test]
    fn transition_preserves_output_and_velocity() {
        let mut i = Inertializer::new(2, 0.1).unwrap();
        let (xa, va) = ([1.0, -2.0], [0.5, 3.0]);
        i.transition(&xa, &va, &[0.0, 0.0], &[0.0, 0.0]);
        i.update(1.0 / 24.0);
        let (xs, vs) = ([0.3, 0.7], [1.0, -1.0]);
        let out_x: Vec<f64> = xs.iter().zip(i.offset_x()).map(|(a, o)| a + o).collect();
        let out_v: Vec<f64> = vs.iter().zip(i.offset_v()).map(|(a, o)| a + o).collect();
        let (xd, vd) = ([5.0, -4.0], [0.0, 2.0]);
        i.transition(&xs, &vs, &xd, &vd);
        let mut after = [0.0; 2];
        i.apply(&xd, &mut after);
        for c in 0..2 {
            assert_abs_diff_eq!(after[c], out_x[c], epsilon = 1e-15);
            assert_abs_diff_eq!(vd[c] + i.offset_v()[c], out_v[c], epsilon = 1e-15);
        }
        assert!(Inertializer::new(2, -1.0).is_err());
        assert!(Inertializer::new(2, f64::NAN).is_err());
    }
}
