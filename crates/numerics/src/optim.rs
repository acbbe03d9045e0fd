//! What the optimisers ([`crate::scg`], [`crate::lbfgs`]) share: the convergence rule,
//! why a run stopped, its summary and its per-iteration trace.
//!
//! **The convergence rule** ([`Convergence`]) is a test of the *problem*, not of the
//! optimiser's last step, so SCG and L-BFGS stop at the same kind of point. After an
//! accepted iteration $k$ (with $f_k$, $g_k$, $x_k$) it needs BOTH
//!
//! 1. *the objective has stopped moving over a window*: with $W$ = [`Convergence::window`]
//!    accepted iterations,
//!    $$\frac{f_{k-W} - f_k}{W\,\max(\lvert f_k\rvert, f_{typ})} \le \texttt{ftol},$$
//!    the mean relative decrease per iteration over the last $W$ (a single small step, as
//!    in Netlab's or paramz's tests, is not enough: SCG and L-BFGS both take short steps
//!    in narrow valleys long before they are done);
//! 2. *the gradient is small relative to what a move could gain* (Dennis & Schnabel's
//!    scaled gradient, their §7.2):
//!    $$\max_i \frac{\lvert g_i\rvert\,\max(\lvert x_i\rvert, 1)}{\max(\lvert f_k\rvert, f_{typ})} \le \texttt{gtol},$$
//!    i.e. moving any one parameter by its own size (or by 1, for parameters near 0)
//!    changes $f$ by at most `gtol` relative.
//!
//! $f_{typ}$ ([`Convergence::f_typical`]) is the size the objective has when it happens to
//! be near 0: a sum of $M$ terms of order one nat should pass $M$ (the GPLVM fit passes
//! $N\cdot d$, the number of modelled values), so neither test becomes impossible when $f$
//! crosses zero. Both tests are relative, so they scale with $N$ and $d$ without
//! retuning. An iteration cap remains as a safety net ([`StopReason::MaxIterations`]):
//! hitting it is NOT converged.

use std::collections::VecDeque;

/// The convergence rule (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Convergence {
    /// Window $W$ in accepted iterations (default 10).
    pub window: usize,
    /// Tolerance on the mean relative decrease per iteration over the window (default $10^{-9}$).
    pub ftol: f64,
    /// Tolerance on the scaled gradient (default $10^{-5}$).
    pub gtol: f64,
    /// $f_{typ}$: the objective's typical size when it is near 0 (default 1).
    pub f_typical: f64,
}

impl Default for Convergence {
    fn default() -> Self {
        Self { window: 10, ftol: 1e-9, gtol: 1e-5, f_typical: 1.0 }
    }
}

/// The two quantities the rule tests, at one accepted iterate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ConvergenceMeasures {
    /// Mean relative decrease per iteration over the window (`inf` until the window is full).
    pub rel_decrease: f64,
    /// The scaled gradient.
    pub rel_gradient: f64,
}

impl Convergence {
    /// The scaled gradient $\max_i \lvert g_i\rvert\max(\lvert x_i\rvert,1)/\max(\lvert f\rvert,f_{typ})$.
    pub fn rel_gradient(&self, f: f64, x: &[f64], g: &[f64]) -> f64 {
        let scale = f.abs().max(self.f_typical);
        x.iter().zip(g).map(|(x, g)| g.abs() * x.abs().max(1.0)).fold(0.0, f64::max) / scale
    }
}

/// Tracks the accepted values of a run and applies a [`Convergence`] rule.
#[derive(Debug, Clone)]
pub struct Monitor {
    rule: Convergence,
    values: VecDeque<f64>,
    last: ConvergenceMeasures,
}

impl Monitor {
    /// A monitor starting at the value `f0` of the starting point.
    pub fn new(rule: Convergence, f0: f64) -> Self {
        let mut values = VecDeque::with_capacity(rule.window + 1);
        values.push_back(f0);
        Self { rule, values, last: ConvergenceMeasures { rel_decrease: f64::INFINITY, rel_gradient: f64::INFINITY } }
    }

    /// Records an accepted iterate; true when the rule is met there.
    pub fn accept(&mut self, f: f64, x: &[f64], g: &[f64]) -> bool {
        self.values.push_back(f);
        if self.values.len() > self.rule.window.max(1) + 1 {
            self.values.pop_front();
        }
        let scale = f.abs().max(self.rule.f_typical);
        let full = self.values.len() == self.rule.window.max(1) + 1;
        let rel_decrease =
            if full { (self.values[0] - f) / (self.rule.window.max(1) as f64 * scale) } else { f64::INFINITY };
        let rel_gradient = self.rule.rel_gradient(f, x, g);
        self.last = ConvergenceMeasures { rel_decrease, rel_gradient };
        rel_decrease <= self.rule.ftol && rel_gradient <= self.rule.gtol
    }

    /// The measures at the last accepted iterate.
    pub fn measures(&self) -> ConvergenceMeasures {
        self.last
    }
}

/// Why an optimiser stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// The [`Convergence`] rule was met (converged).
    Converged,
    /// SCG's Netlab/paramz step tolerances were met (a step-size test, kept to reproduce
    /// those optimisers; not evidence of convergence by itself).
    Tolerance,
    /// $g^\top g \le$ `gtol` (SCG's absolute gradient test).
    Gradient,
    /// The search direction vanished ($d^\top d <$ machine epsilon).
    TinyDirection,
    /// The iteration cap was reached before convergence (NOT converged).
    MaxIterations,
    /// No acceptable step could be found along a descent direction (L-BFGS line search
    /// failed twice in a row, the second time along $-g$): NOT converged.
    Stalled,
    /// The starting point has a non-finite value or gradient.
    NonFiniteStart,
    /// An evaluation returned NaN (a computation went wrong, not a step that was too long).
    NonFinite,
}

impl StopReason {
    /// The kebab-case name written to artifacts.
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Converged => "converged",
            StopReason::Tolerance => "tolerance",
            StopReason::Gradient => "gradient",
            StopReason::TinyDirection => "tiny-direction",
            StopReason::MaxIterations => "max-iterations",
            StopReason::Stalled => "stalled",
            StopReason::NonFiniteStart => "non-finite-start",
            StopReason::NonFinite => "non-finite",
        }
    }

    /// Whether the reason means a converged run.
    pub fn is_converged(self) -> bool {
        matches!(self, StopReason::Converged | StopReason::Tolerance | StopReason::Gradient | StopReason::TinyDirection)
    }
}

/// Summary of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptInfo {
    /// Iterations performed.
    pub iterations: usize,
    /// Closure calls (value and gradient together).
    pub evaluations: usize,
    /// Objective at the returned point.
    pub value: f64,
    /// $\lVert\nabla f\rVert_2$ at the returned point.
    pub grad_norm: f64,
    /// Whether a convergence test (not the iteration cap, a stall or a failure) stopped the run.
    pub converged: bool,
    /// Why it stopped.
    pub reason: StopReason,
    /// The convergence measures at the returned point (also computed when another rule
    /// stopped the run).
    pub measures: ConvergenceMeasures,
}

/// One iteration of the trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptIter {
    /// Objective at the current point after this iteration.
    pub value: f64,
    /// $\lVert\nabla f\rVert_2$ at the current point.
    pub grad_norm: f64,
    /// SCG: $\beta$ after this iteration; L-BFGS: the accepted step length.
    pub beta: f64,
    /// Whether the step was accepted.
    pub accepted: bool,
    /// Evaluations so far.
    pub evaluations: usize,
    /// Seconds since the run started.
    pub seconds: f64,
}

/// The optimum, its summary and the per-iteration trace.
#[derive(Debug, Clone, PartialEq)]
pub struct OptResult {
    /// The final point.
    pub x: Vec<f64>,
    /// Summary.
    pub info: OptInfo,
    /// One entry per iteration.
    pub trace: Vec<OptIter>,
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// Builds the result of a run that stopped at `x` (value `f`, gradient `g`).
pub(crate) fn finish(
    x: Vec<f64>,
    f: f64,
    g: &[f64],
    (iterations, evaluations): (usize, usize),
    reason: StopReason,
    measures: ConvergenceMeasures,
    trace: Vec<OptIter>,
) -> OptResult {
    let info = OptInfo {
        iterations,
        evaluations,
        value: f,
        grad_norm: dot(g, g).sqrt(),
        converged: reason.is_converged(),
        reason,
        measures,
    };
    OptResult { x, info, trace }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The window test needs W accepted iterations; the gradient test is relative to |f|
    /// and to each parameter's size; both must hold.
    #[test]
    fn rule_needs_both_tests_over_a_full_window() {
        let rule = Convergence { window: 3, ftol: 1e-6, gtol: 1e-3, f_typical: 1.0 };
        let mut m = Monitor::new(rule, 100.0);
        let (x, small_g, big_g) = ([10.0, 0.1], [1e-3, 1e-2], [1.0, 0.0]);
        assert!(!m.accept(100.0, &x, &small_g), "window not full yet");
        assert!(!m.accept(100.0, &x, &small_g));
        assert!(m.accept(100.0, &x, &small_g));
        assert!((m.measures().rel_gradient - 1e-4).abs() < 1e-15);
        assert!(!m.accept(100.0, &x, &big_g), "gradient 1·10/100 = 0.1 > gtol");
        // Decreasing by 1e-3 relative per iteration fails the window test.
        let mut m = Monitor::new(rule, 100.0);
        let all: Vec<bool> = (1..=5).map(|k| m.accept(100.0 - 0.1 * k as f64, &x, &small_g)).collect();
        assert!(all.iter().all(|c| !c), "{all:?}");
        // Near f = 0, f_typical sets the scale.
        let r = Convergence { f_typical: 1e4, ..rule };
        assert!((r.rel_gradient(1e-3, &[0.0], &[1.0]) - 1e-4).abs() < 1e-18);
    }
}
