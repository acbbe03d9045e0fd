//! The engine's named improvements over the paper, each an option of [`Method`], and what
//! they read from the training data: each model's idle [`Dynamics`] and each bridge's
//! [`Landing`]. `docs/method.md` states each rule and its measured effect.
//!
//! - **`live-idle`** ([`IdleRule::FromData`]): the random force's variance $\alpha_m$ and the
//!   drag $c_m$ come from model $m$'s training latents, so that an idling particle moves
//!   as fast as the label's training frames do (the paper: the particle "moves randomly
//!   within a radius r about the point"; it gives no values). The rule:
//!   - $c_m = 1/\tau_m$, with $\tau_m$ the lag at which the autocorrelation of the training
//!     latent velocity, $\rho(k) = \sum_t v_t\cdot v_{t+k} / \sum_t\lVert v_t\rVert^2$ over
//!     consecutive frames of a segment, first falls below $e^{-1}$ (linearly interpolated,
//!     clamped to $[2/\text{fps}, 2\,\text{s}]$): the particle forgets its velocity as fast
//!     as the training motion does;
//!   - $\alpha_m$ such that the free particle's stationary mean speed equals the training
//!     mean speed $\bar s_m$: under $\dot v = f(t) - c\,v$ with $f$ each component
//!     $\mathcal{GP}(0, \alpha e^{-u^2/2\gamma})$, each velocity component has variance
//!     $\sigma^2 = \frac{\alpha}{c}\int_0^\infty e^{-cu - u^2/2\gamma}\,du$, and the mean
//!     speed in $q$ dimensions is $m_q\sigma$, $m_q = \sqrt2\,\Gamma(\frac{q+1}2)/\Gamma(\frac q2)$;
//!   - then corrected by simulation, since the disc and the density force slow the free
//!     particle: IDLE is run from [`CALIBRATION_STARTS`] training latents for
//!     [`CALIBRATION_SECONDS`] and $\alpha_m$ scaled by $(\bar s_m / \text{measured})^2$,
//!     [`CALIBRATION_ROUNDS`] times (each factor clamped to $[1/16, 16]$);
//!   - and at most $\alpha_{\max} = (\kappa\,\omega_0^2 r)^2$ ([`MAX_FORCE_RATIO`] $=\kappa$,
//!     $r$ the default idle radius, and in every frame the radius of the disc the particle
//!     is in, so the force quietens in the tight disc of an approach to a bridge or a
//!     segment): a random force stronger than the path constraint's pull
//!     at the disc's edge throws the particle out of the disc, and the constrained
//!     integration then diverges (measured on dragon-face: `roar` calibrated to
//!     $\alpha = 3.1\times10^5$ left for $10^{153}$ latent units). A label whose training
//!     motion is faster than an idle within $r$ can be therefore idles slower than it moves.
//! - **`landing-choice`** ([`BridgeChoice::TravelAndLanding`]): TRANSITION takes the bridge
//!   of least expected time until the particle is at a pose of the target label,
//!   $\lVert x - x_1\rVert / v_A + \lVert x_2 - x_B\rVert / v_B$, with $v$ each model's
//!   speed limit and $x_B$ the bridge's [`Landing`] point; the paper takes the nearest
//!   $x_1$.
//! - **`settle`**: after the blend, the particle MOVEs (straight, at the speed limit, to
//!   within the idle radius) from $x_2$ to the landing point $x_B$, a training latent of
//!   the target label, and what follows (IDLE) happens there; the paper idles at $x_2$,
//!   which the bridge search placed to match the *source* pose and which may be a pose
//!   the target label never has.

use crate::engine::TrainingFrame;

/// How the random force's variance and the drag are set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IdleRule {
    /// `Settings::random_variance` and `Settings::drag` for every model.
    Fixed,
    /// Each model's own [`Dynamics`], from its training latents.
    FromData,
}

/// Which bridge TRANSITION takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BridgeChoice {
    /// The bridge whose $x_1$ is nearest the particle (the paper).
    Nearest,
    /// The least travel-plus-landing time (see the module doc).
    TravelAndLanding,
}

/// The engine's options over the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Method {
    /// Random force and drag.
    pub idle: IdleRule,
    /// TRANSITION's bridge.
    pub bridge_choice: BridgeChoice,
    /// MOVE to the landing point after a switch.
    pub settle: bool,
}

/// One improvement: its name (as the benchmark's ablation shows it), what it does, and how
/// it turns a method on.
#[derive(Debug, Clone, Copy)]
pub struct Improvement {
    /// Name, e.g. `live-idle`.
    pub name: &'static str,
    /// One sentence.
    pub about: &'static str,
    /// The method with this improvement turned on.
    pub apply: fn(Method) -> Method,
}

impl Method {
    /// As the paper describes it.
    pub const PAPER: Method = Method { idle: IdleRule::Fixed, bridge_choice: BridgeChoice::Nearest, settle: false };
    /// Every improvement on (the default).
    pub const TUNED: Method =
        Method { idle: IdleRule::FromData, bridge_choice: BridgeChoice::TravelAndLanding, settle: true };
    /// The improvements, in the order the ablation lists them.
    pub const IMPROVEMENTS: [Improvement; 3] = [
        Improvement {
            name: "live-idle",
            about: "random force and drag set per label so the idle moves as fast as the label's training frames",
            apply: |m| Method { idle: IdleRule::FromData, ..m },
        },
        Improvement {
            name: "landing-choice",
            about: "TRANSITION takes the bridge of least travel-plus-landing time, not the nearest",
            apply: |m| Method { bridge_choice: BridgeChoice::TravelAndLanding, ..m },
        },
        Improvement {
            name: "settle",
            about: "after the switch the particle moves to the target label's training pose nearest the landing",
            apply: |m| Method { settle: true, ..m },
        },
    ];
}

impl Default for Method {
    fn default() -> Self {
        Self::TUNED
    }
}

/// A model's random-force variance $\alpha$ and drag $c$ (s⁻¹), and the training speed
/// they were set to reproduce (latent units per second).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics {
    /// $\alpha$.
    pub random_variance: f64,
    /// $c$.
    pub drag: f64,
    /// $\bar s$: the training frames' mean latent speed.
    pub training_speed: f64,
}

/// IDLE runs from this many training latents per model to calibrate $\alpha$.
pub const CALIBRATION_STARTS: usize = 4;
/// Seconds of each calibration run (its first half-second is not measured).
pub const CALIBRATION_SECONDS: f64 = 6.0;
/// Rounds of the calibration.
pub const CALIBRATION_ROUNDS: usize = 2;
/// $\kappa$: the random force's standard deviation per component is at most $\kappa$ times
/// the constraint's pull $\omega_0^2 r$ at the edge of the default idle disc.
pub const MAX_FORCE_RATIO: f64 = 1.0;
/// The largest random-force standard deviation per component in a disc of radius `r`:
/// $\kappa\,\omega_0^2 r$ ([`MAX_FORCE_RATIO`]), the constraint's pull at the disc's edge.
pub fn max_random_force(omega0: f64, r: f64) -> f64 {
    MAX_FORCE_RATIO * omega0 * omega0 * r
}

/// The longest velocity memory $\tau$ the rule allows (s).
pub const MAX_MEMORY_SECONDS: f64 = 2.0;

/// The velocities $(x_{t+1} - x_t)\cdot\text{fps}$ of consecutive training frames, one run
/// per stretch of consecutive frames of a segment.
fn velocity_runs(frames: &[TrainingFrame], fps: f64) -> Vec<Vec<Vec<f64>>> {
    let mut order: Vec<&TrainingFrame> = frames.iter().collect();
    order.sort_by_key(|f| (f.segment, f.frame));
    let mut runs: Vec<Vec<Vec<f64>>> = Vec::new();
    let mut open = false;
    for w in order.windows(2) {
        if w[0].segment == w[1].segment && w[1].frame == w[0].frame + 1 {
            if !open {
                runs.push(Vec::new());
                open = true;
            }
            let v = w[1].x.iter().zip(&w[0].x).map(|(b, a)| (b - a) * fps).collect();
            runs.last_mut().expect("opened above").push(v);
        } else {
            open = false;
        }
    }
    runs
}

/// The mean speed of an isotropic Gaussian velocity with unit per-component variance in
/// `q` dimensions: $m_q = \sqrt2\,\Gamma(\frac{q+1}2)/\Gamma(\frac q2)$, by
/// $m_1 = \sqrt{2/\pi}$, $m_2 = \sqrt{\pi/2}$, $m_{q+2} = m_q\,(q+1)/q$.
pub fn mean_speed_factor(q: usize) -> f64 {
    let (mut m, mut k) =
        if q % 2 == 1 { ((2.0 / std::f64::consts::PI).sqrt(), 1) } else { ((std::f64::consts::PI / 2.0).sqrt(), 2) };
    while k < q.max(1) {
        m *= (k + 1) as f64 / k as f64;
        k += 2;
    }
    m
}

/// $\int_0^\infty e^{-cu - u^2/2\gamma}\,du$ by Simpson's rule over
/// $[0, \min(12\sqrt\gamma, 40/c)]$ (beyond, the Gaussian factor is below $e^{-72}$ or the
/// exponential one below $e^{-40}$).
pub fn memory_integral(c: f64, gamma: f64) -> f64 {
    let end = if c > 0.0 { (12.0 * gamma.sqrt()).min(40.0 / c) } else { 12.0 * gamma.sqrt() };
    let n = 2000;
    let h = end / n as f64;
    let f = |u: f64| (-c * u - u * u / (2.0 * gamma)).exp();
    let inner: f64 = (1..n).map(|i| f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 }).sum();
    (f(0.0) + inner + f(end)) * h / 3.0
}

impl Dynamics {
    /// The closed-form rule (before the simulated correction) from a model's training
    /// frames; `None` without two consecutive frames or without motion.
    pub fn from_training(frames: &[TrainingFrame], fps: f64, gamma: f64) -> Option<Self> {
        let runs = velocity_runs(frames, fps);
        let q = frames.first()?.x.len();
        let (mut sum, mut count) = (0.0, 0usize);
        for v in runs.iter().flatten() {
            sum += v.iter().map(|a| a * a).sum::<f64>().sqrt();
            count += 1;
        }
        if count == 0 || sum <= 0.0 {
            return None;
        }
        let speed = sum / count as f64;
        let max_lag = (MAX_MEMORY_SECONDS * fps).ceil() as usize;
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let rho = |k: usize| -> Option<f64> {
            let (mut num, mut den) = (0.0, 0.0);
            for r in &runs {
                for t in 0..r.len().saturating_sub(k) {
                    num += dot(&r[t], &r[t + k]);
                    den += dot(&r[t], &r[t]);
                }
            }
            (den > 0.0).then(|| num / den)
        };
        let target = (-1.0f64).exp();
        let mut tau = MAX_MEMORY_SECONDS;
        let mut prev = 1.0;
        for k in 1..=max_lag {
            let Some(r) = rho(k) else { break };
            if r < target {
                let frac = if prev > r { (prev - target) / (prev - r) } else { 1.0 };
                tau = ((k - 1) as f64 + frac) / fps;
                break;
            }
            prev = r;
        }
        let tau = tau.clamp(2.0 / fps, MAX_MEMORY_SECONDS);
        let drag = 1.0 / tau;
        let sigma = speed / mean_speed_factor(q);
        let random_variance = drag * sigma * sigma / memory_integral(drag, gamma);
        Some(Self { random_variance, drag, training_speed: speed })
    }
}

/// Where a bridge lands in its target model: the training point of the target whose
/// reconstructed pose is nearest $g_2(x_2)$, and how far.
#[derive(Debug, Clone, PartialEq)]
pub struct Landing {
    /// Index of the training point in the target model (its point order).
    pub point: usize,
    /// Its latent $x_B$.
    pub x: Vec<f64>,
    /// $\lVert x_2 - x_B\rVert$ (latent units).
    pub latent_distance: f64,
    /// $\lVert g_2(x_2) - g_2(x_B)\rVert$ in the target's scaled control space (mesh
    /// length; PCA directions are orthonormal there, so it is the distance of the GP means).
    pub pose_distance: f64,
}

/// The landing of `x2` in `model`, given the GP means at its training points
/// (`train_means`, row-major `N × d`).
pub fn landing(model: &reprise_numerics::gplvm::LatentModel, train_means: &[f64], x2: &[f64]) -> Option<Landing> {
    let (q, d) = (model.q(), model.d());
    let mut y = vec![0.0; d];
    model.predictor.mean(x2, &mut y);
    let (point, sq) = train_means
        .chunks_exact(d)
        .map(|t| t.iter().zip(&y).map(|(a, b)| (a - b) * (a - b)).sum::<f64>())
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let x = model.latents()[point * q..(point + 1) * q].to_vec();
    let latent_distance = reprise_numerics::vector::dist(&x, x2);
    Some(Landing { point, x, latent_distance, pose_distance: sq.sqrt() })
}

/// The GP means $\mu(x_i)$ at a model's training points (row-major `N × d`).
pub fn training_means(model: &reprise_numerics::gplvm::LatentModel) -> Vec<f64> {
    model.training_means()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// $m_q$ against its definition through the gamma function's known values.
    #[test]
    fn mean_speed_factor_matches_the_chi_mean() {
        let pi = std::f64::consts::PI;
        assert!((mean_speed_factor(1) - (2.0 / pi).sqrt()).abs() < 1e-12);
        assert!((mean_speed_factor(2) - (pi / 2.0).sqrt()).abs() < 1e-12);
        assert!((mean_speed_factor(3) - (8.0 / pi).sqrt()).abs() < 1e-12);
        // q = 4: √2 Γ(5/2)/Γ(2) = √2 · (3/4)√π.
        assert!((mean_speed_factor(4) - 2f64.sqrt() * 0.75 * pi.sqrt()).abs() < 1e-12);
    }

    /// The memory integral: at c = 0 it is √(πγ/2); at γ → ∞ (a constant force) it is 1/c.
    #[test]
    fn memory_integral_has_its_limits() {
        let g: f64 = 0.05;
        assert!((memory_integral(0.0, g) - (std::f64::consts::PI * g / 2.0).sqrt()).abs() < 1e-9);
        assert!((memory_integral(2.0, 1e6) - 0.5).abs() < 1e-3);
    }

    fn frames_of(xs: &[Vec<f64>], segment: i64) -> Vec<TrainingFrame> {
        xs.iter()
            .enumerate()
            .map(|(i, x)| TrainingFrame { segment, clip: "c".into(), frame: i as i64, x: x.clone() })
            .collect()
    }

    /// A circle traversed at a known speed: the training speed is that speed, and the
    /// velocity's memory is the lag at which cos(ωτ) = 1/e.
    #[test]
    fn the_rule_reads_speed_and_memory_from_the_training_frames() {
        let (fps, w, r) = (24.0, 1.5, 0.8);
        let xs: Vec<Vec<f64>> =
            (0..400).map(|i| i as f64 / fps).map(|t| vec![r * (w * t).cos(), r * (w * t).sin()]).collect();
        let d = Dynamics::from_training(&frames_of(&xs, 0), fps, 0.05).unwrap();
        let chord = 2.0 * r * (w / (2.0 * fps)).sin() * fps;
        assert!((d.training_speed - chord).abs() < 1e-9, "{}", d.training_speed);
        let tau = (-1.0f64).exp().acos() / w;
        assert!((1.0 / d.drag - tau).abs() < 0.5 / fps, "memory {} vs {tau}", 1.0 / d.drag);
        // A frozen label has no dynamics; one frame has none either.
        let still = vec![vec![0.1, 0.2]; 10];
        assert_eq!(Dynamics::from_training(&frames_of(&still, 0), fps, 0.05), None);
        assert_eq!(Dynamics::from_training(&frames_of(&xs[..1], 0), fps, 0.05), None);
    }
}
