//! Animation curves the way animators key them: key poses with flat-tangent eases, holds,
//! anticipation and overshoot keys, damped-spring secondary motion, blinks and saccades.
//! Time is in frames (24 fps).

use rand::Rng;

/// Cubic Hermite ease between two keys with flat (zero) tangents: `h(u) = 3u² − 2u³`,
/// `u ∈ [0, 1]` the normalised time between the keys. Ease-in and ease-out in one curve.
pub(crate) fn ease(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// A sequence of full-pose keys. Between consecutive keys every control follows
/// `v(t) = v_a + (v_b − v_a) · ease((t − t_a)/(t_b − t_a))`; before the first key and after
/// the last the pose is held. Two consecutive keys with the same pose make a held key.
#[derive(Clone, Debug, Default)]
pub(crate) struct PoseKeys {
    pub frames: Vec<f64>,
    pub poses: Vec<Vec<f64>>,
}

impl PoseKeys {
    /// Append a key; `frame` must not precede the last key (equal frames replace it).
    pub(crate) fn push(&mut self, frame: f64, pose: Vec<f64>) {
        if let Some(&last) = self.frames.last() {
            debug_assert!(frame >= last);
            if frame <= last {
                *self.poses.last_mut().expect("non-empty") = pose;
                return;
            }
        }
        self.frames.push(frame);
        self.poses.push(pose);
    }

    /// Sample the controls listed in `idx` at time `t` into `out` (indexed by control).
    pub(crate) fn sample_into(&self, t: f64, idx: &[usize], out: &mut [f64]) {
        let n = self.frames.len();
        let b = self.frames.partition_point(|&f| f <= t);
        if b == 0 || b == n {
            let p = &self.poses[if b == 0 { 0 } else { n - 1 }];
            for &i in idx {
                out[i] = p[i];
            }
            return;
        }
        let a = b - 1;
        let h = ease((t - self.frames[a]) / (self.frames[b] - self.frames[a]));
        let (pa, pb) = (&self.poses[a], &self.poses[b]);
        for &i in idx {
            out[i] = pa[i] + (pb[i] - pa[i]) * h;
        }
    }
}

/// Damped spring driven by an acceleration signal, one value per frame:
/// `x'' = −ω² x − 2ζω x' + drive(t)` (ω in rad/frame), integrated with semi-implicit Euler
/// using `substeps` steps per frame; returns `x` per frame (starts at rest).
pub(crate) fn spring_response(drive: &[f64], omega: f64, zeta: f64, substeps: usize) -> Vec<f64> {
    let h = 1.0 / substeps as f64;
    let (mut x, mut v) = (0.0, 0.0);
    drive
        .iter()
        .map(|&a| {
            for _ in 0..substeps {
                v += h * (a - omega * omega * x - 2.0 * zeta * omega * v);
                x += h * v;
            }
            x
        })
        .collect()
}

/// Second difference `a_t = x_{t+1} − 2x_t + x_{t−1}` (per frame², one-sided at the ends = 0).
pub(crate) fn acceleration(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n).map(|t| if t == 0 || t + 1 >= n { 0.0 } else { x[t + 1] - 2.0 * x[t] + x[t - 1] }).collect()
}

/// Blink timing: lids close over `close` frames, stay shut `hold` frames, open over `open`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Blink {
    pub close: f64,
    pub hold: f64,
    pub open: f64,
}

impl Blink {
    /// Lid closure 0..1 at `dt` frames after the blink starts (eased both ways).
    pub(crate) fn value(&self, dt: f64) -> f64 {
        if dt < 0.0 {
            0.0
        } else if dt < self.close {
            ease(dt / self.close)
        } else if dt < self.close + self.hold {
            1.0
        } else {
            1.0 - ease((dt - self.close - self.hold) / self.open)
        }
    }

    pub(crate) fn length(&self) -> f64 {
        self.close + self.hold + self.open
    }
}

/// Blink start frames over `n` frames: gaps drawn uniformly from `gap` (frames).
pub(crate) fn blink_starts(n: usize, gap: (usize, usize), rng: &mut impl Rng) -> Vec<usize> {
    let mut out = Vec::new();
    let mut t = rng.gen_range(0..gap.1 / 2 + 1);
    while t < n {
        out.push(t);
        t += rng.gen_range(gap.0..=gap.1);
    }
    out
}

/// Eye saccades: gaze targets (yaw, pitch in degrees) held for `interval` frames, each jump
/// taking two frames (linear), with a small fixational drift between jumps.
pub(crate) fn saccades(
    n: usize,
    interval: (usize, usize),
    range: (f64, f64),
    bias: (f64, f64),
    rng: &mut impl Rng,
) -> Vec<(f64, f64)> {
    let mut target = (bias.0 + rng.gen_range(-range.0..=range.0), bias.1 + rng.gen_range(-range.1..=range.1));
    let mut prev = target;
    let mut jump_at = 0usize;
    let mut next = rng.gen_range(interval.0..=interval.1);
    let mut out = Vec::with_capacity(n);
    for t in 0..n {
        if t == next {
            prev = *out.last().unwrap_or(&target);
            // A saccade is a real jump: at least half the yaw range away from the last target.
            let old = target;
            for _ in 0..16 {
                target = (bias.0 + rng.gen_range(-range.0..=range.0), bias.1 + rng.gen_range(-range.1..=range.1));
                if (target.0 - old.0).abs() >= 0.5 * range.0 {
                    break;
                }
            }
            jump_at = t;
            next = t + rng.gen_range(interval.0..=interval.1);
        }
        let u = ((t - jump_at) as f64 / 2.0).min(1.0);
        let drift = 0.3 * ((t as f64) * 0.21).sin();
        out.push((prev.0 + (target.0 - prev.0) * u + drift, prev.1 + (target.1 - prev.1) * u));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn ease_and_keys() {
        assert_eq!(ease(0.0), 0.0);
        assert_eq!(ease(1.0), 1.0);
        assert!((ease(0.5) - 0.5).abs() < 1e-12);
        // flat tangents: tiny slope near the keys
        assert!(ease(0.01) < 0.001 && ease(0.99) > 0.999);
        let mut k = PoseKeys::default();
        k.push(0.0, vec![0.0, 1.0]);
        k.push(10.0, vec![0.0, 1.0]); // hold
        k.push(20.0, vec![2.0, 1.0]);
        let mut out = vec![9.0; 2];
        k.sample_into(5.0, &[0, 1], &mut out);
        assert_eq!(out, vec![0.0, 1.0]);
        k.sample_into(15.0, &[0], &mut out);
        assert!((out[0] - 1.0).abs() < 1e-12);
        k.sample_into(99.0, &[0], &mut out);
        assert_eq!(out[0], 2.0);
    }

    #[test]
    fn spring_lags_and_settles() {
        let mut drive = vec![0.0; 200];
        drive[10] = 1.0;
        let x = spring_response(&drive, 0.5, 0.25, 4);
        assert_eq!(x[5], 0.0);
        assert!(x[12] > 0.0);
        assert!(x.iter().any(|&v| v < 0.0), "under-damped: swings back");
        assert!(x[199].abs() < 1e-3, "settles");
    }

    #[test]
    fn blink_shape_and_saccades() {
        let b = Blink { close: 2.0, hold: 1.0, open: 4.0 };
        assert_eq!(b.value(2.5), 1.0);
        assert!(b.value(1.0) > 0.0 && b.value(1.0) < 1.0);
        assert_eq!(b.value(7.0), 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let s = saccades(300, (10, 30), (15.0, 8.0), (0.0, 0.0), &mut rng);
        let jumps = s.windows(2).filter(|w| (w[1].0 - w[0].0).abs() > 1.0).count();
        assert!(jumps >= 8, "{jumps}");
        let starts = blink_starts(480, (48, 144), &mut rng);
        assert!(starts.len() >= 3 && starts.windows(2).all(|w| w[1] - w[0] >= 48));
    }
}
