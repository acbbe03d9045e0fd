//! The path-following particle of §5.1: a unit-mass particle in a latent space,
//! $\ddot x = F(x, t) + \lambda g$, $g = x - p(t)$, kept within radius $r$ of the path by
//! the inequality $C = g^\top g - r^2 \le 0$, stabilised with Baumgarte's method.
//!
//! **Corrected sign** (`../shared/method.md` §6): Baumgarte's law
//! $\ddot C + 2\alpha\dot C + \beta^2C = 0$ gives
//!
//! $$\lambda = -\frac{g^\top F - g^\top\ddot p + G}{g^\top g},\qquad
//! G = \lVert\dot x-\dot p\rVert^2 + 2\alpha\,g^\top(\dot x-\dot p) + \tfrac12\beta^2(g^\top g - r^2),$$
//!
//! clamped to $\lambda \le 0$ (the force only pulls toward $p$), with $\alpha = \zeta\omega_0$,
//! $\beta = \omega_0$ (critical damping at $\zeta = 1$). The paper prints
//! $\lambda = (-g^\top F + G)/g^\top g$ with $\beta = \alpha^2$; its clamp then zeroes the
//! constraint exactly when it should act. [`ConstraintSign::SeedLiteral`] reproduces the
//! printed equations for comparison.
//!
//! **Guards** (a deviation, method.md §6.3): $\nabla C = 2g$ vanishes at the path point, and
//! a particle passing close to it would get an unbounded force. $\lambda = 0$ whenever
//! $\lVert g\rVert < \varepsilon r$, and deep inside the disc, $C < -\eta r^2$ (default
//! $\eta = 0.5$: within $r/\sqrt2$), where the inequality is comfortably satisfied and the
//! conservative Baumgarte law would otherwise still act on a fast particle.
//!
//! **Integration**: classical RK4 over one frame interval, in equal steps (`substeps`, or
//! more so that $\omega_0 h \le 1/2$ and the particle moves at most $r/2$ relative to the
//! path per step, up to [`MAX_SUBSTEPS`]), with
//! $p(t)$ linear inside the interval (so $\ddot p = 0$) — never across frames, where
//! $\dot p$ jumps.

/// The most RK4 steps one frame takes (the travel rule's cap).
pub const MAX_SUBSTEPS: usize = 256;

/// Which multiplier formula to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConstraintSign {
    /// method.md §6.1: the Baumgarte-stabilised inequality with $\beta = \omega_0$.
    Corrected,
    /// The paper's Eq. 9 as printed, with $\beta = \alpha^2$.
    SeedLiteral,
}

/// Constraint and integration settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParticleParams {
    /// $\omega_0$ (s⁻¹), how fast a violated constraint is restored (default 8).
    pub omega0: f64,
    /// Damping ratio $\zeta$ (default 1, critical).
    pub zeta: f64,
    /// Multiplier formula (default corrected).
    pub sign: ConstraintSign,
    /// RK4 steps per frame, at least (default 2); more when $\omega_0\Delta t > 1/2$, so
    /// that every step has $\omega_0 h \le 1/2$ (accurate; RK4 is stable to 2.78).
    pub substeps: usize,
    /// Guard: no constraint force within $\varepsilon r$ of the path point (default $10^{-3}$).
    pub guard: f64,
    /// Guard: no constraint force where $C < -\eta r^2$ (default 0.5; 1 disables).
    pub inner: f64,
}

impl Default for ParticleParams {
    fn default() -> Self {
        Self { omega0: 8.0, zeta: 1.0, sign: ConstraintSign::Corrected, substeps: 2, guard: 1e-3, inner: 0.5 }
    }
}

/// Position and velocity.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// $x$.
    pub x: Vec<f64>,
    /// $\dot x$.
    pub v: Vec<f64>,
}

impl State {
    /// At rest at `x`.
    pub fn at_rest(x: &[f64]) -> Self {
        Self { x: x.to_vec(), v: vec![0.0; x.len()] }
    }
}

/// The multiplier $\lambda$ (after the clamp and the guard).
pub fn multiplier(params: &ParticleParams, g: &[f64], rel_v: &[f64], force: &[f64], r: f64) -> f64 {
    let gg: f64 = g.iter().map(|v| v * v).sum();
    if gg.sqrt() < params.guard * r || gg - r * r < -params.inner * r * r {
        return 0.0;
    }
    let gf: f64 = g.iter().zip(force).map(|(a, b)| a * b).sum();
    let gv: f64 = g.iter().zip(rel_v).map(|(a, b)| a * b).sum();
    let vv: f64 = rel_v.iter().map(|v| v * v).sum();
    let alpha = params.zeta * params.omega0;
    let lambda = match params.sign {
        ConstraintSign::Corrected => {
            let beta = params.omega0;
            -(gf + vv + 2.0 * alpha * gv + 0.5 * beta * beta * (gg - r * r)) / gg
        }
        ConstraintSign::SeedLiteral => {
            let beta = alpha * alpha;
            (-gf + vv + 2.0 * alpha * gv + 0.5 * beta * beta * (gg - r * r)) / gg
        }
    };
    if lambda > 0.0 || !lambda.is_finite() {
        0.0
    } else {
        lambda
    }
}

/// One frame of the path: from `from` at `t0` linearly to `to` at `t0 + dt`, radius `radius`.
#[derive(Debug, Clone, Copy)]
pub struct Leg<'a> {
    /// Start time (s).
    pub t0: f64,
    /// Frame length (s).
    pub dt: f64,
    /// Path point at `t0`.
    pub from: &'a [f64],
    /// Path point at `t0 + dt`.
    pub to: &'a [f64],
    /// Radius $r$.
    pub radius: f64,
}

/// Advances `state` over one frame `leg` under the external force `force(x, v, t, out)`.
pub fn step_frame(
    params: &ParticleParams,
    state: &mut State,
    leg: Leg<'_>,
    force: &mut impl FnMut(&[f64], &[f64], f64, &mut [f64]),
) {
    let Leg { t0, dt, from: p0, to: p1, radius: r } = leg;
    let q = state.x.len();
    let pdot: Vec<f64> = p0.iter().zip(p1).map(|(a, b)| (b - a) / dt).collect();
    // Steps so that ω₀h ≤ 1/2 and the particle moves at most r/2 relative to the path in
    // one step: the multiplier grows like ‖ẋ − ṗ‖²/r², and a path point that outruns a
    // small disc (a PLAY through fast training frames) would otherwise make RK4 unstable.
    let rel: f64 = state.v.iter().zip(&pdot).map(|(v, p)| (v - p) * (v - p)).sum::<f64>().sqrt();
    let speed = pdot.iter().map(|p| p * p).sum::<f64>().sqrt() + rel;
    let by_travel = if r > 0.0 { (2.0 * speed * dt / r).ceil().min(MAX_SUBSTEPS as f64) as usize } else { 1 };
    let steps = params.substeps.max(1).max((2.0 * params.omega0 * dt).ceil() as usize).max(by_travel);
    let h = dt / steps as f64;
    let mut f = vec![0.0; q];
    let (mut g, mut rel) = (vec![0.0; q], vec![0.0; q]);
    // The acceleration at (x, v, t): F + λ g.
    let mut accel = |x: &[f64], v: &[f64], t: f64, out: &mut [f64]| {
        force(x, v, t, &mut f);
        let s = t - t0;
        for k in 0..q {
            g[k] = x[k] - (p0[k] + pdot[k] * s);
            rel[k] = v[k] - pdot[k];
        }
        let lambda = multiplier(params, &g, &rel, &f, r);
        for k in 0..q {
            out[k] = f[k] + lambda * g[k];
        }
    };
    let mut k = [vec![0.0; q], vec![0.0; q], vec![0.0; q], vec![0.0; q]];
    let (mut xs, mut vs) = (vec![0.0; q], vec![0.0; q]);
    for sub in 0..steps {
        let t = t0 + sub as f64 * h;
        let (x, v) = (state.x.clone(), state.v.clone());
        // RK4 on (x, v): k_x = v, k_v = a(x, v, t).
        accel(&x, &v, t, &mut k[0]);
        let v1 = v.clone();
        for i in 0..q {
            xs[i] = x[i] + 0.5 * h * v1[i];
            vs[i] = v[i] + 0.5 * h * k[0][i];
        }
        let v2 = vs.clone();
        accel(&xs.clone(), &v2, t + 0.5 * h, &mut k[1]);
        for i in 0..q {
            xs[i] = x[i] + 0.5 * h * v2[i];
            vs[i] = v[i] + 0.5 * h * k[1][i];
        }
        let v3 = vs.clone();
        accel(&xs.clone(), &v3, t + 0.5 * h, &mut k[2]);
        for i in 0..q {
            xs[i] = x[i] + h * v3[i];
            vs[i] = v[i] + h * k[2][i];
        }
        let v4 = vs.clone();
        accel(&xs.clone(), &v4, t + h, &mut k[3]);
        for i in 0..q {
            state.x[i] = x[i] + h / 6.0 * (v1[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
            state.v[i] = v[i] + h / 6.0 * (k[0][i] + 2.0 * k[1][i] + 2.0 * k[2][i] + k[3][i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(s: &State) -> f64 {
        s.x.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    fn run(params: &ParticleParams, start: State, seconds: f64, dt: f64, r: f64) -> (State, Vec<f64>) {
        let mut s = start;
        let mut ds = vec![];
        let zero = [0.0, 0.0];
        let mut none = |_: &[f64], _: &[f64], _: f64, o: &mut [f64]| o.fill(0.0);
        for i in 0..(seconds / dt).round() as usize {
            step_frame(params, &mut s, Leg { t0: i as f64 * dt, dt, from: &zero, to: &zero, radius: r }, &mut none);
            ds.push(dist(&s));
        }
        (s, ds)
    }

    /// method.md §6.4 (a): at rest inside the disc with no force, nothing moves.
    #[test]
    fn inactive_inside_the_disc() {
        let p = ParticleParams::default();
        let (s, _) = run(&p, State::at_rest(&[0.2, 0.1]), 1.0, 1.0 / 24.0, 0.5);
        assert_eq!(s.x, vec![0.2, 0.1]);
    }

    /// method.md §6.4 (b): released at distance 2 (r = 0.5, α = β = 4), C(t) follows the
    /// critically damped law C₀(1 + αt)e^{−αt} while λ < 0 (to t ≈ 0.337 s).
    #[test]
    fn active_constraint_is_critically_damped() {
        let p = ParticleParams { omega0: 4.0, substeps: 1, ..Default::default() };
        let (r, dt) = (0.5, 1e-4);
        let (_, ds) = run(&p, State::at_rest(&[2.0, 0.0]), 0.3, dt, r);
        let c0 = 4.0 - r * r;
        for (i, d) in ds.iter().enumerate().step_by(100) {
            let t = (i + 1) as f64 * dt;
            let want = c0 * (1.0 + 4.0 * t) * (-4.0 * t).exp();
            assert!((d * d - r * r - want).abs() < 1e-9, "t = {t}: {} vs {want}", d * d - r * r);
        }
    }

    /// method.md §6.4 (c): with a small tangential velocity, the corrected sign brings the
    /// particle inside r within 2 s, and the printed sign leaves it outside (the oracle's
    /// set-up: no inner guard).
    #[test]
    fn printed_sign_never_pulls() {
        let start = State { x: vec![2.0, 0.0], v: vec![0.0, 0.1] };
        let corrected = ParticleParams { omega0: 4.0, inner: 1.0, ..Default::default() };
        let literal = ParticleParams { sign: ConstraintSign::SeedLiteral, ..corrected };
        let (a, _) = run(&corrected, start.clone(), 2.0, 1.0 / 240.0, 0.5);
        let (b, _) = run(&literal, start, 2.0, 1.0 / 240.0, 0.5);
        assert!(dist(&a) < 0.5, "corrected ends at {}", dist(&a));
        assert!(dist(&b) > 1.9, "literal ends at {}", dist(&b));
    }

    /// A particle shot straight through the path point stays finite (the guard).
    #[test]
    fn no_nan_through_the_path_point() {
        let p = ParticleParams::default();
        let start = State { x: vec![-0.3, 0.0], v: vec![3.0, 0.0] };
        let (s, ds) = run(&p, start, 2.0, 1.0 / 24.0, 0.5);
        assert!(ds.iter().all(|d| d.is_finite()) && s.v.iter().all(|v| v.is_finite()));
        assert!(dist(&s) < 0.6, "{}", dist(&s));
    }
}
