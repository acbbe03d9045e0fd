//! Test helpers: seeded random problems and finite differences.

use rand::{Rng, SeedableRng};

/// A latent `X` (N × q, entries in ±1.5) and data `Y` (N × d) that is a smooth function
/// of `X` plus a little noise, centred per column.
pub(crate) fn random_problem(n: usize, d: usize, q: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let x: Vec<f64> = (0..n * q).map(|_| rng.gen_range(-1.5..1.5)).collect();
    let w: Vec<f64> = (0..q * d).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let mut y: Vec<f64> = (0..n * d)
        .map(|idx| {
            let (i, j) = (idx / d, idx % d);
            let s: f64 = (0..q).map(|k| x[i * q + k] * w[k * d + j]).sum();
            (1.3 * s + j as f64).sin() + 0.05 * rng.gen_range(-1.0..1.0)
        })
        .collect();
    for j in 0..d {
        let m = (0..n).map(|i| y[i * d + j]).sum::<f64>() / n as f64;
        (0..n).for_each(|i| y[i * d + j] -= m);
    }
    (x, y)
}

/// Fourth-order central differences
/// $(f(x-2h) - 8f(x-h) + 8f(x+h) - f(x+2h))/(12h)$ along every coordinate: truncation
/// $O(h^4)$, so a moderate $h$ keeps the round-off term $\epsilon\lvert f\rvert/h$ small even
/// when $\lvert f\rvert$ is large.
pub(crate) fn central_diff(x: &[f64], h: f64, mut f: impl FnMut(&[f64]) -> f64) -> Vec<f64> {
    let mut xp = x.to_vec();
    let mut at = |xp: &mut Vec<f64>, i: usize, t: f64| {
        xp[i] = x[i] + t;
        let v = f(xp);
        xp[i] = x[i];
        v
    };
    (0..x.len())
        .map(|i| {
            let (m2, m1, p1, p2) =
                (at(&mut xp, i, -2.0 * h), at(&mut xp, i, -h), at(&mut xp, i, h), at(&mut xp, i, 2.0 * h));
            (m2 - 8.0 * m1 + 8.0 * p1 - p2) / (12.0 * h)
        })
        .collect()
}

/// Norm-wise relative error $\max_i\lvert a_i - b_i\rvert / \max_i\lvert b_i\rvert$.
pub(crate) fn max_rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let num = a.iter().zip(b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let den = b.iter().map(|b| b.abs()).fold(0.0, f64::max);
    if den == 0.0 {
        num
    } else {
        num / den
    }
}
