//! The paper's comparison (Bouaziz and Pauly §3, the protocol A): source frames
//! with known targets, a blocked split (the training block's frames are labelled or left
//! unlabelled; the test block's are mapped), and for each label count the RMS target error
//! of every method over random draws of which frames are labelled.
//!
//! Each space is centred and divided by its largest per-dimension standard deviation before
//! the GP methods see it (the paper's implementation note); predictions are mapped back.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use reprise_numerics::gplvm::{GplvmError, LikelihoodConfig};
use reprise_numerics::lbfgs::LbfgsOptions;

use crate::align::{align, denoise};
use crate::baselines::{gpr, Ridge};
use crate::lle;
use crate::shared::{fit, initial_latents, predictor, SharedObjective, Space};
use crate::source::{Noise, SourceGp};

/// A way to map source frames to targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Ridge regression on the labelled pairs.
    Ridge,
    /// GPR on the labelled pairs.
    Gpr,
    /// A shared GPLVM on the labelled pairs alone.
    SharedGplvm,
    /// The shared GPLVM with unlabelled frames of both spaces.
    SemiSupervised,
    /// The semi-supervised GPLVM with the LLE prior (the paper's method).
    SemiSupervisedLle,
}

impl Method {
    /// Every method, in the paper's order.
    pub const ALL: [Method; 5] =
        [Method::Ridge, Method::Gpr, Method::SharedGplvm, Method::SemiSupervised, Method::SemiSupervisedLle];
}

/// How the comparison is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Label counts to measure.
    pub labels: Vec<usize>,
    /// Random draws per label count.
    pub draws: usize,
    /// Unlabelled frames of each space (semi-supervised methods).
    pub unlabelled: usize,
    /// Latent dimension.
    pub q: usize,
    /// LLE neighbours.
    pub k: usize,
    /// Ridge penalty (in the normalised units).
    pub alpha: f64,
    /// The per-frame solve's noise levels (normalised units), used where
    /// [`Config::capture_noise`] and [`Config::temporal_from_data`] do not set them.
    pub noise: Noise,
    /// The capture system's noise, a standard deviation per source value in *source* units
    /// (the paper fixes $\sigma_c$ from it): $\sigma_c$ = this / the source's scale.
    pub capture_noise: Option<f64>,
    /// Whether $\sigma_t$ is estimated from the training block (see [`noise_levels`]).
    pub temporal_from_data: bool,
    /// How the shared GPLVM's latents start.
    pub init: Init,
    /// Whether the GPLVM methods without the LLE prior get the unit Gaussian prior
    /// $\tfrac12\lVert Z\rVert^2$ (the LLE prior's $L = M^\top M + I$ with $M = 0$).
    pub gaussian_prior: bool,
    /// L-BFGS iterations of a shared GPLVM fit.
    pub max_iters: usize,
    /// Seed of the draws.
    pub seed: u64,
}

/// The start of the shared GPLVM's latents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Init {
    /// Source principal coordinates, target-only rows at their nearest labelled row
    /// ([`initial_latents`]).
    Pca,
    /// Semi-supervised manifold alignment with the LLE's `k` ([`crate::align::align`]), the
    /// paper's.
    Alignment,
}

/// One method at one label count.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The method.
    pub method: Method,
    /// Labelled pairs.
    pub labels: usize,
    /// Mean over draws of the RMS target error (target units).
    pub rms: f64,
}

/// A table of `n` rows of `d` values, centred and scaled.
struct Normalised {
    data: Vec<f64>,
    dim: usize,
    mean: Vec<f64>,
    scale: f64,
}

fn normalise(v: &[f64], d: usize) -> Normalised {
    let n = (v.len() / d).max(1) as f64;
    let mean: Vec<f64> = (0..d).map(|j| v.chunks_exact(d).map(|r| r[j]).sum::<f64>() / n).collect();
    let var =
        (0..d).map(|j| v.chunks_exact(d).map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>() / n).fold(0.0f64, f64::max);
    let scale = if var > 0.0 { var.sqrt() } else { 1.0 };
    let data = v.chunks_exact(d).flat_map(|r| r.iter().zip(&mean).map(|(a, m)| (a - m) / scale)).collect();
    Normalised { data, dim: d, mean, scale }
}

fn rows(v: &[f64], d: usize, idx: &[usize]) -> Vec<f64> {
    idx.iter().flat_map(|&r| v[r * d..(r + 1) * d].iter().copied()).collect()
}

/// The per-frame solve's noise levels in normalised units, for a source `x` (`n × dx`)
/// whose normalisation divides by `scale`:
///
/// - $\sigma_c$ = `cfg.capture_noise / scale` when the capture noise is known;
/// - $\sigma_t$, when `cfg.temporal_from_data`, from the consecutive frames of the training
///   block: their mean squared difference per value, $s^2 = \frac{1}{(T-1)d_x}
///   \sum_k \lVert x_k - x_{k-1}\rVert^2$, holds the motion's and twice the capture noise's
///   variance, so $\sigma_t^2 = s^2 - 2\sigma_c^2$, the motion between denoised frames
///   (floored at $s^2/100$ should the stated noise explain all the differences).
pub fn noise_levels(x: &[f64], dx: usize, scale: f64, train: std::ops::Range<usize>, cfg: &Config) -> Noise {
    let capture = cfg.capture_noise.map_or(cfg.noise.capture, |c| c / scale);
    let temporal = if cfg.temporal_from_data && train.len() >= 2 {
        let sq: f64 = train
            .clone()
            .skip(1)
            .map(|k| {
                x[k * dx..(k + 1) * dx]
                    .iter()
                    .zip(&x[(k - 1) * dx..k * dx])
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
            })
            .sum();
        let s2 = sq / ((train.len() - 1) * dx) as f64 / (scale * scale);
        (s2 - 2.0 * capture * capture).max(1e-2 * s2).sqrt()
    } else {
        cfg.noise.temporal
    };
    Noise { capture, temporal }
}

/// The source's normalisation scale (its largest per-value standard deviation), as
/// [`compare`] uses it.
pub fn source_scale(x: &[f64], dx: usize) -> f64 {
    normalise(x, dx).scale
}

/// Runs the comparison on source `x` (`n × dx`) and target `y` (`n × dy`), training block
/// `train`, test block `test` (row ranges of both).
///
/// # Errors
/// A label count plus twice the unlabelled count larger than the training block; the fits'
/// errors.
pub fn compare(
    x: &[f64],
    dx: usize,
    y: &[f64],
    dy: usize,
    train: std::ops::Range<usize>,
    test: std::ops::Range<usize>,
    cfg: &Config,
) -> Result<Vec<Row>, GplvmError> {
    let (nx, ny) = (normalise(x, dx), normalise(y, dy));
    let noise = noise_levels(x, dx, nx.scale, train.clone(), cfg);
    let test_rows: Vec<usize> = test.collect();
    let truth = rows(y, dy, &test_rows);
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut out = Vec::new();
    for &l in &cfg.labels {
        if l + 2 * cfg.unlabelled > train.len() || l < 2 {
            return Err(GplvmError::Shape(format!(
                "{l} labels and 2 × {} unlabelled frames need more than the {} training frames (and at least 2 labels)",
                cfg.unlabelled,
                train.len()
            )));
        }
        let mut sums = vec![0.0; Method::ALL.len()];
        for _ in 0..cfg.draws {
            let mut pool: Vec<usize> = train.clone().collect();
            pool.shuffle(&mut rng);
            let labelled = &pool[..l];
            let src_only = &pool[l..l + cfg.unlabelled];
            let tgt_only = &pool[l + cfg.unlabelled..l + 2 * cfg.unlabelled];
            for (m, method) in Method::ALL.into_iter().enumerate() {
                let pred = predict(method, &nx, &ny, (labelled, src_only, tgt_only), &test_rows, noise, cfg)?;
                let denorm: Vec<f64> = pred
                    .chunks_exact(dy)
                    .flat_map(|r| r.iter().zip(&ny.mean).map(|(a, mu)| a * ny.scale + mu).collect::<Vec<_>>())
                    .collect();
                let sq: f64 = denorm.iter().zip(&truth).map(|(a, b)| (a - b) * (a - b)).sum();
                sums[m] += (sq / truth.len() as f64).sqrt();
            }
        }
        out.extend(Method::ALL.into_iter().zip(&sums).map(|(method, s)| Row {
            method,
            labels: l,
            rms: s / cfg.draws as f64,
        }));
    }
    Ok(out)
}

/// Normalised target predictions of the test rows by one method.
fn predict(
    method: Method,
    nx: &Normalised,
    ny: &Normalised,
    (labelled, src_only, tgt_only): (&[usize], &[usize], &[usize]),
    test: &[usize],
    noise: Noise,
    cfg: &Config,
) -> Result<Vec<f64>, GplvmError> {
    let (dx, dy) = (nx.dim, ny.dim);
    let xl = rows(&nx.data, dx, labelled);
    let yl = rows(&ny.data, dy, labelled);
    let xt = rows(&nx.data, dx, test);
    match method {
        Method::Ridge => {
            let r = Ridge::fit(&xl, dx, &yl, dy, cfg.alpha)?;
            Ok(xt.chunks_exact(dx).flat_map(|x| r.predict(x)).collect())
        }
        Method::Gpr => {
            let g = gpr(&xl, dx, &yl, dy)?;
            let mut out = vec![0.0; test.len() * dy];
            for (x, o) in xt.chunks_exact(dx).zip(out.chunks_exact_mut(dy)) {
                g.mean(x, o);
            }
            Ok(out)
        }
        _ => {
            let (s, t) = if method == Method::SharedGplvm { (&[][..], &[][..]) } else { (src_only, tgt_only) };
            let l = labelled.len();
            let n = l + s.len() + t.len();
            let x_rows: Vec<usize> = (0..l + s.len()).collect();
            let y_rows: Vec<usize> = (0..l).chain(l + s.len()..n).collect();
            let xs = [xl.clone(), rows(&nx.data, dx, s)].concat();
            let ys = [yl.clone(), rows(&ny.data, dy, t)].concat();
            let source = Space { data: &xs, dim: dx, rows: x_rows.clone() };
            let target = Space { data: &ys, dim: dy, rows: y_rows.clone() };
            let q = cfg.q.min(dx).min(l + s.len() - 1).max(1);
            let k = cfg.k.min(x_rows.len() - 1).min(y_rows.len() - 1).max(1);
            let prior = if method == Method::SemiSupervisedLle {
                let wx = lle::weights(&xs, dx, k).map_err(|e| GplvmError::Shape(e.to_string()))?;
                let wy = lle::weights(&ys, dy, k).map_err(|e| GplvmError::Shape(e.to_string()))?;
                Some(lle::prior_matrix(&[(&wx, &x_rows), (&wy, &y_rows)], n))
            } else {
                cfg.gaussian_prior.then(|| faer::Mat::<f64>::identity(n, n))
            };
            let mut obj =
                SharedObjective::new(&[source.clone(), target.clone()], n, q, prior, LikelihoodConfig::default())?;
            let mut start = match cfg.init {
                Init::Pca => initial_latents(&source, &target, n, q)?,
                Init::Alignment => {
                    // The source's neighbourhoods without the capture noise (when it is known).
                    let clean = match cfg.capture_noise {
                        Some(_) => denoise(&xs, dx, noise.capture * noise.capture)?,
                        None => xs.clone(),
                    };
                    align(&[Space { data: &clean, ..source.clone() }, target.clone()], n, q, k)?
                }
            };
            start.extend([0.0, 0.0, (1e-2f64).ln(), 0.0, 0.0, (1e-2f64).ln()]);
            let (p, _) = fit(&mut obj, &start, &LbfgsOptions { max_iters: cfg.max_iters, ..LbfgsOptions::default() });
            let hyper = |k: usize| {
                let h = n * q + 3 * k;
                reprise_numerics::gplvm::Hyper::from_log([p[h], p[h + 1], p[h + 2]])
            };
            let z = &p[..n * q];
            let gp = SourceGp::new(&source, z, q, hyper(0))?;
            let tp = predictor(&target, z, q, hyper(1))?;
            let mut out = vec![0.0; test.len() * dy];
            let mut previous: Option<Vec<f64>> = None;
            for (x, o) in xt.chunks_exact(dx).zip(out.chunks_exact_mut(dy)) {
                // The paper's start: x at the observation, z at the nearest training source frame's latent.
                let d2 = |r: usize| xs[r * dx..(r + 1) * dx].iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
                let near = x_rows.iter().copied().min_by(|&a, &b| d2(a).total_cmp(&d2(b))).unwrap_or(0);
                let start = [x, &z[near * q..(near + 1) * q]].concat();
                let f = gp.solve(&start, x, &vec![true; dx], previous.as_deref(), noise);
                tp.mean(&f.z, o);
                previous = Some(f.x);
            }
            Ok(out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_maps_a_smooth_correspondence_and_the_gp_methods_beat_ridge() {
        // A hidden 1-D performance: the source sees it through a curve in 4-D, the target
        // through another in 2-D; 60 frames, the first 40 to train on, the last 20 mapped.
        let t: Vec<f64> = (0..60).map(|i| (f64::from(i) * 0.37).sin() * 1.5).collect();
        let x: Vec<f64> = t.iter().flat_map(|&s| [s.sin(), s.cos(), 0.3 * s, (2.0 * s).sin() * 0.2]).collect();
        let y: Vec<f64> = t.iter().flat_map(|&s| [s * s - 0.5, (1.5 * s).cos()]).collect();
        let cfg = Config {
            labels: vec![8],
            draws: 2,
            unlabelled: 10,
            q: 2,
            k: 4,
            alpha: 1e-3,
            noise: Noise { capture: 0.05, temporal: 10.0 },
            capture_noise: None,
            temporal_from_data: false,
            init: Init::Alignment,
            gaussian_prior: true,
            max_iters: 300,
            seed: 3,
        };
        let rows = compare(&x, 4, &y, 2, 0..40, 40..60, &cfg).unwrap();
        assert_eq!(rows.len(), 5);
        let rms = |m: Method| rows.iter().find(|r| r.method == m).unwrap().rms;
        let spread = 0.6; // about the targets' standard deviation
        for m in Method::ALL {
            assert!(rms(m).is_finite() && rms(m) < spread, "{m:?}: {}", rms(m));
        }
        assert!(rms(Method::Gpr) < rms(Method::Ridge), "GPR {} vs ridge {}", rms(Method::Gpr), rms(Method::Ridge));
        let err = compare(&x, 4, &y, 2, 0..20, 40..60, &Config { labels: vec![8], ..cfg }).unwrap_err();
        assert!(err.to_string().contains("training frames"), "{err}");
    }
}
