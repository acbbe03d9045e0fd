//! A fitted retargeting model and its per-frame mapping: the shared GPLVM of
//! [`crate::shared`] over a training set (labelled pairs, source-only frames, target-only
//! poses), each space normalised as the paper's implementation note says (centred, divided
//! by its largest per-dimension standard deviation), and [`Mapper`], which maps one source
//! frame by the MAP solve of [`crate::source`] and returns the target GP's mean (Eq. 18).
//!
//! Latent rows: the source rows first (labelled, then source-only), then the target-only
//! rows. The target space owns the labelled rows and the target-only rows.

use reprise_numerics::gplvm::{GplvmError, Hyper, LikelihoodConfig, MeanPredictor};
use reprise_numerics::lbfgs::LbfgsOptions;
use reprise_numerics::optim::OptInfo;

use crate::align::{align, denoise};
use crate::lle;
use crate::shared::{fit, initial_latents, predictor, SharedObjective, Space};
use crate::source::{Noise, SourceGp};

/// The paper's starting kernel parameters $\Phi = \{1, 1, 100\}$: $\sigma_f^2 = 1$,
/// $\ell = 1$, $\sigma_w^2 = 1/100$.
pub const START_HYPER: Hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 0.01 };

/// Centring and one scale: $\hat v = (v - \bar v)/s$, $s$ the largest per-dimension
/// standard deviation (1 for constant data).
#[derive(Debug, Clone, PartialEq)]
pub struct Affine {
    /// $\bar v$ per dimension.
    pub mean: Vec<f64>,
    /// $s$.
    pub scale: f64,
}

impl Affine {
    /// The normalisation of `v` (`n × d`, row-major).
    pub fn fit(v: &[f64], d: usize) -> Self {
        let n = (v.len() / d.max(1)).max(1) as f64;
        let mean: Vec<f64> = (0..d).map(|j| v.chunks_exact(d).map(|r| r[j]).sum::<f64>() / n).collect();
        let var =
            (0..d).map(|j| v.chunks_exact(d).map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>() / n).fold(0.0f64, f64::max);
        Self { mean, scale: if var > 0.0 { var.sqrt() } else { 1.0 } }
    }

    /// $\hat v$ of every row of `v`.
    pub fn apply(&self, v: &[f64]) -> Vec<f64> {
        let d = self.mean.len();
        v.chunks_exact(d).flat_map(|r| r.iter().zip(&self.mean).map(|(a, m)| (a - m) / self.scale)).collect()
    }

    /// $v = s\hat v + \bar v$ of every row of `v`.
    pub fn invert(&self, v: &[f64]) -> Vec<f64> {
        let d = self.mean.len();
        v.chunks_exact(d).flat_map(|r| r.iter().zip(&self.mean).map(|(a, m)| a * self.scale + m)).collect()
    }
}

/// What a model is fitted from, in each space's own units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainingSet<'a> {
    /// Source rows (`dx` values each): the labelled frames, then the source-only frames.
    pub x: &'a [f64],
    /// Source values per row.
    pub dx: usize,
    /// Target rows (`dy` values each): the labelled frames' targets, then the target-only
    /// poses.
    pub y: &'a [f64],
    /// Target values per row.
    pub dy: usize,
    /// Labelled pairs: the first rows of both.
    pub labelled: usize,
}

/// The prior over the latents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prior {
    /// None: the likelihoods alone.
    None,
    /// $\tfrac12\lVert Z\rVert^2$ (a unit Gaussian per latent).
    Gaussian,
    /// The LLE prior of Eq. 5–8 (which includes the unit Gaussian, $L = M^\top M + I$).
    Lle,
}

/// Where the latents start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Init {
    /// [`initial_latents`]: source principal coordinates, target-only rows at the nearest
    /// labelled row.
    Pca,
    /// The paper's semi-supervised manifold alignment ([`align`]), the source's
    /// neighbourhoods taken with the capture noise removed ([`denoise`]).
    Alignment,
}

impl Init {
    /// The start named `alignment` or `pca` (the stages' `--init`).
    ///
    /// # Errors
    /// Any other name, in words.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "alignment" => Ok(Init::Alignment),
            "pca" => Ok(Init::Pca),
            other => Err(format!("--init `{other}`: alignment or pca")),
        }
    }
}

/// The capture system's noise σc as the stages take it (`--capture-noise`): required,
/// finite and positive, in capture units.
///
/// # Errors
/// None given, or not finite and positive, in words.
pub fn capture_noise(given: Option<f64>) -> Result<f64, String> {
    let noise = given
        .ok_or("--capture-noise is required: the capture system's noise, a standard deviation in capture units")?;
    if noise.is_finite() && noise > 0.0 {
        Ok(noise)
    } else {
        Err(format!("--capture-noise {noise} must be finite and positive"))
    }
}

/// How a model is fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Latent dimension (the paper: 8); at most the source dimension and one less than the
    /// source rows.
    pub q: usize,
    /// Neighbours of the LLE prior and of the alignment's graphs (the paper: 8).
    pub k: usize,
    /// The prior over the latents.
    pub prior: Prior,
    /// Where the latents start.
    pub init: Init,
    /// The capture's noise $\sigma_c$, source units (the alignment's denoising; 0: none).
    pub capture_noise: f64,
    /// L-BFGS iterations at most.
    pub max_iters: usize,
}

/// A fitted model: both spaces' normalised data, the latents and the kernels.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Latent dimension.
    pub q: usize,
    /// Labelled pairs.
    pub labelled: usize,
    /// The source normalisation.
    pub x_norm: Affine,
    /// The target normalisation.
    pub y_norm: Affine,
    /// Normalised source rows (labelled, then source-only).
    pub x: Vec<f64>,
    /// Normalised target rows (labelled, then target-only).
    pub y: Vec<f64>,
    /// Latents, `n × q`: the source rows, then the target-only rows.
    pub z: Vec<f64>,
    /// The source kernel.
    pub hyper_x: Hyper,
    /// The target kernel.
    pub hyper_y: Hyper,
}

impl Model {
    /// Source values per row.
    pub fn dx(&self) -> usize {
        self.x_norm.mean.len()
    }

    /// Target values per row.
    pub fn dy(&self) -> usize {
        self.y_norm.mean.len()
    }

    /// Source rows.
    pub fn source_rows(&self) -> usize {
        self.x.len() / self.dx()
    }

    /// Latent rows.
    pub fn n(&self) -> usize {
        self.z.len() / self.q
    }

    /// The source space: rows `0..source_rows`.
    pub fn source(&self) -> Space<'_> {
        Space { data: &self.x, dim: self.dx(), rows: (0..self.source_rows()).collect() }
    }

    /// The target space: the labelled rows, then the target-only rows.
    pub fn target(&self) -> Space<'_> {
        Space { data: &self.y, dim: self.dy(), rows: (0..self.labelled).chain(self.source_rows()..self.n()).collect() }
    }

    /// Fits a model: normalisation, the initial latents, the prior, and L-BFGS on the
    /// shared objective from [`START_HYPER`].
    ///
    /// # Errors
    /// [`GplvmError::Shape`] for fewer than two labelled pairs, rows that do not match the
    /// dimensions, or a degenerate LLE neighbourhood; the likelihood's errors.
    pub fn fit(set: &TrainingSet<'_>, settings: &Settings) -> Result<(Self, OptInfo), GplvmError> {
        let (dx, dy, l) = (set.dx, set.dy, set.labelled);
        if dx == 0 || dy == 0 || !set.x.len().is_multiple_of(dx) || !set.y.len().is_multiple_of(dy) {
            return Err(GplvmError::Shape(format!(
                "{} source values are not rows of {dx}, or {} target values not rows of {dy}",
                set.x.len(),
                set.y.len()
            )));
        }
        let (nx, ny) = (set.x.len() / dx, set.y.len() / dy);
        if l < 2 || l > nx.min(ny) {
            return Err(GplvmError::Shape(format!(
                "{l} labelled pairs: at least 2 are needed, and at most the {nx} source and {ny} target rows"
            )));
        }
        let (x_norm, y_norm) = (Affine::fit(set.x, dx), Affine::fit(set.y, dy));
        let (x, y) = (x_norm.apply(set.x), y_norm.apply(set.y));
        let n = nx + ny - l;
        let q = settings.q.min(dx).min(nx - 1).max(1);
        let source = Space { data: &x, dim: dx, rows: (0..nx).collect() };
        let target = Space { data: &y, dim: dy, rows: (0..l).chain(nx..n).collect() };
        let k = settings.k.min(nx - 1).min(ny - 1).max(1);
        let prior = match settings.prior {
            Prior::None => None,
            Prior::Gaussian => Some(faer::Mat::<f64>::identity(n, n)),
            Prior::Lle => {
                let wx = lle::weights(&x, dx, k).map_err(|e| GplvmError::Shape(format!("the source's LLE: {e}")))?;
                let wy = lle::weights(&y, dy, k).map_err(|e| GplvmError::Shape(format!("the target's LLE: {e}")))?;
                Some(lle::prior_matrix(&[(&wx, &source.rows), (&wy, &target.rows)], n))
            }
        };
        let mut obj =
            SharedObjective::new(&[source.clone(), target.clone()], n, q, prior, LikelihoodConfig::default())?;
        let mut start = match settings.init {
            Init::Pca => initial_latents(&source, &target, n, q)?,
            Init::Alignment => {
                let sigma = settings.capture_noise / x_norm.scale;
                let clean = if sigma > 0.0 { denoise(&x, dx, sigma * sigma)? } else { x.clone() };
                align(&[Space { data: &clean, ..source.clone() }, target.clone()], n, q, k)?
            }
        };
        let log = START_HYPER.to_log();
        start.extend(log.iter().chain(log.iter()));
        let (p, info) =
            fit(&mut obj, &start, &LbfgsOptions { max_iters: settings.max_iters, ..LbfgsOptions::default() });
        let hyper = |k: usize| {
            let h = n * q + 3 * k;
            Hyper::from_log([p[h], p[h + 1], p[h + 2]])
        };
        let model =
            Self { q, labelled: l, x_norm, y_norm, z: p[..n * q].to_vec(), hyper_x: hyper(0), hyper_y: hyper(1), x, y };
        Ok((model, info))
    }
}

/// The root mean square of consecutive frames' per-dimension differences within each run
/// of `runs` (row ranges of `v`, `d` values per row): the size of one frame's step, what
/// the temporal term's $\sigma_t$ is set from. 0 when no run has two frames.
pub fn step_rms(v: &[f64], d: usize, runs: &[std::ops::Range<usize>]) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for r in runs.iter().filter(|r| r.len() > 1) {
        for i in r.start + 1..r.end {
            sum +=
                v[i * d..(i + 1) * d].iter().zip(&v[(i - 1) * d..i * d]).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            count += d;
        }
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f64).sqrt()
    }
}

/// The temporal term's $\sigma_t$ from the capture's RMS step `step` between consecutive
/// frames and its noise $\sigma_c$. A step of noisy observations has variance
/// $s^2 = \delta^2 + 2\sigma_c^2$ ($\delta$ the true motion's step); the term compares a
/// frame with the previous frame's *estimate* $x^*_{k-1}$, whose own error is at most
/// $\sigma_c^2$, so $\sigma_t^2 = \delta^2 + \sigma_c^2 = s^2 - \sigma_c^2$, kept at least
/// $s^2/100$ (a capture whose steps are all noise still moves); 0 (no temporal term) when
/// `step` is 0.
pub fn temporal_noise(step: f64, capture: f64) -> f64 {
    (step * step - capture * capture).max(1e-2 * step * step).sqrt()
}

/// One mapped frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Mapped {
    /// The target (its own units): the target GP's mean at $z^*$.
    pub y: Vec<f64>,
    /// $x^*$, normalised: what the next frame's temporal term reads.
    pub x: Vec<f64>,
    /// $z^*$.
    pub z: Vec<f64>,
    /// $\sigma_p^2(z^*)$, normalised source units².
    pub variance: f64,
    /// RMS over the seen dimensions of $\tilde x - x^*$, source units.
    pub residual: f64,
}

/// A model ready to map frames.
pub struct Mapper<'m> {
    model: &'m Model,
    source: SourceGp,
    target: MeanPredictor,
    noise: Noise,
}

impl<'m> Mapper<'m> {
    /// The mapper of `model`, with the capture noise $\sigma_c$ and the temporal
    /// $\sigma_t$ in source units (converted to normalised units here).
    ///
    /// # Errors
    /// A kernel that will not factor; a non-positive capture noise, a negative or
    /// non-finite temporal one. A temporal noise of 0 turns the temporal term off (a
    /// capture without two consecutive frames has no step to set it from).
    pub fn new(model: &'m Model, noise: Noise) -> Result<Self, GplvmError> {
        let finite = noise.capture.is_finite() && noise.temporal.is_finite();
        if !(finite && noise.capture > 0.0 && noise.temporal >= 0.0) {
            return Err(GplvmError::Shape(format!("noise levels must be positive (σt may be 0: off): {noise:?}")));
        }
        let s = model.x_norm.scale;
        let source = SourceGp::new(&model.source(), &model.z, model.q, model.hyper_x)?;
        let target = predictor(&model.target(), &model.z, model.q, model.hyper_y)?;
        Ok(Self { model, source, target, noise: Noise { capture: noise.capture / s, temporal: noise.temporal / s } })
    }

    /// Maps one frame: `observed` in source units (`seen[d]` false for a missing dimension,
    /// whose value is ignored), `previous` the last frame's [`Mapped::x`] (none at a clip's
    /// start). The solve starts at the observation (missing dimensions at the nearest
    /// training frame's values) with $z$ at that frame's latent, as the paper does.
    pub fn map(&self, observed: &[f64], seen: &[bool], previous: Option<&[f64]>) -> Mapped {
        let m = self.model;
        let dx = m.dx();
        let obs = m.x_norm.apply(observed);
        let d2 = |r: usize| {
            m.x[r * dx..(r + 1) * dx]
                .iter()
                .zip(&obs)
                .zip(seen)
                .filter(|(_, &s)| s)
                .map(|((a, b), _)| (a - b) * (a - b))
                .sum::<f64>()
        };
        let near = (0..m.source_rows()).min_by(|&a, &b| d2(a).total_cmp(&d2(b))).unwrap_or(0);
        let mut start: Vec<f64> =
            obs.iter().zip(seen).enumerate().map(|(d, (&v, &s))| if s { v } else { m.x[near * dx + d] }).collect();
        start.extend_from_slice(&m.z[near * m.q..(near + 1) * m.q]);
        let previous = previous.filter(|_| self.noise.temporal > 0.0);
        let f = self.source.solve(&start, &obs, seen, previous, self.noise);
        let mut y = vec![0.0; m.dy()];
        self.target.mean(&f.z, &mut y);
        let seen_count = seen.iter().filter(|&&s| s).count().max(1);
        let sq: f64 = f.x.iter().zip(&obs).zip(seen).filter(|(_, &s)| s).map(|((a, b), _)| (a - b) * (a - b)).sum();
        Mapped {
            y: m.y_norm.invert(&y),
            residual: (sq / seen_count as f64).sqrt() * m.x_norm.scale,
            variance: f.variance,
            x: f.x,
            z: f.z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hidden 1-D performance seen by a 4-D source and a 2-D target (both in units far
    /// from 1, so the normalisation matters).
    fn spaces(t: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let x = t.iter().flat_map(|&s| [s.sin() * 0.01, s.cos() * 0.01, 0.003 * s, 0.02]).collect();
        let y = t.iter().flat_map(|&s| [40.0 * (s * s - 0.5), 10.0 + 5.0 * (1.5 * s).cos()]).collect();
        (x, y)
    }

    #[test]
    fn the_normalisation_round_trips_and_uses_the_largest_deviation() {
        let v = [1.0, 10.0, 3.0, 10.0, 5.0, 10.0];
        let a = Affine::fit(&v, 2);
        assert_eq!(a.mean, vec![3.0, 10.0]);
        assert!((a.scale - (8.0f64 / 3.0).sqrt()).abs() < 1e-12);
        let back = a.invert(&a.apply(&v));
        assert!(back.iter().zip(v).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn the_step_rms_is_the_consecutive_difference_within_runs() {
        // Two runs of a 1-D ramp with step 2; the jump between runs is not a step.
        let v = [0.0, 2.0, 4.0, 100.0, 102.0];
        assert!((step_rms(&v, 1, &[0..3, 3..5]) - 2.0).abs() < 1e-12);
        assert_eq!(step_rms(&v, 1, std::slice::from_ref(&(0..1))), 0.0);
    }

    #[test]
    fn the_temporal_noise_takes_the_capture_noise_out_of_the_step() {
        assert!((temporal_noise(5.0, 3.0) - 4.0).abs() < 1e-12);
        assert!((temporal_noise(1.0, 1.0) - 0.1).abs() < 1e-12, "all noise: kept at a tenth of the step");
        assert_eq!(temporal_noise(0.0, 1.0), 0.0, "no step: no temporal term");
    }

    #[test]
    fn a_model_maps_unseen_frames_and_fills_a_missing_dimension() {
        // 5 labelled pairs, then the other frames alternately source-only (18) and
        // target-only (17).
        let t: Vec<f64> = (0..40).map(|i| -1.2 + 2.4 * f64::from(i) / 39.0).collect();
        let (x, _) = spaces(&t);
        let labelled: Vec<usize> = (0..40).step_by(8).collect();
        let rest: Vec<usize> = (0..40).filter(|i| !labelled.contains(i)).collect();
        let pick = |v: &[f64], d: usize, idx: &[usize]| -> Vec<f64> {
            idx.iter().flat_map(|&r| v[r * d..(r + 1) * d].iter().copied()).collect()
        };
        let (_, y) = spaces(&t);
        let (src, tgt): (Vec<usize>, Vec<usize>) = rest.iter().partition(|&&i| i % 2 == 0);
        let xs = [pick(&x, 4, &labelled), pick(&x, 4, &src)].concat();
        let ys = [pick(&y, 2, &labelled), pick(&y, 2, &tgt)].concat();
        let set = TrainingSet { x: &xs, dx: 4, y: &ys, dy: 2, labelled: labelled.len() };
        let settings =
            Settings { q: 2, k: 4, prior: Prior::Lle, init: Init::Alignment, capture_noise: 0.0, max_iters: 300 };
        let (model, info) = Model::fit(&set, &settings).unwrap();
        assert!(info.value.is_finite());
        assert_eq!(model.n(), 5 + 18 + 17);
        let mapper = Mapper::new(&model, Noise { capture: 1e-4, temporal: 1.0 }).unwrap();
        // Frames between the training latents, in the target's units.
        let probe: Vec<f64> = (0..9).map(|i| -1.0 + 2.0 * f64::from(i) / 8.0 + 0.013).collect();
        let (px, py) = spaces(&probe);
        let mut sq = 0.0;
        for (o, truth) in px.chunks_exact(4).zip(py.chunks_exact(2)) {
            let m = mapper.map(o, &[true; 4], None);
            assert!(m.residual < 1e-3, "the solve stays near the observation: {}", m.residual);
            sq += m.y.iter().zip(truth).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        }
        let rms = (sq / 18.0).sqrt();
        // Against the probes' own spread about their mean (what predicting the mean scores).
        let mean = [0, 1].map(|j| py.chunks_exact(2).map(|r| r[j]).sum::<f64>() / 9.0);
        let spread = (py.chunks_exact(2).map(|r| (r[0] - mean[0]).powi(2) + (r[1] - mean[1]).powi(2)).sum::<f64>()
            / 18.0)
            .sqrt();
        assert!(rms < 0.4 * spread, "target RMS {rms}, spread {spread}");
        // The second source dimension missing: filled in from the manifold.
        let o = &px[4 * 4..5 * 4];
        let garbage = [o[0], 7.0, o[2], o[3]];
        let m = mapper.map(&garbage, &[true, false, true, true], None);
        let filled = model.x_norm.invert(&m.x)[1];
        assert!((filled - o[1]).abs() < 2e-3, "filled {filled} vs {}", o[1]);
    }

    #[test]
    fn too_few_labels_and_bad_shapes_are_errors() {
        let (x, y) = spaces(&[0.0, 0.5, 1.0]);
        let set = TrainingSet { x: &x, dx: 4, y: &y, dy: 2, labelled: 1 };
        let s = Settings { q: 2, k: 2, prior: Prior::None, init: Init::Pca, capture_noise: 0.0, max_iters: 10 };
        assert!(Model::fit(&set, &s).unwrap_err().to_string().contains("at least 2"));
        let set = TrainingSet { x: &x[..7], dx: 4, y: &y, dy: 2, labelled: 2 };
        assert!(Model::fit(&set, &s).is_err());
    }
}
