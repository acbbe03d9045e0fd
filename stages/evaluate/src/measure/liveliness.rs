//! Liveliness: does the character move as much as the training data does? Per frame after
//! the request, the RMS vertex speed (mesh units/s), against label B's training frames:
//! the ratio of the means (1: as lively as B; a frozen character near 0, a jittering one
//! above 1) and the Kolmogorov–Smirnov distance between the two speed distributions.
//! Smoothness is read beside it: a system cannot win both by standing still.

use std::ops::Range;

use reprise_motion_metrics::{ks_distance, rms_speeds};

use crate::training::Training;

/// One answer's liveliness: (ratio of mean speeds, KS distance) over every frame after the
/// request (`all`) and per phase after it (NaN where a phase has no frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Liveliness {
    /// Over every frame after the request.
    pub all: (f64, f64),
    /// Reach, blend, settle ([`super::Phase::AFTER`] order).
    pub phases: [(f64, f64); 3],
}

impl Default for Liveliness {
    fn default() -> Self {
        Self { all: (f64::NAN, f64::NAN), phases: [(f64::NAN, f64::NAN); 3] }
    }
}

/// Measures the meshes `m` (`frames × dim`) split into `phases` ([`super::Phase::ranges`])
/// against label `to`'s training speeds (`None`: a label without training frames, NaN).
pub fn measure(m: &[f64], training: &Training, to: Option<usize>, phases: &[Range<usize>; 4]) -> Liveliness {
    let Some(b) = to else { return Liveliness::default() };
    let reference = &training.speeds[b];
    let mean_b = training.mean_speed(b);
    let v = rms_speeds(m, training.dim, training.fps);
    let of = |r: Range<usize>| -> (f64, f64) {
        let s = &v[r.start.max(1).min(v.len())..r.end.min(v.len())];
        if s.is_empty() {
            return (f64::NAN, f64::NAN);
        }
        (s.iter().sum::<f64>() / s.len() as f64 / mean_b, ks_distance(s, reference))
    };
    let after = phases[1].start..phases[3].end;
    Liveliness { all: of(after), phases: [of(phases[1].clone()), of(phases[2].clone()), of(phases[3].clone())] }
}
