//! Smoothness on the mesh: peak vertex acceleration and jerk over the whole answer, pose
//! jumps, and the peak-speed trace around the arrival in B.

use reprise_motion_metrics::{peak_speeds, peaks};

use super::{SPEED_AFTER, SPEED_BEFORE};
use crate::training::Training;

/// One answer's motion measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// max over frames $t \in [a, a + L + k)$ of the peak vertex acceleration, / the training p95.
    pub accel: f64,
    /// Likewise for jerk.
    pub jerk: f64,
    /// max over frames after the request of the peak vertex speed, / the training p99.
    pub jump: f64,
    /// Peak vertex speed around the first frame of B (mesh units/s; NaN outside the answer).
    pub speed: Vec<f64>,
}

/// Measures the meshes `m` (`frames × dim`) of an answer asked at frame `asked` whose first
/// frame of B is `arrive`, blend length `k`.
pub fn measure(m: &[f64], training: &Training, asked: usize, arrive: usize, k: usize) -> Motion {
    let dim = training.dim;
    let frames = m.len() / dim.max(1);
    let (a, j) = peaks(m, dim, training.fps);
    let lo = asked.min(frames);
    let hi = (arrive + k).min(frames).max(lo);
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let v = peak_speeds(m, dim, training.fps);
    let speed = (-SPEED_BEFORE..=SPEED_AFTER)
        .map(|o| {
            let t = arrive as i64 + o;
            if t < 1 || t as usize >= frames {
                f64::NAN
            } else {
                v[t as usize]
            }
        })
        .collect();
    Motion {
        accel: max(&a[lo..hi]) / training.acc95,
        jerk: max(&j[lo..hi]) / training.jerk95,
        jump: max(&v[(lo + 1).min(frames)..]) / training.speed99,
        speed,
    }
}
