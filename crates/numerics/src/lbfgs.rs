//! Limited-memory BFGS (Nocedal & Wright, *Numerical Optimization*, 2nd ed., Alg. 7.4
//! and 7.5) with a strong-Wolfe line search (their Alg. 3.5–3.6), minimising
//! $f:\mathbb R^n\to\mathbb R$ given as one closure that returns the value and writes the
//! gradient — the same shape as [`crate::scg::scg`], and the same convergence rule
//! ([`crate::optim::Convergence`]).
//!
//! - **Direction**: the two-loop recursion over the last `memory` pairs
//!   $s_k = x_{k+1}-x_k$, $y_k = g_{k+1}-g_k$, with the initial inverse Hessian
//!   $\gamma I$, $\gamma = s^\top y / y^\top y$ of the newest pair. A pair with
//!   $s^\top y \le 10^{-10}\lVert s\rVert\lVert y\rVert$ is not stored (the update would
//!   not stay positive definite). A direction that is not a descent direction empties the
//!   memory and restarts along $-g$.
//! - **Line search**: initial step 1 (the quasi-Newton step), or $1/\lVert g\rVert_2$ along
//!   $-g$ after a (re)start; expansion by 2 until the minimum is bracketed, then zoom by
//!   safeguarded cubic interpolation, until the strong Wolfe conditions
//!   $\phi(\alpha)\le\phi(0)+c_1\alpha\phi'(0)$ and $\lvert\phi'(\alpha)\rvert\le c_2\lvert\phi'(0)\rvert$
//!   hold. A value of $+\infty$ (e.g. an indefinite kernel matrix) counts as "too far";
//!   NaN stops the run ([`StopReason::NonFinite`]). If the budget of evaluations runs
//!   out, the best point with sufficient decrease is taken; if there is none, the memory
//!   is emptied and the search repeated along $-g$, and a second failure is
//!   [`StopReason::Stalled`].
//! - Usually one evaluation per iteration (SCG needs two: its curvature probe and the
//!   step).

use std::collections::VecDeque;

use crate::optim::{dot, finish, Convergence, Monitor, OptResult, StopReason};
use crate::scg::iterate;

/// L-BFGS settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbfgsOptions {
    /// Pairs kept (default 10).
    pub memory: usize,
    /// Iteration cap, a safety net (default 10 000).
    pub max_iters: usize,
    /// The convergence rule.
    pub convergence: Convergence,
    /// Sufficient-decrease constant $c_1$ (default $10^{-4}$).
    pub c1: f64,
    /// Curvature constant $c_2$ (default 0.9).
    pub c2: f64,
    /// Evaluations per line search (default 20).
    pub max_line_search: usize,
}

impl Default for LbfgsOptions {
    fn default() -> Self {
        Self {
            memory: 10,
            max_iters: 10_000,
            convergence: Convergence::default(),
            c1: 1e-4,
            c2: 0.9,
            max_line_search: 20,
        }
    }
}

/// A point of the line search: step, value, slope, and the point with its gradient.
#[derive(Debug, Clone)]
struct Probe {
    alpha: f64,
    f: f64,
    slope: f64,
    x: Vec<f64>,
    g: Vec<f64>,
}

enum Search {
    /// Strong Wolfe met, or the best sufficient-decrease point when the budget ran out.
    Found(Probe),
    /// No point with sufficient decrease.
    Failed,
    /// NaN.
    NaN,
}

/// The minimiser of the cubic through $(a,f_a,f'_a)$, $(b,f_b,f'_b)$ (N&W Eq. 3.59),
/// kept inside the middle 80 % of the interval; bisection when the cubic has none.
fn cubic_step(a: &Probe, b: &Probe) -> f64 {
    let (lo, hi) = (a.alpha.min(b.alpha), a.alpha.max(b.alpha));
    let mid = 0.5 * (lo + hi);
    if !b.f.is_finite() {
        return mid;
    }
    let d1 = a.slope + b.slope - 3.0 * (a.f - b.f) / (a.alpha - b.alpha);
    let disc = d1 * d1 - a.slope * b.slope;
    if disc.is_nan() || disc < 0.0 {
        return mid;
    }
    let d2 = (b.alpha - a.alpha).signum() * disc.sqrt();
    let t = b.alpha - (b.alpha - a.alpha) * (b.slope + d2 - d1) / (b.slope - a.slope + 2.0 * d2);
    let margin = 0.1 * (hi - lo);
    if t.is_finite() {
        t.clamp(lo + margin, hi - margin)
    } else {
        mid
    }
}

/// Strong-Wolfe search along `d` from `x` (value `f0`, slope `slope0 < 0`).
#[allow(clippy::too_many_arguments)]
fn line_search<F>(
    f: &mut F,
    x: &[f64],
    f0: f64,
    slope0: f64,
    d: &[f64],
    alpha0: f64,
    opts: &LbfgsOptions,
    evaluations: &mut usize,
) -> Search
where
    F: FnMut(&[f64], &mut [f64]) -> f64,
{
    let n = x.len();
    let mut eval = |alpha: f64| -> Probe {
        let xt: Vec<f64> = x.iter().zip(d).map(|(x, d)| x + alpha * d).collect();
        let mut g = vec![0.0; n];
        let fv = f(&xt, &mut g);
        *evaluations += 1;
        let finite = fv.is_finite() && g.iter().all(|v| v.is_finite());
        let (fv, slope) = if finite {
            (fv, dot(&g, d))
        } else if fv.is_nan() || (fv.is_finite() && g.iter().any(|v| v.is_nan())) {
            (f64::NAN, f64::NAN)
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        Probe { alpha, f: fv, slope, x: xt, g }
    };
    let armijo = |p: &Probe| p.f <= f0 + opts.c1 * p.alpha * slope0;
    let wolfe = |p: &Probe| p.slope.abs() <= -opts.c2 * slope0;
    let mut best: Option<Probe> = None;
    let keep = |p: &Probe, best: &mut Option<Probe>| {
        if armijo(p) && p.f < f0 && best.as_ref().is_none_or(|b| p.f < b.f) {
            *best = Some(p.clone());
        }
    };
    let origin = Probe { alpha: 0.0, f: f0, slope: slope0, x: x.to_vec(), g: vec![] };
    let (mut lo, mut hi);
    let mut prev = origin;
    let mut alpha = alpha0;
    let mut used = 0;
    // Bracketing.
    loop {
        if used == opts.max_line_search {
            return best.map_or(Search::Failed, Search::Found);
        }
        let p = eval(alpha);
        used += 1;
        if p.f.is_nan() {
            return Search::NaN;
        }
        keep(&p, &mut best);
        if !armijo(&p) || (used > 1 && p.f >= prev.f) {
            (lo, hi) = (prev, p);
            break;
        }
        if wolfe(&p) {
            return Search::Found(p);
        }
        if p.slope >= 0.0 {
            (lo, hi) = (p, prev);
            break;
        }
        alpha = 2.0 * p.alpha;
        prev = p;
    }
    // Zoom: lo satisfies sufficient decrease and has the lowest value seen in the bracket.
    while used < opts.max_line_search {
        let a = cubic_step(&lo, &hi);
        let p = eval(a);
        used += 1;
        if p.f.is_nan() {
            return Search::NaN;
        }
        keep(&p, &mut best);
        if !armijo(&p) || p.f >= lo.f {
            hi = p;
        } else {
            if wolfe(&p) {
                return Search::Found(p);
            }
            if p.slope * (hi.alpha - lo.alpha) >= 0.0 {
                hi = lo;
            }
            lo = p;
        }
        if (hi.alpha - lo.alpha).abs() <= 1e-16 * lo.alpha.abs().max(1e-300) {
            break;
        }
    }
    best.map_or(Search::Failed, Search::Found)
}

/// The two-loop recursion: $d = -H g$.
fn direction(g: &[f64], pairs: &VecDeque<(Vec<f64>, Vec<f64>, f64)>) -> Vec<f64> {
    let mut q: Vec<f64> = g.to_vec();
    let mut alphas = Vec::with_capacity(pairs.len());
    for (s, y, rho) in pairs.iter().rev() {
        let a = rho * dot(s, &q);
        q.iter_mut().zip(y).for_each(|(q, y)| *q -= a * y);
        alphas.push(a);
    }
    if let Some((s, y, _)) = pairs.back() {
        let gamma = dot(s, y) / dot(y, y);
        q.iter_mut().for_each(|v| *v *= gamma);
    }
    for ((s, y, rho), a) in pairs.iter().zip(alphas.iter().rev()) {
        let b = rho * dot(y, &q);
        q.iter_mut().zip(s).for_each(|(q, s)| *q += (a - b) * s);
    }
    q.iter_mut().for_each(|v| *v = -*v);
    q
}

/// Minimises `f` from `x0`. `f(x, g)` returns $f(x)$ and writes $\nabla f(x)$ into `g`.
pub fn lbfgs<F>(mut f: F, x0: &[f64], opts: &LbfgsOptions) -> OptResult
where
    F: FnMut(&[f64], &mut [f64]) -> f64,
{
    let clock = std::time::Instant::now();
    let mut x = x0.to_vec();
    let mut g = vec![0.0; x.len()];
    let mut fx = f(&x, &mut g);
    let mut evaluations = 1;
    let mut trace = Vec::new();
    if !fx.is_finite() || g.iter().any(|v| !v.is_finite()) {
        return finish(x, fx, &g, (0, evaluations), StopReason::NonFiniteStart, Default::default(), trace);
    }
    let mut monitor = Monitor::new(opts.convergence, fx);
    let mut pairs: VecDeque<(Vec<f64>, Vec<f64>, f64)> = VecDeque::with_capacity(opts.memory);
    for k in 1..=opts.max_iters {
        let stop = |x, fx, g: &[f64], reason, m: &Monitor, trace, evals| {
            finish(x, fx, g, (k, evals), reason, m.measures(), trace)
        };
        let found = loop {
            let mut d = direction(&g, &pairs);
            let mut slope = dot(&g, &d);
            if slope.is_nan() || slope >= 0.0 {
                pairs.clear();
                d = g.iter().map(|v| -v).collect();
                slope = dot(&g, &d);
            }
            if slope == 0.0 {
                return stop(x, fx, &g, StopReason::TinyDirection, &monitor, trace, evaluations);
            }
            let alpha0 = if pairs.is_empty() { 1.0 / dot(&g, &g).sqrt() } else { 1.0 };
            match line_search(&mut f, &x, fx, slope, &d, alpha0, opts, &mut evaluations) {
                Search::Found(p) => break p,
                Search::NaN => return stop(x, fx, &g, StopReason::NonFinite, &monitor, trace, evaluations),
                Search::Failed if pairs.is_empty() => {
                    return stop(x, fx, &g, StopReason::Stalled, &monitor, trace, evaluations)
                }
                Search::Failed => pairs.clear(),
            }
        };
        let s: Vec<f64> = found.x.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = found.g.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-10 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
            if pairs.len() == opts.memory.max(1) {
                pairs.pop_front();
            }
            pairs.push_back((s, y, 1.0 / sy));
        }
        (x, g, fx) = (found.x, found.g, found.f);
        let converged = monitor.accept(fx, &x, &g);
        trace.push(iterate(fx, &g, found.alpha, true, evaluations, &clock));
        if converged {
            return stop(x, fx, &g, StopReason::Converged, &monitor, trace, evaluations);
        }
    }
    let measures = monitor.measures();
    finish(x, fx, &g, (opts.max_iters, evaluations), StopReason::MaxIterations, measures, trace)
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

    fn tight() -> LbfgsOptions {
        LbfgsOptions {
            convergence: Convergence { window: 3, ftol: 1e-14, gtol: 1e-10, f_typical: 1.0 },
            ..Default::default()
        }
    }

    /// ½xᵀAx − bᵀx with A = diag(1, 10, 100), b = 1 (method.md §4.5's oracle): the
    /// solution A⁻¹b, values never rising, about one evaluation per iteration.
    #[test]
    fn quadratic_converges_to_solution() {
        let a = [1.0, 10.0, 100.0];
        let f = |x: &[f64], g: &mut [f64]| {
            (0..3).for_each(|i| g[i] = a[i] * x[i] - 1.0);
            (0..3).map(|i| 0.5 * a[i] * x[i] * x[i] - x[i]).sum::<f64>()
        };
        let r = lbfgs(f, &[0.0; 3], &tight());
        eprintln!("quadratic: {:?} at {:?}", r.info, r.x);
        assert_eq!(r.info.reason, StopReason::Converged);
        for (x, want) in r.x.iter().zip([1.0, 0.1, 0.01]) {
            assert!((x - want).abs() < 1e-8, "{:?}", r.x);
        }
        assert!(r.trace.windows(2).all(|w| w[1].value <= w[0].value));
        assert!(r.info.evaluations < 3 * r.info.iterations + 5, "{:?}", r.info);
    }

    /// Rosenbrock from (−1.2, 1) reaches (1, 1) to 1e-6 and stops for convergence.
    #[test]
    fn rosenbrock_converges() {
        let r = lbfgs(rosenbrock, &[-1.2, 1.0], &tight());
        eprintln!("rosenbrock: {:?} at {:?}", r.info, r.x);
        assert_eq!(r.info.reason, StopReason::Converged);
        assert!((r.x[0] - 1.0).abs() < 1e-6 && (r.x[1] - 1.0).abs() < 1e-6, "{:?}", r.x);
        assert!(r.trace.windows(2).all(|w| w[1].value <= w[0].value));
        // A 20-dimensional chained Rosenbrock, where memory matters.
        let chained = |x: &[f64], g: &mut [f64]| {
            g.fill(0.0);
            let mut v = 0.0;
            for i in 0..x.len() - 1 {
                let t = x[i + 1] - x[i] * x[i];
                v += 100.0 * t * t + (1.0 - x[i]).powi(2);
                g[i] += -400.0 * x[i] * t - 2.0 * (1.0 - x[i]);
                g[i + 1] += 200.0 * t;
            }
            v
        };
        let x0: Vec<f64> = (0..20).map(|i| if i % 2 == 0 { -1.2 } else { 1.0 }).collect();
        let r = lbfgs(chained, &x0, &tight());
        assert_eq!(r.info.reason, StopReason::Converged, "{:?}", r.info);
        assert!(r.x.iter().all(|v| (v - 1.0).abs() < 1e-5), "{:?}", r.x);
    }

    /// The cap is not converged; +∞ beyond a wall is "too far" (the search stays inside);
    /// NaN stops the run; a function with no descent possible stalls or stops, never
    /// claims convergence.
    #[test]
    fn stops_and_failures_are_reported() {
        let r = lbfgs(rosenbrock, &[-1.2, 1.0], &LbfgsOptions { max_iters: 3, ..tight() });
        assert_eq!((r.info.reason, r.info.converged, r.info.iterations), (StopReason::MaxIterations, false, 3));
        let wall = |x: &[f64], g: &mut [f64]| {
            g[0] = 2.0 * (x[0] - 3.0);
            if x[0] < 2.0 {
                (x[0] - 3.0).powi(2)
            } else {
                f64::INFINITY
            }
        };
        let r = lbfgs(wall, &[0.0], &LbfgsOptions { max_iters: 200, ..tight() });
        assert!(r.x[0] < 2.0 && r.x[0] > 1.9, "{:?} {:?}", r.x, r.info);
        assert!(!r.info.converged, "{:?}", r.info);
        let nan = |x: &[f64], g: &mut [f64]| {
            g[0] = 2.0 * (x[0] - 3.0);
            if x[0] < 2.0 {
                (x[0] - 3.0).powi(2)
            } else {
                f64::NAN
            }
        };
        let r = lbfgs(nan, &[0.0], &LbfgsOptions { max_iters: 200, ..tight() });
        assert_eq!(r.info.reason, StopReason::NonFinite, "{:?}", r.info);
        // A wrong gradient (the sign flipped): no step can decrease f.
        let wrong = |x: &[f64], g: &mut [f64]| {
            g[0] = -2.0 * x[0];
            x[0] * x[0] + 1.0
        };
        let r = lbfgs(wrong, &[1.0], &tight());
        assert_eq!(r.info.reason, StopReason::Stalled, "{:?}", r.info);
    }
}
