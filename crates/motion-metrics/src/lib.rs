//! Metrics of synthesized animation, on per-frame vectors (mesh vertices `x0 y0 z0 x1 …`,
//! or scaled controls), with no I/O. Definitions (the report restates them):
//!
//! - **Peak vertex acceleration** of frame $t$: $\max_v\lVert x_v(t+1) - 2x_v(t) + x_v(t-1)\rVert\,f^2$
//!   (mesh units/s², $f$ = fps), the central second difference; **peak jerk** of frame $t$:
//!   $\max_v\lVert x_v(t+2) - 3x_v(t+1) + 3x_v(t) - x_v(t-1)\rVert\,f^3$ ([`peaks`]).
//! - **Plausibility distance** of a pose: the Euclidean distance to its nearest training
//!   pose ([`nearest_distance`]), divided by the typical per-frame motion of the training data
//!   (the median distance between consecutive frames).
//! - **Variety** of two runs of one script: the mean over frames of the distance between
//!   their poses ([`mean_distance`]).
//! - **RMS vertex speed** of frame $t$: $\sqrt{\tfrac1V\sum_v\lVert x_v(t) - x_v(t-1)\rVert^2}\,f$
//!   (mesh units/s; [`rms_speeds`]) — how much the whole character moves, where the peak
//!   speed finds the one vertex that jumps.
//! - **Kolmogorov–Smirnov distance** of two samples: $\sup_x\lvert F_a(x) - F_b(x)\rvert$ of
//!   their empirical distribution functions ([`ks_distance`]); 0 for the same distribution,
//!   1 for disjoint ones.
//! - Confidence intervals: percentile bootstrap of the mean ([`bootstrap_mean_ci`]).

use rand::{Rng, SeedableRng};

/// Per frame, the peak vertex acceleration and jerk (see the crate docs) of a sequence of
/// `frames` vectors of `3V` values (row-major); entries without enough neighbours are 0.
pub fn peaks(x: &[f64], dim: usize, fps: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len() / dim;
    let f = |t: usize| &x[t * dim..(t + 1) * dim];
    let (mut acc, mut jerk) = (vec![0.0; n], vec![0.0; n]);
    for t in 1..n.saturating_sub(1) {
        let (a, b, c) = (f(t - 1), f(t), f(t + 1));
        acc[t] = (0..dim / 3)
            .map(|v| (0..3).map(|k| (c[3 * v + k] - 2.0 * b[3 * v + k] + a[3 * v + k]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max)
            * fps
            * fps;
        if t + 2 < n {
            let d = f(t + 2);
            jerk[t] = (0..dim / 3)
                .map(|v| {
                    (0..3)
                        .map(|k| (d[3 * v + k] - 3.0 * c[3 * v + k] + 3.0 * b[3 * v + k] - a[3 * v + k]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .fold(0.0, f64::max)
                * fps
                * fps
                * fps;
        }
    }
    (acc, jerk)
}

/// Per frame, the peak vertex speed: the largest $\lVert x_t - x_{t-1}\rVert$ over vertices,
/// × fps (mesh units per second); 0 at the first frame. A pose jump shows as one large value.
pub fn peak_speeds(x: &[f64], dim: usize, fps: f64) -> Vec<f64> {
    let n = x.len() / dim.max(1);
    (0..n)
        .map(|t| {
            if t == 0 {
                return 0.0;
            }
            let (a, b) = (&x[(t - 1) * dim..t * dim], &x[t * dim..(t + 1) * dim]);
            (0..dim / 3)
                .map(|v| (0..3).map(|k| (b[3 * v + k] - a[3 * v + k]).powi(2)).sum::<f64>().sqrt())
                .fold(0.0, f64::max)
                * fps
        })
        .collect()
}

/// Per frame, the RMS vertex speed (see the crate docs; mesh units/s); 0 at the first frame.
pub fn rms_speeds(x: &[f64], dim: usize, fps: f64) -> Vec<f64> {
    let n = x.len() / dim.max(1);
    let vertices = (dim / 3).max(1) as f64;
    (0..n)
        .map(|t| {
            if t == 0 {
                return 0.0;
            }
            let (a, b) = (&x[(t - 1) * dim..t * dim], &x[t * dim..(t + 1) * dim]);
            (a.iter().zip(b).map(|(p, q)| (q - p) * (q - p)).sum::<f64>() / vertices).sqrt() * fps
        })
        .collect()
}

/// The two-sample Kolmogorov–Smirnov distance $\sup_x\lvert F_a(x) - F_b(x)\rvert$ between
/// the samples `a` and `sorted_b` (ascending, finite); NaN if either is empty.
pub fn ks_distance(a: &[f64], sorted_b: &[f64]) -> f64 {
    let mut a: Vec<f64> = a.iter().copied().filter(|v| v.is_finite()).collect();
    if a.is_empty() || sorted_b.is_empty() {
        return f64::NAN;
    }
    a.sort_by(f64::total_cmp);
    let (na, nb) = (a.len() as f64, sorted_b.len() as f64);
    let (mut i, mut j, mut d) = (0usize, 0usize, 0f64);
    // Walk both in order; at each distinct value, step past every copy in both samples.
    while i < a.len() && j < sorted_b.len() {
        let x = a[i].min(sorted_b[j]);
        while i < a.len() && a[i] <= x {
            i += 1;
        }
        while j < sorted_b.len() && sorted_b[j] <= x {
            j += 1;
        }
        d = d.max((i as f64 / na - j as f64 / nb).abs());
    }
    d
}

/// The `q`-quantile (0–1) of `values` by linear interpolation between order statistics;
/// NaN for no values.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (pos - lo as f64) * (v[hi] - v[lo])
}

/// $\sum_i (a_i - b_i)^2$ over the common length of `a` and `b`, each element taken to `T`
/// by `ta` / `tb`, summed in `L` interleaved lanes (so the compiler can keep them in vector
/// registers; the order of the additions differs from a left-to-right sum only by rounding).
fn lane_sum<A: Copy, B: Copy, T, const L: usize>(a: &[A], b: &[B], ta: impl Fn(A) -> T, tb: impl Fn(B) -> T) -> T
where
    T: Copy + Default + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Mul<Output = T>,
{
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut lanes = [T::default(); L];
    let (ac, bc) = (a.chunks_exact(L), b.chunks_exact(L));
    let (ar, br) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        for k in 0..L {
            let d = ta(x[k]) - tb(y[k]);
            lanes[k] = lanes[k] + d * d;
        }
    }
    let tail = ar.iter().zip(br).fold(T::default(), |s, (x, y)| {
        let d = ta(*x) - tb(*y);
        s + d * d
    });
    lanes.iter().fold(T::default(), |s, l| s + *l) + tail
}

/// $\sum_i (a_i - b_i)^2$ over the common length, summed in four interleaved lanes (vector
/// registers; the order of the additions differs from a left-to-right sum only by rounding).
pub fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    lane_sum::<_, _, f64, 4>(a, b, |x| x, |y| y)
}

/// [`squared_distance`] between single-precision `a` and double-precision `b`.
pub fn squared_distance_f32(a: &[f32], b: &[f64]) -> f64 {
    lane_sum::<_, _, f64, 4>(a, b, f64::from, |y| y)
}

/// [`squared_distance`] between two single-precision vectors, summed in single precision
/// in eight lanes (for orderings and bounds, not for reported distances).
pub fn squared_distance_f32s(a: &[f32], b: &[f32]) -> f64 {
    f64::from(lane_sum::<_, _, f32, 8>(a, b, |x| x, |y| y))
}

/// The distance from `x` to the nearest of the rows of `set` (`rows × dim`).
pub fn nearest_distance(x: &[f64], set: &[f64], dim: usize) -> f64 {
    set.chunks_exact(dim)
        .map(|r| r.iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>())
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

/// The `k` rows of `set` (`rows × dim`) nearest to `x`: (distance, row), nearest first.
pub fn nearest_k(x: &[f64], set: &[f64], dim: usize, k: usize) -> Vec<(f64, usize)> {
    let mut d: Vec<(f64, usize)> =
        set.chunks_exact(dim.max(1)).enumerate().map(|(i, r)| (squared_distance(r, x), i)).collect();
    let order = |a: &(f64, usize), b: &(f64, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    let k = k.min(d.len());
    if k < d.len() {
        d.select_nth_unstable_by(k, order);
        d.truncate(k);
    }
    d.sort_by(order);
    d.into_iter().map(|(s, i)| (s.sqrt(), i)).collect()
}

/// The mean over frames of the distance between two equally long sequences.
pub fn mean_distance(a: &[f64], b: &[f64], dim: usize) -> f64 {
    let n = a.len().min(b.len()) / dim;
    if n == 0 {
        return f64::NAN;
    }
    (0..n)
        .map(|t| {
            a[t * dim..(t + 1) * dim]
                .iter()
                .zip(&b[t * dim..(t + 1) * dim])
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum::<f64>()
        / n as f64
}

/// The mean of `values` and its 95 % percentile-bootstrap interval (`resamples` draws,
/// seeded): (mean, low, high); NaNs for no values.
pub fn bootstrap_mean_ci(values: &[f64], resamples: usize, seed: u64) -> (f64, f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let means: Vec<f64> =
        (0..resamples).map(|_| (0..n).map(|_| values[rng.gen_range(0..n)]).sum::<f64>() / n as f64).collect();
    (mean, quantile(&means, 0.025), quantile(&means, 0.975))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The k nearest rows, nearest first, agree with sorting every distance.
    #[test]
    fn nearest_k_agrees_with_a_full_sort() {
        let set: Vec<f64> = (0..40).map(|i| ((i * 37) % 17) as f64).collect();
        let x = [3.0, 5.0];
        let mut all: Vec<(f64, usize)> = set
            .chunks_exact(2)
            .enumerate()
            .map(|(i, r)| (((r[0] - x[0]).powi(2) + (r[1] - x[1]).powi(2)).sqrt(), i))
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(nearest_k(&x, &set, 2, 5), all[..5].to_vec());
        assert_eq!(nearest_k(&x, &set, 2, 99).len(), 20);
        assert_eq!(nearest_k(&x, &set, 2, 1)[0].0, nearest_distance(&x, &set, 2));
    }

    /// Two vertices, one still and one moving 1, 1, then jumping 5 per frame: the peak
    /// speed is the mover's step × fps.
    #[test]
    fn peak_speeds_find_the_jump() {
        let x = [
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            7.0, 0.0, 0.0,
        ];
        assert_eq!(peak_speeds(&x, 6, 24.0), vec![0.0, 24.0, 24.0, 120.0]);
    }

    /// A unit step of one vertex along x at frame 5 has second differences ±1 and third
    /// differences 1, −3·… : peak acceleration f² at frames 4 and 5, peak jerk ≤ 3f³ — and
    /// a constant-velocity motion has none.
    #[test]
    fn a_step_has_a_known_jerk() {
        let fps = 24.0;
        let x: Vec<f64> = (0..10).flat_map(|t| [if t >= 5 { 1.0 } else { 0.0 }, 0.0, 0.0]).collect();
        let (acc, jerk) = peaks(&x, 3, fps);
        assert_eq!(acc[4], fps * fps);
        assert_eq!(acc[5], fps * fps);
        assert_eq!(acc[3], 0.0);
        // x(t+2) − 3x(t+1) + 3x(t) − x(t−1) at t = 3: 1 − 0 = 1; at t = 4: 1 − 3 = −2 → 2.
        assert_eq!(jerk[3], fps.powi(3));
        assert_eq!(jerk[4], 2.0 * fps.powi(3));
        let lin: Vec<f64> = (0..10).flat_map(|t| [t as f64 * 0.5, 1.0, -(t as f64)]).collect();
        let (a, j) = peaks(&lin, 3, fps);
        assert!(a.iter().chain(&j).all(|v| v.abs() < 1e-9));
    }

    /// The lane sums agree with a plain sum on lengths with and without a remainder.
    #[test]
    fn squared_distances_agree_with_a_plain_sum() {
        for n in [0, 1, 3, 4, 5, 17, 48] {
            let a: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
            let plain: f64 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
            assert!((squared_distance(&a, &b) - plain).abs() < 1e-12, "{n}");
            let a32: Vec<f32> = a.iter().map(|v| *v as f32).collect();
            let plain32: f64 = a32.iter().zip(&b).map(|(x, y)| (f64::from(*x) - y).powi(2)).sum();
            assert!((squared_distance_f32(&a32, &b) - plain32).abs() < 1e-12, "{n}");
            let b32: Vec<f32> = b.iter().map(|v| *v as f32).collect();
            assert!((squared_distance_f32s(&a32, &b32) - plain).abs() <= 1e-5 * (1.0 + plain), "{n}");
        }
    }

    /// RMS speed: one of two vertices moving 1 per frame is sqrt(1/2) × fps; KS distances
    /// of known samples: equal 0, disjoint 1, shifted halves 0.5, ties handled.
    #[test]
    fn rms_speed_and_ks_have_known_values() {
        let x = [0.0, 0.0, 0.0, 5.0, 5.0, 5.0, 1.0, 0.0, 0.0, 5.0, 5.0, 5.0];
        let v = rms_speeds(&x, 6, 24.0);
        assert_eq!(v[0], 0.0);
        assert!((v[1] - 0.5f64.sqrt() * 24.0).abs() < 1e-12);
        let b: Vec<f64> = (0..10).map(f64::from).collect();
        assert_eq!(ks_distance(&b, &b), 0.0);
        assert_eq!(ks_distance(&[100.0, 200.0], &b), 1.0);
        assert_eq!(ks_distance(&[-1.0, -2.0], &b), 1.0);
        let shifted: Vec<f64> = (5..15).map(f64::from).collect();
        assert!((ks_distance(&shifted, &b) - 0.5).abs() < 1e-12);
        assert_eq!(ks_distance(&[1.0, 1.0, 1.0], &[1.0, 1.0]), 0.0);
        assert!(ks_distance(&[], &b).is_nan());
    }

    /// Identical runs have zero variety; a copied training frame has zero plausibility
    /// distance; quantiles interpolate; the bootstrap interval brackets the mean.
    #[test]
    fn known_answers() {
        let a = vec![1.0, 2.0, 3.0, 4.0];
        assert_eq!(mean_distance(&a, &a, 2), 0.0);
        assert!((mean_distance(&a, &[1.0, 2.0, 3.0, 5.0], 2) - 0.5).abs() < 1e-12);
        let train = vec![0.0, 0.0, 3.0, 4.0, 1.0, 1.0];
        assert_eq!(nearest_distance(&[3.0, 4.0], &train, 2), 0.0);
        assert!((nearest_distance(&[3.0, 0.0], &train, 2) - 5f64.sqrt()).abs() < 1e-12);
        assert_eq!(quantile(&[3.0, 1.0, 2.0, 4.0], 0.5), 2.5);
        let v: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let (m, lo, hi) = bootstrap_mean_ci(&v, 500, 1);
        assert!(lo < m && m < hi && (m - 49.5).abs() < 1e-12 && hi - lo < 20.0);
    }
}
