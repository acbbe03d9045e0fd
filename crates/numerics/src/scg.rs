//! Scaled conjugate gradients (Møller 1993), the Netlab `scg.m` variant that the
//! Lawrence-lineage GPLVM code ran (`../shared/method.md` §4.1), minimising any
//! $f:\mathbb R^n\to\mathbb R$ given as one closure that returns the value and writes the
//! gradient.
//!
//! Each iteration estimates the curvature along the search direction $d$ by a one-sided
//! difference of gradients, $\theta = d^\top(\nabla f(x+\sigma d) - \nabla f(x))/\sigma$ with
//! $\sigma = \sigma_0/\lVert d\rVert$, regularises it with a Levenberg–Marquardt scale
//! $\beta$ ($\delta = \theta + \beta\kappa$, $\kappa = d^\top d$; if $\delta\le0$ then
//! $\delta = \beta\kappa$ and $\beta \leftarrow \beta - \theta/\kappa$), steps
//! $\alpha = -\mu/\delta$ ($\mu = d^\top g$), and accepts the step iff the comparison ratio
//! $\Delta = 2(f_{new} - f_{old})/(\alpha\mu)\ge 0$ (i.e. iff $f$ did not increase). Then
//! $\beta$ is multiplied by 4 if $\Delta < 0.25$ and by `beta_decrease` (½) if
//! $\Delta > 0.75$; directions follow Polak–Ribière,
//! $d \leftarrow \tfrac{(g_{old}-g)^\top g}{\mu}d - g$, restarted to $-g$ every $n$
//! accepted steps and whenever $d$ is not a descent direction.
//!
//! Termination ([`Termination`]): Netlab stops when an accepted step has BOTH
//! $\max\lvert\alpha d\rvert <$ `xtol` AND $\lvert f_{new}-f_{old}\rvert <$ `ftol`, or when
//! $g^\top g \le$ `gtol` (Netlab: exactly 0); paramz stops on ANY of the three.
//! [`ScgOptions::paramz`] reproduces paramz's constants. [`Termination::Converged`] uses
//! the problem-level rule of [`crate::optim`] instead (relative decrease over a window AND
//! scaled gradient), the one L-BFGS ([`crate::lbfgs`]) uses too.
//!
//! Because the closure computes value and gradient together, the gradient at an accepted
//! point is the one computed with its value: an iteration costs two evaluations after an
//! accepted step (probe, trial point) and one after a rejected one.
//!
//! Pitfalls handled (method.md §4.4): a non-finite trial value counts as a rejected step
//! ($\Delta = -\infty$, so $\beta$ grows and the step shrinks); a curvature probe whose
//! value or curvature is non-finite is replaced by $\theta = 0$ (a pure $\beta$-scaled
//! gradient step).

use crate::optim::{dot, finish, Convergence, Monitor};
pub use crate::optim::{OptInfo, OptIter, OptResult, StopReason};

/// Which termination rule to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The problem-level [`Convergence`] rule of [`crate::optim`] (window of relative
    /// decrease AND scaled gradient), with [`ScgOptions::convergence`].
    Converged,
    /// Netlab: x-change AND f-change below tolerance (or $g^\top g \le$ `gtol`).
    Netlab,
    /// paramz: x-change OR f-change below tolerance OR $g^\top g \le$ `gtol`.
    Paramz,
}

/// SCG settings; the defaults are Netlab's constants with GPmat's iteration budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScgOptions {
    /// Maximum iterations (default 1000).
    pub max_iters: usize,
    /// Tolerance on $\max_i\lvert\alpha d_i\rvert$ (Netlab `options(2)`, default $10^{-4}$).
    pub xtol: f64,
    /// Tolerance on $\lvert f_{new}-f_{old}\rvert$ (Netlab `options(3)`, default $10^{-4}$).
    pub ftol: f64,
    /// Stop when $g^\top g\le$ `gtol` (the squared norm; default 0, Netlab's exact zero).
    pub gtol: f64,
    /// AND (Netlab) or OR (paramz) of the x and f tests.
    pub termination: Termination,
    /// $\sigma_0$ of the curvature probe (default $10^{-4}$).
    pub sigma0: f64,
    /// Initial $\beta$ (default 1).
    pub beta_init: f64,
    /// Lower bound of $\beta$ (default $10^{-15}$).
    pub beta_min: f64,
    /// Upper bound of $\beta$ (default $10^{100}$).
    pub beta_max: f64,
    /// Factor applied to $\beta$ when $\Delta > 0.75$ (default ½; paramz ¼).
    pub beta_decrease: f64,
    /// Reset $\beta$ to `beta_init` on each restart (paramz; default off).
    pub reset_beta_on_restart: bool,
    /// The rule used with [`Termination::Converged`] (its measures are reported with
    /// every termination).
    pub convergence: Convergence,
}

impl Default for ScgOptions {
    fn default() -> Self {
        Self {
            max_iters: 1000,
            xtol: 1e-4,
            ftol: 1e-4,
            gtol: 0.0,
            termination: Termination::Netlab,
            sigma0: 1e-4,
            beta_init: 1.0,
            beta_min: 1e-15,
            beta_max: 1e100,
            beta_decrease: 0.5,
            reset_beta_on_restart: false,
            convergence: Convergence::default(),
        }
    }
}

impl ScgOptions {
    /// paramz's `scg.py` (the SCG behind GPy's `optimize('scg')`): $\sigma_0 = 10^{-7}$,
    /// $\beta_{max} = 10^{15}$, decrease ¼, tolerances $10^{-6}$, `gtol` $10^{-5}$, OR rule,
    /// $\beta$ reset on restart.
    pub fn paramz() -> Self {
        Self {
            xtol: 1e-6,
            ftol: 1e-6,
            gtol: 1e-5,
            termination: Termination::Paramz,
            sigma0: 1e-7,
            beta_max: 1e15,
            beta_decrease: 0.25,
            reset_beta_on_restart: true,
            ..Self::default()
        }
    }
}

/// SCG's summary (the shared [`OptInfo`]).
pub type ScgInfo = OptInfo;
/// One SCG iteration (the shared [`OptIter`]).
pub type ScgIter = OptIter;
/// SCG's result (the shared [`OptResult`]).
pub type ScgResult = OptResult;

/// Minimises `f` from `x0`. `f(x, g)` returns $f(x)$ and writes $\nabla f(x)$ into `g`.
/// A value of $+\infty$ at a trial point is a rejected step; NaN stops the run
/// ([`StopReason::NonFinite`]).
pub fn scg<F>(mut f: F, x0: &[f64], opts: &ScgOptions) -> ScgResult
where
    F: FnMut(&[f64], &mut [f64]) -> f64,
{
    let clock = std::time::Instant::now();
    let n = x0.len();
    let mut x = x0.to_vec();
    let mut g = vec![0.0; n];
    let mut f_old = f(&x, &mut g);
    let mut evaluations = 1;
    let mut trace = Vec::new();
    if !f_old.is_finite() || g.iter().any(|v| !v.is_finite()) {
        return finish(x, f_old, &g, (0, evaluations), StopReason::NonFiniteStart, Default::default(), trace);
    }
    let mut monitor = Monitor::new(opts.convergence, f_old);
    let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
    let (mut g_old, mut g_plus, mut g_new) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut x_trial = vec![0.0; n];
    let mut success = true;
    let mut nsuccess = 0;
    let mut beta = opts.beta_init;
    let (mut mu, mut kappa, mut theta) = (0.0, 0.0, 0.0);
    for j in 1..=opts.max_iters {
        let stop = |x, f, g: &[f64], reason, m: &Monitor, trace, evals| {
            finish(x, f, g, (j, evals), reason, m.measures(), trace)
        };
        if success {
            mu = dot(&d, &g);
            if mu >= 0.0 {
                d.iter_mut().zip(&g).for_each(|(d, g)| *d = -g);
                mu = dot(&d, &g);
            }
            kappa = dot(&d, &d);
            if kappa < f64::EPSILON {
                return finish(
                    x,
                    f_old,
                    &g,
                    (j - 1, evaluations),
                    StopReason::TinyDirection,
                    monitor.measures(),
                    trace,
                );
            }
            let sigma = opts.sigma0 / kappa.sqrt();
            x_trial.iter_mut().zip(x.iter().zip(&d)).for_each(|(t, (x, d))| *t = x + sigma * d);
            let f_plus = f(&x_trial, &mut g_plus);
            evaluations += 1;
            if f_plus.is_nan() {
                return stop(x, f_old, &g, StopReason::NonFinite, &monitor, trace, evaluations);
            }
            theta = d.iter().zip(g_plus.iter().zip(&g)).map(|(d, (gp, g))| d * (gp - g)).sum::<f64>() / sigma;
            if !f_plus.is_finite() || !theta.is_finite() {
                theta = 0.0;
            }
        }
        let mut delta = theta + beta * kappa;
        if delta <= 0.0 {
            delta = beta * kappa;
            beta -= theta / kappa;
        }
        let alpha = -mu / delta;
        x_trial.iter_mut().zip(x.iter().zip(&d)).for_each(|(t, (x, d))| *t = x + alpha * d);
        let f_new = f(&x_trial, &mut g_new);
        evaluations += 1;
        if f_new.is_nan() || g_new.iter().any(|v| v.is_nan()) {
            return stop(x, f_old, &g, StopReason::NonFinite, &monitor, trace, evaluations);
        }
        let big_delta = if f_new.is_finite() && g_new.iter().all(|v| v.is_finite()) {
            2.0 * (f_new - f_old) / (alpha * mu)
        } else {
            f64::NEG_INFINITY
        };
        success = big_delta >= 0.0;
        if success {
            nsuccess += 1;
            std::mem::swap(&mut x, &mut x_trial);
            let step = d.iter().map(|d| (alpha * d).abs()).fold(0.0, f64::max);
            let x_ok = step < opts.xtol;
            let f_ok = (f_new - f_old).abs() < opts.ftol;
            std::mem::swap(&mut g_old, &mut g);
            std::mem::swap(&mut g, &mut g_new);
            f_old = f_new;
            let converged = monitor.accept(f_old, &x, &g);
            let done = match opts.termination {
                Termination::Netlab => (x_ok && f_ok).then_some(StopReason::Tolerance),
                Termination::Paramz => (x_ok || f_ok).then_some(StopReason::Tolerance),
                Termination::Converged => converged.then_some(StopReason::Converged),
            }
            .or((dot(&g, &g) <= opts.gtol).then_some(StopReason::Gradient));
            if let Some(reason) = done {
                trace.push(iterate(f_old, &g, beta, true, evaluations, &clock));
                return stop(x, f_old, &g, reason, &monitor, trace, evaluations);
            }
        }
        if big_delta < 0.25 {
            beta = (4.0 * beta).min(opts.beta_max);
        }
        if big_delta > 0.75 {
            beta = (opts.beta_decrease * beta).max(opts.beta_min);
        }
        if nsuccess == n {
            d.iter_mut().zip(&g).for_each(|(d, g)| *d = -g);
            nsuccess = 0;
            if opts.reset_beta_on_restart {
                beta = opts.beta_init;
            }
        } else if success {
            let gamma = g_old.iter().zip(&g).map(|(go, g)| (go - g) * g).sum::<f64>() / mu;
            d.iter_mut().zip(&g).for_each(|(d, g)| *d = gamma * *d - g);
        }
        trace.push(iterate(f_old, &g, beta, success, evaluations, &clock));
    }
    let measures = monitor.measures();
    finish(x, f_old, &g, (opts.max_iters, evaluations), StopReason::MaxIterations, measures, trace)
}

/// One trace entry.
pub(crate) fn iterate(
    value: f64,
    g: &[f64],
    beta: f64,
    accepted: bool,
    evaluations: usize,
    clock: &std::time::Instant,
) -> OptIter {
    OptIter { value, grad_norm: dot(g, g).sqrt(), beta, accepted, evaluations, seconds: clock.elapsed().as_secs_f64() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rosenbrock(x: &[f64], g: &mut [f64]) -> f64 {
        let (a, b) = (x[0], x[1]);
        g[0] = -400.0 * a * (b - a * a) - 2.0 * (1.0 - a);
        g[1] = 200.0 * (b - a * a);
        100.0 * (b - a * a).powi(2) + (1.0 - a).powi(2)
    }

    /// The quadratic oracle of method.md §4.5: ½xᵀAx − bᵀx with A = diag(1, 10, 100),
    /// b = 1, from 0, converges to A⁻¹b = (1, 0.1, 0.01); the accepted values never rise.
    #[test]
    fn quadratic_converges_to_solution() {
        let a = [1.0, 10.0, 100.0];
        let f = |x: &[f64], g: &mut [f64]| {
            for i in 0..3 {
                g[i] = a[i] * x[i] - 1.0;
            }
            (0..3).map(|i| 0.5 * a[i] * x[i] * x[i] - x[i]).sum::<f64>()
        };
        let opts = ScgOptions { xtol: 1e-10, ftol: 1e-14, ..Default::default() };
        let r = scg(f, &[0.0; 3], &opts);
        eprintln!("quadratic: {:?} at {:?}", r.info, r.x);
        assert!(r.info.converged, "{:?}", r.info);
        for (x, want) in r.x.iter().zip([1.0, 0.1, 0.01]) {
            assert!((x - want).abs() < 1e-8, "{:?}", r.x);
        }
        assert!(r.info.iterations < 100, "{:?}", r.info);
        assert!(r.trace.windows(2).all(|w| w[1].value <= w[0].value));
        assert_eq!(r.trace.len(), r.info.iterations);
    }

    /// Rosenbrock from (−1.2, 1) (method.md §4.5): Netlab tolerances 1e-4 land within
    /// 1e-2 of (1, 1), tolerances 1e-8 within 1e-5; the paramz rule also converges.
    #[test]
    fn rosenbrock_converges() {
        for (tol, reach) in [(1e-4, 1e-2), (1e-8, 1e-5)] {
            let opts = ScgOptions { xtol: tol, ftol: tol, ..Default::default() };
            let r = scg(rosenbrock, &[-1.2, 1.0], &opts);
            eprintln!("rosenbrock tol {tol:e}: {:?} at {:?}", r.info, r.x);
            assert!(r.info.converged && r.info.reason == StopReason::Tolerance, "{:?}", r.info);
            assert!((r.x[0] - 1.0).abs() < reach && (r.x[1] - 1.0).abs() < reach, "tol {tol}: {:?}", r.x);
            assert!(r.trace.windows(2).all(|w| w[1].value <= w[0].value));
        }
        let opts = ScgOptions { max_iters: 5000, gtol: 1e-16, xtol: 0.0, ftol: 0.0, ..ScgOptions::paramz() };
        let r = scg(rosenbrock, &[-1.2, 1.0], &opts);
        eprintln!("rosenbrock paramz rule: {:?} at {:?}", r.info, r.x);
        assert!(r.info.converged, "{:?}", r.info);
        assert!((r.x[0] - 1.0).abs() < 1e-6 && (r.x[1] - 1.0).abs() < 1e-6, "{:?}", r.x);
    }

    /// The window rule of crate::optim stops SCG on Rosenbrock close to (1, 1), for the
    /// right reason.
    #[test]
    fn convergence_rule_stops_rosenbrock() {
        let convergence = Convergence { window: 3, ftol: 1e-8, gtol: 1e-5, f_typical: 1.0 };
        let opts = ScgOptions { termination: Termination::Converged, convergence, ..Default::default() };
        let r = scg(rosenbrock, &[-1.2, 1.0], &opts);
        eprintln!("rosenbrock, window rule: {:?} at {:?}", r.info, r.x);
        assert_eq!(r.info.reason, StopReason::Converged);
        assert!(r.info.measures.rel_gradient <= 1e-5 && r.info.measures.rel_decrease <= 1e-8);
        assert!((r.x[0] - 1.0).abs() < 1e-4 && (r.x[1] - 1.0).abs() < 1e-4, "{:?}", r.x);
    }

    /// The iteration cap is reported as not converged; a NaN start stops at once; a
    /// region where f is +∞ is treated as rejected steps, not accepted.
    #[test]
    fn stops_and_failures_are_reported() {
        let r = scg(rosenbrock, &[-1.2, 1.0], &ScgOptions { max_iters: 3, ..Default::default() });
        assert_eq!((r.info.reason, r.info.converged, r.info.iterations), (StopReason::MaxIterations, false, 3));
        let r = scg(
            |_, g| {
                g.fill(0.0);
                f64::NAN
            },
            &[0.0],
            &ScgOptions::default(),
        );
        assert_eq!(r.info.reason, StopReason::NonFiniteStart);
        // NaN after the start stops the run as NonFinite (not a rejected step).
        let nan_beyond = |x: &[f64], g: &mut [f64]| {
            g[0] = 2.0 * (x[0] - 3.0);
            if x[0] < 2.0 {
                (x[0] - 3.0).powi(2)
            } else {
                f64::NAN
            }
        };
        let r = scg(nan_beyond, &[0.0], &ScgOptions { max_iters: 200, ..Default::default() });
        assert_eq!((r.info.reason, r.info.converged), (StopReason::NonFinite, false));
        // f(x) = (x − 3)² for x < 2, +∞ beyond: the minimiser within the domain is 2⁻.
        let wall = |x: &[f64], g: &mut [f64]| {
            g[0] = 2.0 * (x[0] - 3.0);
            if x[0] < 2.0 {
                (x[0] - 3.0).powi(2)
            } else {
                f64::INFINITY
            }
        };
        let r = scg(wall, &[0.0], &ScgOptions { max_iters: 200, ..Default::default() });
        assert!(r.x[0] < 2.0 && r.x[0] > 1.9, "{:?} {:?}", r.x, r.info);
        assert!(r.trace.iter().any(|t| !t.accepted));
    }
}
