//! Smoothness on the mesh: the discontinuity around the label switch (peak vertex
//! acceleration and jerk in a window of the same length for every system), pose jumps, and
//! the peak-speed trace around the switch.

use reprise_motion_metrics::{peak_speeds, peaks};

use super::{SPEED_AFTER, SPEED_BEFORE};
use crate::training::Training;

/// Peak acceleration and jerk in the discontinuity window, / the training p95s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Discontinuity {
    /// max over the window of the per-frame peak vertex acceleration / the training p95.
    pub accel: f64,
    /// Likewise for jerk.
    pub jerk: f64,
}

/// One answer's motion measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Around the label switch.
    pub discontinuity: Discontinuity,
    /// max over frames after the request of the peak vertex speed, / the training p99.
    pub jump: f64,
    /// Peak vertex speed around the first frame of B (mesh units/s; NaN outside the answer).
    pub speed: Vec<f64>,
}

/// The `w` frames centred on frame `centre`, moved to lie inside `first..frames` (the
/// frames after the request: the hold before it is context, and a system asked after a
/// hold must not be charged for it) where the answer is long enough, so every system is
/// measured over the same length.
pub fn window(centre: usize, w: usize, first: usize, frames: usize) -> std::ops::Range<usize> {
    let first = first.min(frames);
    let w = w.min(frames - first);
    let lo = centre.saturating_sub(w / 2).max(first).min(frames - w);
    lo..lo + w
}

/// Measures the meshes `m` (`frames × dim`) of an answer asked at frame `asked` whose label
/// switches to B at frame `switch`, with a discontinuity window of `w` frames.
pub fn measure(m: &[f64], training: &Training, asked: usize, switch: usize, w: usize) -> Motion {
    let dim = training.dim;
    let frames = m.len() / dim.max(1);
    let (a, j) = peaks(m, dim, training.fps);
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let v = peak_speeds(m, dim, training.fps);
    let speed = (-SPEED_BEFORE..=SPEED_AFTER)
        .map(|o| {
            let t = switch as i64 + o;
            if t < 1 || t as usize >= frames {
                f64::NAN
            } else {
                v[t as usize]
            }
        })
        .collect();
    let win = window(switch, w, asked + 1, frames);
    Motion {
        discontinuity: Discontinuity {
            accel: max(&a[win.clone()]) / training.acc95,
            jerk: max(&j[win]) / training.jerk95,
        },
        jump: max(&v[(asked + 1).min(frames)..]) / training.speed99,
        speed,
    }
}

#[cfg(test)]
mod tests {
    use super::window;

    /// The window keeps its length, centred where it can be, shifted after the request
    /// and inside the answer where it cannot, and is all the frames after the request when
    /// they are fewer. A switch right after a hold (reprise is asked at frame 11) and one
    /// at the start (the others are asked at 0) are measured over the same frames relative
    /// to the request.
    #[test]
    fn the_window_has_one_length() {
        assert_eq!(window(20, 8, 1, 40), 16..24);
        assert_eq!(window(2, 8, 1, 40), 1..9);
        assert_eq!(window(39, 8, 1, 40), 32..40);
        assert_eq!(window(3, 8, 1, 5), 1..5);
        assert_eq!(window(13, 8, 12, 50), 12..20);
        assert_eq!(window(1, 8, 1, 50), 1..9);
        assert_eq!(window(3, 8, 9, 5), 5..5);
    }
}
