//! The regression's training set (Holden et al. 2017, §4.2, Eq. 7–12): the rest pose, then
//! the pose farthest from every pose taken (in position space) `farthest` times, then,
//! until `total` are taken, the poses the regression fitted to those taken gets most wrong
//! (in control space).
//!
//! **Deviation, for cost:** the paper refits after every pose added by error; here `batch`
//! poses of largest error are added per refit (`batch = 1` is the paper's rule). Each refit
//! costs $O(m^3 + (n - m)\,m\,(d + c))$ for $m$ taken of $n$.

use crate::error::{check_table, InvrigError, Result};
use crate::gpr::{gather, Gpr};

/// How many poses [`subsample`] takes, and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubsampleSettings {
    /// Poses taken by distance after the rest pose (Eq. 7–9).
    pub farthest: usize,
    /// Poses taken in all (at most the rows there are).
    pub total: usize,
    /// Poses added per refit in the error phase (Eq. 10–12; the paper's is 1).
    pub batch: usize,
    /// The regression's $\theta_0$.
    pub theta0: f64,
    /// The regression's $\theta_1$.
    pub theta1: f64,
}

/// The rows taken, in the order taken; row `rest` first.
///
/// # Errors
/// As [`Gpr::fit`] for the tables; [`InvrigError::Param`] for a `rest` row out of range or
/// a zero `batch`.
pub fn subsample(x: &[f64], d: usize, y: &[f64], c: usize, rest: usize, s: &SubsampleSettings) -> Result<Vec<usize>> {
    let n = x.len().checked_div(d).unwrap_or(0);
    check_table("positions", x, n, d)?;
    check_table("controls", y, n, c)?;
    if rest >= n {
        return Err(InvrigError::Param { name: "rest", value: rest as f64, why: "must name a row of the data" });
    }
    if s.batch == 0 {
        return Err(InvrigError::Param { name: "batch", value: 0.0, why: "must be at least 1" });
    }
    let total = s.total.clamp(1, n);
    let row = |i: usize| &x[i * d..(i + 1) * d];
    let mut taken = vec![rest];
    let mut is_taken = vec![false; n];
    is_taken[rest] = true;
    // Eq. 7–9: the nearest taken pose's squared distance, per row.
    let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>();
    let mut nearest: Vec<f64> = (0..n).map(|i| d2(row(i), row(rest))).collect();
    while taken.len() < total.min(1 + s.farthest) {
        let Some(far) =
            (0..n).filter(|&i| !is_taken[i]).max_by(|&a, &b| nearest[a].total_cmp(&nearest[b]).then(b.cmp(&a)))
        else {
            break;
        };
        taken.push(far);
        is_taken[far] = true;
        for (i, m) in nearest.iter_mut().enumerate() {
            *m = m.min(d2(row(i), row(far)));
        }
    }
    // Eq. 10–12: the largest errors of the regression on what is taken.
    let mut pred = vec![0.0; c];
    while taken.len() < total {
        let g = Gpr::fit(&gather(x, d, &taken), d, &gather(y, c, &taken), c, s.theta0, s.theta1)?;
        let mut errors: Vec<(f64, usize)> = Vec::with_capacity(n - taken.len());
        for i in (0..n).filter(|&i| !is_taken[i]) {
            g.predict_into(row(i), &mut pred)?;
            errors.push((d2(&pred, &y[i * c..(i + 1) * c]), i));
        }
        // Largest error first, lower row on ties.
        errors.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for &(_, i) in errors.iter().take(s.batch.min(total - taken.len())) {
            taken.push(i);
            is_taken[i] = true;
        }
    }
    Ok(taken)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-D curve of 60 points with 2 controls each.
    fn curve() -> (Vec<f64>, Vec<f64>) {
        let ts: Vec<f64> = (0..60).map(|i| i as f64 / 59.0 * 6.0).collect();
        let x = ts.iter().flat_map(|&t| [t.cos() * (1.0 + 0.1 * t), t.sin()]).collect();
        let y = ts.iter().flat_map(|&t| [t, (3.0 * t).sin()]).collect();
        (x, y)
    }

    fn settings(farthest: usize, total: usize, batch: usize) -> SubsampleSettings {
        SubsampleSettings { farthest, total, batch, theta0: 0.2, theta1: 1e-6 }
    }

    /// The rest pose first, then the farthest-point rule by hand, no row twice.
    #[test]
    fn rest_then_farthest_points() {
        let (x, y) = curve();
        let got = subsample(&x, 2, &y, 2, 0, &settings(3, 4, 1)).unwrap();
        assert_eq!(got[0], 0);
        let mut taken = vec![0usize];
        for _ in 0..3 {
            let far = (0..60)
                .filter(|i| !taken.contains(i))
                .max_by(|&a, &b| {
                    let m = |i: usize| {
                        taken
                            .iter()
                            .map(|&t| (x[2 * i] - x[2 * t]).hypot(x[2 * i + 1] - x[2 * t + 1]))
                            .fold(f64::INFINITY, f64::min)
                    };
                    m(a).total_cmp(&m(b))
                })
                .unwrap();
            taken.push(far);
        }
        assert_eq!(got, taken);
    }

    /// The error phase with batch 1 adds, each time, the row the regression on what is
    /// taken gets most wrong; a larger batch takes distinct rows and stops at the total.
    #[test]
    fn then_the_largest_errors() {
        let (x, y) = curve();
        let got = subsample(&x, 2, &y, 2, 5, &settings(2, 8, 1)).unwrap();
        assert_eq!(got.len(), 8);
        for k in 3..8 {
            let before = &got[..k];
            let gx: Vec<f64> = before.iter().flat_map(|&r| x[2 * r..2 * r + 2].to_vec()).collect();
            let gy: Vec<f64> = before.iter().flat_map(|&r| y[2 * r..2 * r + 2].to_vec()).collect();
            let g = Gpr::fit(&gx, 2, &gy, 2, 0.2, 1e-6).unwrap();
            let err = |i: usize| {
                let p = g.predict(&x[2 * i..2 * i + 2]).unwrap();
                (p[0] - y[2 * i]).powi(2) + (p[1] - y[2 * i + 1]).powi(2)
            };
            let worst = (0..60).filter(|i| !before.contains(i)).max_by(|&a, &b| err(a).total_cmp(&err(b))).unwrap();
            assert_eq!(got[k], worst, "step {k}");
        }
        let batched = subsample(&x, 2, &y, 2, 5, &settings(2, 20, 4)).unwrap();
        let mut uniq = batched.clone();
        uniq.sort_unstable();
        uniq.dedup();
        assert_eq!((batched.len(), uniq.len()), (20, 20));
        // More than there are rows: every row once.
        assert_eq!(subsample(&x, 2, &y, 2, 0, &settings(100, 500, 50)).unwrap().len(), 60);
    }

    #[test]
    fn bad_settings_are_errors() {
        let (x, y) = curve();
        assert!(subsample(&x, 2, &y, 2, 60, &settings(2, 5, 1)).unwrap_err().to_string().contains("rest"));
        assert!(subsample(&x, 2, &y, 2, 0, &settings(2, 5, 0)).unwrap_err().to_string().contains("batch"));
        assert!(subsample(&x, 2, &y[..10], 2, 0, &settings(2, 5, 1)).is_err());
    }
}
