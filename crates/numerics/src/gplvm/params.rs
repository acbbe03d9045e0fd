//! Kernel hyperparameters, their gradients, the jitter policy, and the layout of the flat
//! parameter vector that the optimiser sees.

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, LltRegularization};
use faer::reborrow::ReborrowMut;
use faer::{MatMut, Par};

use super::GplvmError;

/// The three hyperparameters of $k(x,x') = \sigma_f^2 e^{-\lVert x-x'\rVert^2/(2\ell^2)} +
/// \sigma_w^2\delta$, in natural space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hyper {
    /// RBF variance $\sigma_f^2$.
    pub rbf_variance: f64,
    /// Length scale $\ell$ (not $\ell^2$).
    pub lengthscale: f64,
    /// White-noise variance $\sigma_w^2$.
    pub white_variance: f64,
}

impl Hyper {
    /// From log space $(\log\sigma_f^2, \log\ell, \log\sigma_w^2)$.
    pub fn from_log(log: [f64; 3]) -> Self {
        Self { rbf_variance: log[0].exp(), lengthscale: log[1].exp(), white_variance: log[2].exp() }
    }

    /// To log space $(\log\sigma_f^2, \log\ell, \log\sigma_w^2)$.
    pub fn to_log(&self) -> [f64; 3] {
        [self.rbf_variance.ln(), self.lengthscale.ln(), self.white_variance.ln()]
    }

    /// Every value finite; $\sigma_f^2, \ell > 0$ and $\sigma_w^2 \ge 0$ (a zero white
    /// variance, e.g. $e^u$ underflowing, is left to the floor and the jitter).
    pub fn check(&self) -> Result<(), GplvmError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if pos(self.rbf_variance)
            && pos(self.lengthscale)
            && self.white_variance.is_finite()
            && self.white_variance >= 0.0
        {
            Ok(())
        } else {
            Err(GplvmError::Params(format!("hyperparameters must be finite and positive, got {self:?}")))
        }
    }
}

/// A gradient with respect to the three hyperparameters (natural or log space, as the
/// producer says).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HyperGrad {
    /// With respect to $\sigma_f^2$ (or $\log\sigma_f^2$).
    pub rbf_variance: f64,
    /// With respect to $\ell$ (or $\log\ell$).
    pub lengthscale: f64,
    /// With respect to $\sigma_w^2$ (or $\log\sigma_w^2$).
    pub white_variance: f64,
}

impl HyperGrad {
    /// The chain rule to log space at `at`: $\partial E/\partial\log\phi = \phi\,\partial E/\partial\phi$.
    pub fn to_log(&self, at: &Hyper) -> Self {
        Self {
            rbf_variance: self.rbf_variance * at.rbf_variance,
            lengthscale: self.lengthscale * at.lengthscale,
            white_variance: self.white_variance * at.white_variance,
        }
    }

    /// As `[σ_f², ℓ, σ_w²]`.
    pub fn to_array(&self) -> [f64; 3] {
        [self.rbf_variance, self.lengthscale, self.white_variance]
    }
}

/// The diagonal jitter policy for a Cholesky factorisation of a covariance $K$.
///
/// Every factorisation adds `base` to the diagonal. If the factorisation fails it is
/// retried with `base + retry_relative · mean(diag K) · growth^k` for
/// $k = 0, …, $ `max_retries − 1` (GPy's `jitchol`: $10^{-6}$, ×10, 5 tries), after which
/// it is an error. [`JitterUsed`] reports what was added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jitter {
    /// Always added to the diagonal (absolute). GPy adds $10^{-8}$.
    pub base: f64,
    /// First escalation, relative to the mean diagonal of $K$.
    pub retry_relative: f64,
    /// Factor between escalations.
    pub growth: f64,
    /// Number of escalations before giving up (0: fail at once).
    pub max_retries: u32,
}

impl Jitter {
    /// GPy's policy: always $10^{-8}$, then $10^{-6}, …, 10^{-2}$ × mean diagonal.
    pub const GPY: Self = Self { base: 1e-8, retry_relative: 1e-6, growth: 10.0, max_retries: 5 };
    /// No jitter at all, and no escalation: the exact matrix or an error.
    pub const NONE: Self = Self { base: 0.0, retry_relative: 0.0, growth: 10.0, max_retries: 0 };

    fn check(&self) -> Result<(), GplvmError> {
        let ok = self.base >= 0.0
            && self.base.is_finite()
            && self.retry_relative >= 0.0
            && self.retry_relative.is_finite()
            && self.growth >= 1.0
            && self.growth.is_finite();
        if ok {
            Ok(())
        } else {
            Err(GplvmError::Params(format!("invalid jitter policy {self:?}")))
        }
    }
}

impl Default for Jitter {
    fn default() -> Self {
        Self::GPY
    }
}

/// What a factorisation actually added to the diagonal.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JitterUsed {
    /// Total added beyond the kernel's own diagonal (`base` + any escalation).
    pub added: f64,
    /// Escalations needed (0 when `base` sufficed).
    pub retries: u32,
}

/// Factors $K + jI$ in place (lower triangle) under the jitter policy. `fill` writes the
/// lower triangle (diagonal included) of $K$ without jitter into its argument; it is
/// called again before every retry because a failed factorisation leaves garbage.
pub(crate) fn cholesky_with_jitter(
    mut l: MatMut<'_, f64>,
    mut fill: impl FnMut(MatMut<'_, f64>),
    jitter: &Jitter,
    what: &'static str,
    par: Par,
    stack: &mut MemStack,
) -> Result<JitterUsed, GplvmError> {
    jitter.check()?;
    let n = l.nrows();
    let mut mean_diag = 0.0;
    let mut extra = 0.0;
    for retries in 0..=jitter.max_retries {
        fill(l.rb_mut());
        if retries == 0 {
            mean_diag = (0..n).map(|i| l[(i, i)]).sum::<f64>() / n.max(1) as f64;
        } else {
            extra = if retries == 1 { jitter.retry_relative * mean_diag } else { extra * jitter.growth };
        }
        let added = jitter.base + extra;
        for i in 0..n {
            l[(i, i)] += added;
        }
        let ok = cholesky_in_place(l.rb_mut(), LltRegularization::default(), par, stack, Default::default()).is_ok();
        if ok {
            return Ok(JitterUsed { added, retries });
        }
    }
    Err(GplvmError::NotPositiveDefinite { what, jitter: jitter.base + extra })
}

/// faer's scratch memory, allocated once per workspace (a newtype only to be `Debug`).
pub(crate) struct Scratch(pub(crate) faer::dyn_stack::MemBuffer);

impl Scratch {
    pub(crate) fn new(req: faer::dyn_stack::StackReq) -> Self {
        Self(faer::dyn_stack::MemBuffer::new(req))
    }

    pub(crate) fn stack(&mut self) -> &mut MemStack {
        MemStack::new(&mut self.0)
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Scratch")
    }
}

/// The flat parameter vector of the MAP fit, length $Nq + 3$:
///
/// `[x_{0,0}, …, x_{N−1,q−1}, log σ_f², log ℓ, log σ_w²]`
///
/// i.e. $X$ row-major (frame by frame), then the log hyperparameters. (A sparse fit's
/// inducing points are tied to latents, so they add no parameters.) Gradients use the
/// same layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Number of latent points $N$.
    pub n: usize,
    /// Latent dimension $q$.
    pub q: usize,
}

impl Layout {
    /// The layout of $N$ latent points in $q$ dimensions.
    pub fn new(n: usize, q: usize) -> Self {
        Self { n, q }
    }

    /// Total length $Nq + 3$.
    pub fn len(&self) -> usize {
        self.hyper_offset() + 3
    }

    /// Where the log hyperparameters start, $Nq$.
    pub fn hyper_offset(&self) -> usize {
        self.n * self.q
    }

    /// Never empty (the three hyperparameters are always there).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The latent block $X$ (row-major $N\times q$).
    pub fn x<'a>(&self, params: &'a [f64]) -> &'a [f64] {
        &params[..self.n * self.q]
    }

    /// The latent block, mutable.
    pub fn x_mut<'a>(&self, params: &'a mut [f64]) -> &'a mut [f64] {
        &mut params[..self.n * self.q]
    }

    /// The hyperparameters (natural space) encoded in `params`.
    pub fn hyper(&self, params: &[f64]) -> Hyper {
        let o = self.hyper_offset();
        Hyper::from_log([params[o], params[o + 1], params[o + 2]])
    }

    /// The flat vector for `x` and `hyper`.
    pub fn pack(&self, x: &[f64], hyper: &Hyper) -> Vec<f64> {
        assert_eq!(x.len(), self.n * self.q, "x must be N × q");
        let mut p = Vec::with_capacity(self.len());
        p.extend_from_slice(x);
        p.extend_from_slice(&hyper.to_log());
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Log space round-trips and the chain rule multiplies by the natural value.
    #[test]
    fn log_space_round_trip_and_chain_rule() {
        let h = Hyper { rbf_variance: 2.5, lengthscale: 0.3, white_variance: 1e-3 };
        let back = Hyper::from_log(h.to_log());
        for (a, b) in [(h.rbf_variance, back.rbf_variance), (h.lengthscale, back.lengthscale)] {
            assert!((a - b).abs() < 1e-15 * a);
        }
        let g = HyperGrad { rbf_variance: 1.0, lengthscale: 2.0, white_variance: 3.0 }.to_log(&h);
        assert_eq!(g.to_array(), [2.5, 0.6, 3e-3]);
        let layout = Layout::new(2, 3);
        let p = layout.pack(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &h);
        assert_eq!((p.len(), layout.hyper_offset()), (9, 6));
        assert_eq!(layout.x(&p), &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert!((layout.hyper(&p).lengthscale - 0.3).abs() < 1e-15);
        assert!(Hyper { white_variance: -1e-3, ..h }.check().is_err());
        assert!(Hyper { white_variance: 0.0, ..h }.check().is_ok());
        assert!(Hyper { lengthscale: 0.0, ..h }.check().is_err());
    }

    /// An indefinite matrix needs escalation; the reported jitter is what made it factor.
    #[test]
    fn jitter_escalates_and_reports() {
        let n = 3;
        // Rank-1 (singular) matrix 11ᵀ: base jitter 0 fails, escalation succeeds.
        let mut l = faer::Mat::<f64>::zeros(n, n);
        let mut mem = faer::dyn_stack::MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default()),
        );
        let stack = MemStack::new(&mut mem);
        let fill = |mut m: MatMut<'_, f64>| {
            for j in 0..n {
                for i in j..n {
                    m[(i, j)] = 1.0;
                }
            }
        };
        let policy = Jitter { base: 0.0, retry_relative: 1e-6, growth: 10.0, max_retries: 3 };
        let used = cholesky_with_jitter(l.as_mut(), fill, &policy, "K", Par::Seq, stack).unwrap();
        assert!(used.retries >= 1 && used.added >= 1e-6, "{used:?}");
        let err = cholesky_with_jitter(l.as_mut(), fill, &Jitter::NONE, "K", Par::Seq, stack);
        assert!(matches!(err, Err(GplvmError::NotPositiveDefinite { .. })));
    }
}
