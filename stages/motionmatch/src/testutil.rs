//! Test databases with known structure.

use crate::database::Database;
use crate::features::{FeatureDb, FeatureParams};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A smooth random walk of `n` frames in `q` dimensions, cut into segments of 40–300
/// frames with labels 0–3, and its features with the identity projection ($y = z$).
pub(crate) fn random_walk(n: usize, q: usize, seed: u64) -> (Database, FeatureDb) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut z, mut vel) = (vec![0.0; q], vec![0.0; q]);
    let (mut rows, mut labels, mut segments) = (Vec::new(), Vec::new(), Vec::new());
    let (mut seg, mut left, mut label) = (0u32, 0usize, 0u32);
    for _ in 0..n {
        if left == 0 {
            seg += 1;
            left = rng.gen_range(40..300);
            label = rng.gen_range(0..4);
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

/// Two labels as sine curves at 24 fps, C = q = 2 with $y = z$: label 0 (frames 0..120,
/// one segment) $z = (\sin\omega t, \cos\omega t)$; label 1 (frames 120..240) the same
/// curve shifted by `gap` in the first control. $\omega = 2\pi/48$ per frame.
pub(crate) fn two_sines(gap: f64) -> (Database, FeatureDb) {
    let w = std::f64::consts::TAU / 48.0;
    let mut rows = Vec::new();
    for t in 0..240u32 {
        let s = f64::from(t % 120) * w;
        let shift = if t < 120 { 0.0 } else { gap };
        rows.extend_from_slice(&[s.sin() + shift, s.cos()]);
    }
    let labels: Vec<u32> = (0..240).map(|t| u32::from(t >= 120)).collect();
    let db = Database::new(rows.clone(), 2, labels.clone(), &labels, 24.0).unwrap();
    let feats = FeatureDb::build(&db, &rows, 2, &FeatureParams::default()).unwrap();
    (db, feats)
}
