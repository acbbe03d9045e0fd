//! The smooth random force of §5.1: each of the $q$ components an independent draw from
//! $\mathcal{GP}(0, k)$ with $k(t,t') = \alpha\exp(-(t-t')^2/(2\gamma))$.
//!
//! Sampled online by random Fourier features (Rahimi & Recht 2007): with
//! $\omega_m\sim\mathcal N(0, 1/\gamma)$, $\phi_m\sim U[0, 2\pi)$, $a_m\sim\mathcal N(0,1)$,
//!
//! $$f(t) = \sqrt{2\alpha/M}\,\sum_{m=1}^M a_m\cos(\omega_m t + \phi_m),$$
//!
//! whose covariance is $\mathbb E[f(t)f(t')] = \alpha\,\mathbb E_\omega[\cos\omega(t-t')] =
//! k(t,t')$ exactly in expectation over the features, with a Monte-Carlo error
//! $O(1/\sqrt M)$ for one draw of them; given the features, $f$ is Gaussian. It is a
//! deterministic, smooth function of $t$, so every RK4 stage of a step sees the same
//! force, it costs $O(qM)$ per evaluation, needs no history, and any time can be queried
//! (a script can be any length).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One draw of the random force.
#[derive(Debug, Clone, PartialEq)]
pub struct RandomForce {
    q: usize,
    scale: f64,
    omega: Vec<f64>,
    phase: Vec<f64>,
    amp: Vec<f64>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    // Box–Muller; u1 in (0, 1].
    let u1: f64 = 1.0 - rng.gen::<f64>();
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

impl RandomForce {
    /// A draw with variance `alpha`, squared time scale `gamma` (s²), `features` Fourier
    /// features per component, for `q` components, from `seed`.
    pub fn new(q: usize, alpha: f64, gamma: f64, features: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = q * features;
        let sd = 1.0 / gamma.sqrt();
        let omega = (0..n).map(|_| sd * normal(&mut rng)).collect();
        let phase = (0..n).map(|_| rng.gen::<f64>() * 2.0 * std::f64::consts::PI).collect();
        let amp = (0..n).map(|_| normal(&mut rng)).collect();
        let scale = if features == 0 { 0.0 } else { (2.0 * alpha / features as f64).sqrt() };
        Self { q, scale, omega, phase, amp }
    }

    /// No force at all.
    pub fn zero(q: usize) -> Self {
        Self { q, scale: 0.0, omega: vec![], phase: vec![], amp: vec![] }
    }

    /// $f(t)$ into `out` (length $q$).
    pub fn at(&self, t: f64, out: &mut [f64]) {
        out.fill(0.0);
        if self.scale == 0.0 {
            return;
        }
        let m = self.omega.len() / self.q;
        for (k, o) in out.iter_mut().enumerate() {
            let r = k * m..(k + 1) * m;
            let s: f64 = self.omega[r.clone()]
                .iter()
                .zip(&self.phase[r.clone()])
                .zip(&self.amp[r])
                .map(|((w, p), a)| a * (w * t + p).cos())
                .sum();
            *o = self.scale * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over many draws, the empirical covariance at lags 0, √γ and 2√γ matches
    /// α·exp(−τ²/(2γ)); the same seed gives the same force.
    #[test]
    fn covariance_matches_the_kernel() {
        let (alpha, gamma): (f64, f64) = (0.7, 0.04);
        let lags = [0.0, gamma.sqrt(), 2.0 * gamma.sqrt()];
        let draws = 4000;
        let mut acc = [0.0; 3];
        let (mut a, mut b) = ([0.0], [0.0]);
        for s in 0..draws {
            let f = RandomForce::new(1, alpha, gamma, 32, s);
            f.at(1.3, &mut a);
            for (i, lag) in lags.iter().enumerate() {
                f.at(1.3 + lag, &mut b);
                acc[i] += a[0] * b[0];
            }
        }
        for (i, lag) in lags.iter().enumerate() {
            let want = alpha * (-lag * lag / (2.0 * gamma)).exp();
            let got = acc[i] / draws as f64;
            assert!((got - want).abs() < 0.06 * alpha, "lag {lag}: {got} vs {want}");
        }
        let (f, g) = (RandomForce::new(2, 1.0, 0.1, 8, 3), RandomForce::new(2, 1.0, 0.1, 8, 3));
        let (mut x, mut y) = ([0.0; 2], [0.0; 2]);
        f.at(0.4, &mut x);
        g.at(0.4, &mut y);
        assert_eq!(x, y);
    }
}
