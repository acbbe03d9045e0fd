//! Multiquadric Gaussian-process regression (Holden et al. 2017, Eq. 1–6).
//!
//! With training inputs $x_1..x_n$ (positions, $d$ values each) and outputs $Y$ ($n \times
//! c$ controls), the prediction at $x_*$ is
//! $$y_* = K_* (K + \theta_1 I)^{-1} Y,\qquad K_{ij} = k(x_i, x_j),\quad
//! K_{*j} = k(x_*, x_j),\quad k(x, x') = \sqrt{\lVert x - x'\rVert^2 + \theta_0^2}.$$
//! The multiquadric is only *conditionally* positive definite: for distinct points its
//! matrix has one positive eigenvalue and $n - 1$ negative ones, so a Cholesky factorization
//! fails. The weights $A = (K + \theta_1 I)^{-1} Y$ are solved once at fit time with the
//! Bunch–Kaufman $LBL^\top$ factorization (faer's `lblt`), which takes any symmetric
//! nonsingular matrix; a prediction is then $O(n(d + c))$.
//!
//! $\theta_0$ (the "length scale", in the positions' units) is chosen by the paper's line
//! search ([`cross_validate`]): values log-spaced over $[10^{-4}, 10^2]$, each scored by
//! the mean validation error over rounds that train on a random half of the data and
//! predict the other half.

use faer::prelude::Solve;
use faer::{Mat, Side};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::{check_positive, check_table, InvrigError, Result};

/// The paper's Tikhonov term $\theta_1$ ("some very small value such as $10^{-5}$").
pub const DEFAULT_THETA1: f64 = 1e-5;

/// The kernel $\sqrt{\lVert a - b\rVert^2 + \theta_0^2}$.
#[inline]
pub fn multiquadric(a: &[f64], b: &[f64], theta0: f64) -> f64 {
    let d2: f64 = a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum();
    (d2 + theta0 * theta0).sqrt()
}

/// A fitted regression: the training inputs and the weights $A$.
#[derive(Debug, Clone, PartialEq)]
pub struct Gpr {
    x: Vec<f64>,
    d: usize,
    c: usize,
    theta0: f64,
    theta1: f64,
    /// $A = (K + \theta_1 I)^{-1} Y$, $n \times c$ row-major.
    weights: Vec<f64>,
}

impl Gpr {
    /// Fits $n$ rows of inputs `x` ($d$ each) to outputs `y` ($c$ each).
    ///
    /// # Errors
    /// [`InvrigError::Shape`], [`InvrigError::NonFinite`], [`InvrigError::Empty`] for bad
    /// tables; [`InvrigError::Param`] for $\theta_0$ or $\theta_1$ not finite and positive,
    /// or a singular system (two identical inputs with $\theta_1$ too small to separate
    /// them); the message says which.
    pub fn fit(x: &[f64], d: usize, y: &[f64], c: usize, theta0: f64, theta1: f64) -> Result<Self> {
        let n = x.len().checked_div(d).unwrap_or(0);
        check_table("positions", x, n, d)?;
        check_table("controls", y, n, c)?;
        check_positive("theta0", theta0)?;
        check_positive("theta1", theta1)?;
        let row = |i: usize| &x[i * d..(i + 1) * d];
        let k = Mat::from_fn(n, n, |i, j| multiquadric(row(i), row(j), theta0) + if i == j { theta1 } else { 0.0 });
        let mut rhs = Mat::from_fn(n, c, |i, j| y[i * c + j]);
        k.lblt(Side::Lower).solve_in_place(rhs.as_mut());
        let weights: Vec<f64> = (0..n).flat_map(|i| (0..c).map(move |j| (i, j))).map(|(i, j)| rhs[(i, j)]).collect();
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(InvrigError::Param {
                name: "theta1",
                value: theta1,
                why: "the system K + theta1 I is singular (repeated positions?): raise theta1",
            });
        }
        Ok(Self { x: x.to_vec(), d, c, theta0, theta1, weights })
    }

    /// Training rows.
    pub fn len(&self) -> usize {
        self.x.len() / self.d
    }

    /// Whether it has no training rows (never: [`Gpr::fit`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Position values per row, $d$.
    pub fn input_dim(&self) -> usize {
        self.d
    }

    /// Controls per row, $c$.
    pub fn output_dim(&self) -> usize {
        self.c
    }

    /// $\theta_0$.
    pub fn theta0(&self) -> f64 {
        self.theta0
    }

    /// $\theta_1$.
    pub fn theta1(&self) -> f64 {
        self.theta1
    }

    /// $y_*$ for one input `xs` ($d$ values) into `out` ($c$ values).
    ///
    /// # Errors
    /// [`InvrigError::Shape`] / [`InvrigError::NonFinite`] for a bad input or output size.
    pub fn predict_into(&self, xs: &[f64], out: &mut [f64]) -> Result<()> {
        check_table("position", xs, 1, self.d)?;
        if out.len() != self.c {
            return Err(InvrigError::Shape { what: "controls out", expected: self.c, actual: out.len() });
        }
        out.fill(0.0);
        for (xi, wi) in self.x.chunks_exact(self.d).zip(self.weights.chunks_exact(self.c)) {
            let k = multiquadric(xs, xi, self.theta0);
            for (o, w) in out.iter_mut().zip(wi) {
                *o += k * w;
            }
        }
        Ok(())
    }

    /// $y_*$ for `m` inputs (`m × d` row-major): `m × c` controls.
    ///
    /// # Errors
    /// As [`Gpr::predict_into`].
    pub fn predict(&self, xs: &[f64]) -> Result<Vec<f64>> {
        let m = xs.len() / self.d;
        check_table("positions", xs, m, self.d)?;
        let mut out = vec![0.0; m * self.c];
        for (x, o) in xs.chunks_exact(self.d).zip(out.chunks_exact_mut(self.c)) {
            self.predict_into(x, o)?;
        }
        Ok(out)
    }
}

/// Mean over rows of $\lVert a_r - b_r\rVert$ (rows of `cols` values).
pub fn mean_row_distance(a: &[f64], b: &[f64], cols: usize) -> f64 {
    let rows = a.len() / cols;
    let total: f64 = a
        .chunks_exact(cols)
        .zip(b.chunks_exact(cols))
        .map(|(p, q)| p.iter().zip(q).map(|(u, v)| (u - v) * (u - v)).sum::<f64>().sqrt())
        .sum();
    total / rows.max(1) as f64
}

/// Rows `rows` of the row-major table `v` (`cols` values a row), in that order.
pub fn gather(v: &[f64], cols: usize, rows: &[usize]) -> Vec<f64> {
    rows.iter().flat_map(|&r| v[r * cols..(r + 1) * cols].iter().copied()).collect()
}

/// `count` values log-spaced over the paper's range $[10^{-4}, 10^2]$ for $\theta_0$.
pub fn theta0_grid(count: usize) -> Vec<f64> {
    let (lo, hi) = (1e-4f64.ln(), 1e2f64.ln());
    match count {
        0 => Vec::new(),
        1 => vec![1.0],
        _ => (0..count).map(|i| (lo + (hi - lo) * i as f64 / (count - 1) as f64).exp()).collect(),
    }
}

/// The line search's result.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossValidation {
    /// The $\theta_0$ of least mean validation error (the smallest on ties).
    pub theta0: f64,
    /// Every candidate with its mean validation error (control units).
    pub errors: Vec<(f64, f64)>,
}

/// How [`cross_validate`] searches.
#[derive(Debug, Clone, PartialEq)]
pub struct CvSettings {
    /// The candidates for $\theta_0$ ([`theta0_grid`]).
    pub grid: Vec<f64>,
    /// Random half-splits per candidate (the paper: 10).
    pub rounds: usize,
    /// $\theta_1$ of every fit.
    pub theta1: f64,
    /// Seed of the splits.
    pub seed: u64,
}

impl Default for CvSettings {
    fn default() -> Self {
        Self { grid: theta0_grid(25), rounds: 10, theta1: DEFAULT_THETA1, seed: 1 }
    }
}

/// The paper's $\theta_0$ search (§4.1.1): for each candidate, `rounds` times, train on a
/// random half of the rows and score the mean [`mean_row_distance`] of the predictions on
/// the other half; the halves are the same for every candidate (drawn from the seed), so
/// candidates are compared on the same splits.
///
/// # Errors
/// As [`Gpr::fit`]; [`InvrigError::Empty`] for an empty grid, no rounds, or fewer than 4
/// rows (each half needs two).
pub fn cross_validate(x: &[f64], d: usize, y: &[f64], c: usize, cv: &CvSettings) -> Result<CrossValidation> {
    let CvSettings { grid, rounds, theta1, seed } = cv;
    let (rounds, theta1) = (*rounds, *theta1);
    let n = x.len().checked_div(d).unwrap_or(0);
    check_table("positions", x, n, d)?;
    check_table("controls", y, n, c)?;
    if grid.is_empty() || rounds == 0 {
        return Err(InvrigError::Empty("the theta0 grid or the rounds"));
    }
    if n < 4 {
        return Err(InvrigError::Empty("cross-validation needs 4 rows or more"));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(*seed);
    let splits: Vec<Vec<usize>> = (0..rounds)
        .map(|_| {
            let mut idx: Vec<usize> = (0..n).collect();
            idx.shuffle(&mut rng);
            idx
        })
        .collect();
    let mut errors = Vec::with_capacity(grid.len());
    for &theta0 in grid.iter() {
        let mut total = 0.0;
        for idx in &splits {
            let (train, test) = idx.split_at(n / 2);
            let g = Gpr::fit(&gather(x, d, train), d, &gather(y, c, train), c, theta0, theta1)?;
            let pred = g.predict(&gather(x, d, test))?;
            total += mean_row_distance(&pred, &gather(y, c, test), c);
        }
        errors.push((theta0, total / rounds as f64));
    }
    let best = errors.iter().copied().fold((f64::NAN, f64::INFINITY), |b, e| if e.1 < b.1 { e } else { b });
    Ok(CrossValidation { theta0: best.0, errors })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a line, `f` of each.
    fn samples(xs: &[f64], f: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        (xs.to_vec(), xs.iter().map(|&x| f(x)).collect())
    }

    /// The multiquadric matrix of distinct points is indefinite (a Cholesky factorization
    /// fails on it), and the fit still interpolates its training points.
    #[test]
    fn an_indefinite_kernel_matrix_is_solved_and_interpolates() {
        let xs: Vec<f64> = (0..12).map(|i| i as f64 * 0.25).collect();
        let (x, y) = samples(&xs, f64::sin);
        let k = Mat::from_fn(12, 12, |i, j| multiquadric(&x[i..=i], &x[j..=j], 0.5));
        assert!(k.llt(Side::Lower).is_err(), "the multiquadric matrix is not positive definite");
        let g = Gpr::fit(&x, 1, &y, 1, 0.5, 1e-10).unwrap();
        let back = g.predict(&x).unwrap();
        for (p, t) in back.iter().zip(&y) {
            assert!((p - t).abs() < 1e-6, "{p} vs {t}");
        }
    }

    /// Between the samples of a smooth function the prediction is close to it.
    #[test]
    fn interpolates_a_smooth_function_between_samples() {
        let xs: Vec<f64> = (0..=20).map(|i| i as f64 * 0.15).collect();
        let (x, y) = samples(&xs, |t| t.sin() + 0.5 * t);
        let g = Gpr::fit(&x, 1, &y, 1, 0.1, DEFAULT_THETA1).unwrap();
        for (i, x0) in xs.iter().take(20).enumerate() {
            let t = x0 + 0.075;
            let err = (g.predict(&[t]).unwrap()[0] - (t.sin() + 0.5 * t)).abs();
            // Without a polynomial term the ends are the weakest (about 1.4e-2 there).
            let bound = if (2..18).contains(&i) { 1e-3 } else { 2e-2 };
            assert!(err < bound, "at {t}: error {err}");
        }
    }

    /// Several outputs are regressed independently with the same weights' solve: each
    /// column equals a fit of that column alone.
    #[test]
    fn outputs_are_independent_columns() {
        let x: Vec<f64> = (0..10).flat_map(|i| [i as f64 * 0.3, (i as f64 * 0.7).cos()]).collect();
        let y: Vec<f64> = (0..10).flat_map(|i| [i as f64, (i * i) as f64 * 0.1, -(i as f64)]).collect();
        let both = Gpr::fit(&x, 2, &y, 3, 0.3, DEFAULT_THETA1).unwrap();
        let q = [0.45, 0.2];
        let p = both.predict(&q).unwrap();
        for col in 0..3 {
            let yc: Vec<f64> = y.chunks(3).map(|r| r[col]).collect();
            let one = Gpr::fit(&x, 2, &yc, 1, 0.3, DEFAULT_THETA1).unwrap().predict(&q).unwrap()[0];
            assert!((one - p[col]).abs() < 1e-9, "column {col}: {one} vs {}", p[col]);
        }
    }

    /// The line search finds a length scale no worse than the grid's ends, and its error is
    /// the grid's least.
    #[test]
    fn cross_validation_picks_the_least_error() {
        let xs: Vec<f64> = (0..40).map(|i| i as f64 * 0.1).collect();
        let (x, y) = samples(&xs, |t| (2.0 * t).sin());
        let grid = theta0_grid(13);
        assert_eq!(grid.len(), 13);
        assert!((grid[0] - 1e-4).abs() < 1e-12 && (grid[12] - 100.0).abs() < 1e-9);
        let settings = CvSettings { grid, rounds: 5, theta1: DEFAULT_THETA1, seed: 7 };
        let cv = cross_validate(&x, 1, &y, 1, &settings).unwrap();
        let least = cv.errors.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
        let chosen = cv.errors.iter().find(|e| e.0 == cv.theta0).unwrap().1;
        assert_eq!(chosen, least);
        assert!(chosen < cv.errors[12].1, "{:?}", cv.errors);
        // The same seed gives the same answer.
        assert_eq!(cross_validate(&x, 1, &y, 1, &settings).unwrap(), cv);
    }

    #[test]
    fn bad_input_is_a_clear_error() {
        let e = Gpr::fit(&[0.0, 1.0, f64::NAN], 1, &[0.0, 1.0, 2.0], 1, 1.0, 1e-5).unwrap_err();
        assert_eq!(e.to_string(), "positions: row 2, column 0 is NaN (values must be finite)");
        let e = Gpr::fit(&[0.0, 1.0], 1, &[0.0, 1.0, 2.0], 1, 1.0, 1e-5).unwrap_err();
        assert!(e.to_string().starts_with("controls: expected 2 values, got 3"), "{e}");
        assert!(Gpr::fit(&[], 1, &[], 1, 1.0, 1e-5).is_err());
        assert!(Gpr::fit(&[0.0, 1.0], 1, &[0.0, 1.0], 1, 0.0, 1e-5).unwrap_err().to_string().contains("theta0"));
        let g = Gpr::fit(&[0.0, 1.0], 1, &[0.0, 1.0], 1, 1.0, 1e-5).unwrap();
        assert!(g.predict(&[0.0, 1.0, 2.0]).is_ok());
        assert!(g.predict_into(&[0.5], &mut [0.0, 0.0]).is_err());
        assert!(cross_validate(&[0.0, 1.0], 1, &[0.0, 1.0], 1, &CvSettings::default()).is_err());
    }
}
