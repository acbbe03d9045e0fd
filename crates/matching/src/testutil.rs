//! Test databases with known structure.

use crate::database::Database;
use crate::features::{FeatureDb, FeatureParams};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A smooth random walk of `n` frames in `q` dimensions, cut into segments of 40–300
/// frames with labels 0–3, and its features with the identity projection ($y = z$).
pub(crate) fn random_walk(n: usize, q: usize, seed: u64) -> (Database, FeatureDb) {
    walk(n, q, seed, None)
}

/// The label of [`random_walk_with_short_label`]'s short segments.
pub(crate) const SHORT_LABEL: u32 = 4;

/// [`random_walk`] where about half the segments are label [`SHORT_LABEL`], every one
/// `short` frames long.
pub(crate) fn random_walk_with_short_label(n: usize, q: usize, seed: u64, short: usize) -> (Database, FeatureDb) {
    walk(n, q, seed, Some(short))
}

fn walk(n: usize, q: usize, seed: u64, short: Option<usize>) -> (Database, FeatureDb) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut z, mut vel) = (vec![0.0; q], vec![0.0; q]);
    let (mut rows, mut labels, mut segments) = (Vec::new(), Vec::new(), Vec::new());
    let (mut seg, mut left, mut label) = (0u32, 0usize, 0u32);
    for _ in 0..n {
        if left == 0 {
            seg += 1;
            left = rng.gen_range(40..300);
            label = rng.gen_range(0..4);
            if let Some(short) = short.filter(|_| rng.gen_bool(0.5)) {
                (left, label) = (short, SHORT_LABEL);
            }
        }
        left -= 1;
        for (x, v) in z.iter_mut().zip(&mut vel) {
            *v = 0.9 * *v + rng.gen_range(-0.1..0.1);
            *x += *v;
        }
        rows.extend_from_slice(&z);
        labels.push(label);
        segments.push(seg);
    }
    let db = Database::new(rows.clone(), q, labels, &segments, 24.0).unwrap();
    let feats = FeatureDb::build(&db, &rows, q, &FeatureParams::default()).unwrap();
    (db, feats)
}

/// Two labels as sine curves of period 2 s, 5 s each, C = q = 3 with $y = z$: label 0
/// (one segment) $z = (\sin\omega t, \cos\omega t, 0)$, label 1 (the next segment) the
/// same curve with third control `gap`. Frame $t$ of label 0 and frame $t + 5\,\text{fps}$
/// of label 1 have the same phase, so their features differ only by the constant `gap`.
pub(crate) fn two_sines(gap: f64, fps: u32) -> (Database, FeatureDb) {
    let len = 5 * fps;
    let w = std::f64::consts::PI / f64::from(fps);
    let mut rows = Vec::new();
    for t in 0..2 * len {
        let s = f64::from(t % len) * w;
        rows.extend_from_slice(&[s.sin(), s.cos(), if t < len { 0.0 } else { gap }]);
    }
    let labels: Vec<u32> = (0..2 * len).map(|t| u32::from(t >= len)).collect();
    let db = Database::new(rows.clone(), 3, labels.clone(), &labels, f64::from(fps)).unwrap();
    let feats = FeatureDb::build(&db, &rows, 3, &FeatureParams::default()).unwrap();
    (db, feats)
}

/// Like [`two_sines`] (C = q = 3, $y = z$, period 2 s at 24 fps), label 0 one segment of
/// 120 frames, then label 1 cut into `clips` segments of `short` frames each (the curve
/// going on across them, third control 1), then label 2 as three one-frame segments.
pub(crate) fn short_clips(short: usize, clips: usize) -> (Database, FeatureDb) {
    let w = std::f64::consts::PI / 24.0;
    let (mut rows, mut labels, mut segments) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |t: usize, label: u32, segment: u32| {
        let s = t as f64 * w;
        rows.extend_from_slice(&[s.sin(), s.cos(), f64::from(u32::from(label > 0))]);
        labels.push(label);
        segments.push(segment);
    };
    for t in 0..120 {
        push(t, 0, 0);
    }
    for t in 0..short * clips {
        push(t, 1, 1 + (t / short) as u32);
    }
    for t in 0..3 {
        push(7 * t, 2, (1 + clips + t) as u32);
    }
    let db = Database::new(rows.clone(), 3, labels, &segments, 24.0).unwrap();
    let feats = FeatureDb::build(&db, &rows, 3, &FeatureParams::default()).unwrap();
    (db, feats)
}
