//! Touch-ups: the fine blendshapes and the snout lattice, keyed by hand on a share of the
//! keys, independently of the coarse expression.
//!
//! An animator sculpts a lip curl or a brow kink where the shot needs it, not as a function
//! of the smile slider. Each fine family (per side) and the lattice get their own key
//! clock; at a key, with the label's touch-up share, a localised bump is keyed along the
//! feature (a centre segment, a width, an amplitude, one direction), otherwise the family
//! is released back to zero. The lattice keys a few front points (with half-weight
//! neighbours) on top of a label-typical base; its back layer (`k = 0`) is never keyed.

use crate::controls::{lattice_name, FINE_FAMILIES, LATTICE_N};
use crate::keys::PoseKeys;
use crate::poses::Style;
use crate::rig::DragonRig;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Share of a family's keys that carry a touch-up, per label (the rest release it).
fn share(label: &str) -> f64 {
    match label {
        "roar" | "surprise" | "grumpy" => 0.55,
        "neutral" | "bored" => 0.3,
        _ => 0.45,
    }
}

/// Key times on a touch-up clock: holds and moves at the label's pace, slower than the
/// coarse parts (touch-ups are keyed on a share of the main keys).
fn clock(style: &Style, frames: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut t = -rng.gen_range(0.0..style.hold_frames.1);
    let mut out = vec![t];
    while t < frames as f64 + 8.0 {
        t += 1.5 * rng.gen_range(style.hold_frames.0..style.hold_frames.1);
        out.push(t);
        t += rng.gen_range(style.move_frames.0..style.move_frames.1);
        out.push(t);
    }
    out
}

/// Write the fine-shape touch-ups of one take into `v` (row-major, `frames × C`).
pub(crate) fn fine_shapes(
    rig: &DragonRig,
    label: &str,
    style: &Style,
    v: &mut [f64],
    frames: usize,
    rng: &mut ChaCha8Rng,
) {
    let c = rig.controls().len();
    let p = share(label);
    for fam in &FINE_FAMILIES {
        for &(s, _) in fam.sides() {
            let idx: Vec<usize> = (0..fam.count)
                .flat_map(|seg| fam.dirs.iter().map(move |d| (seg, *d)))
                .map(|(seg, d)| rig.control_index(&fam.name(s, seg, d)).expect("fine control"))
                .collect();
            let k = idx.len();
            let mut keys = PoseKeys::default();
            let times = clock(style, frames, rng);
            // Keys come in pairs (end of hold, end of move): a touch-up is keyed at the end
            // of a move and held until the next move.
            let mut cur = vec![0.0; k];
            for (n, &t) in times.iter().enumerate() {
                if n % 2 == 0 {
                    keys.push(t, cur.clone());
                    continue;
                }
                cur = vec![0.0; k];
                if rng.gen_bool(p) {
                    let dir = rng.gen_range(0..fam.dirs.len());
                    let centre = rng.gen_range(0.0..fam.count as f64);
                    let width = rng.gen_range(0.8..2.5);
                    let amp = rng.gen_range(0.15..0.75);
                    for seg in 0..fam.count {
                        let u = (seg as f64 + 0.5 - centre) / width;
                        cur[seg * fam.dirs.len() + dir] = amp * (1.0 - u * u).max(0.0);
                    }
                }
                keys.push(t, cur.clone());
            }
            let local: Vec<usize> = (0..k).collect();
            let mut row = vec![0.0; k];
            for f in 0..frames {
                keys.sample_into(f as f64, &local, &mut row);
                for (j, &i) in idx.iter().enumerate() {
                    v[f * c + i] = row[j];
                }
            }
        }
    }
}

/// Label-typical offset (cm) of front lattice point `(i, j)`.
fn lattice_base(label: &str, i: usize, j: usize) -> [f64; 3] {
    let inner = (1..3).contains(&i) && (1..3).contains(&j);
    match label {
        "roar" if inner => [0.0, 0.0, 1.2],
        "grumpy" => [0.0, -0.2, -0.5],
        "happy" if j == 3 => [0.0, 0.3, 0.0],
        "surprise" => [0.0, 0.4, 0.2],
        _ => [0.0; 3],
    }
}

/// Write the lattice touch-ups of one take into `v`: the label's base on the front layer,
/// plus, at a share of keys, one to three points (layers `k ≥ 1`, mostly the front) pushed
/// by up to ±1.2 cm per axis, their in-layer neighbours by half.
pub(crate) fn lattice(rig: &DragonRig, label: &str, style: &Style, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let n = LATTICE_N;
    let point = |i: usize, j: usize, k: usize| ((k - 1) * n + j) * n + i;
    let idx: Vec<usize> = (1..n)
        .flat_map(|k| (0..n).flat_map(move |j| (0..n).map(move |i| (i, j, k))))
        .flat_map(|(i, j, k)| (0..3).map(move |a| (i, j, k, a)))
        .map(|(i, j, k, a)| rig.control_index(&lattice_name(i, j, k, a)).expect("lattice control"))
        .collect();
    let mut base = vec![0.0; idx.len()];
    for j in 0..n {
        for i in 0..n {
            let b = lattice_base(label, i, j);
            for a in 0..3 {
                base[3 * point(i, j, n - 1) + a] = b[a] * rng.gen_range(0.8..1.2);
            }
        }
    }
    let mut keys = PoseKeys::default();
    let mut cur = base.clone();
    for (m, t) in clock(style, frames, rng).into_iter().enumerate() {
        if m % 2 == 1 {
            cur = base.clone();
            if rng.gen_bool(share(label)) {
                for _ in 0..rng.gen_range(1..=3) {
                    let k = if rng.gen_bool(0.75) { n - 1 } else { rng.gen_range(1..n - 1) };
                    let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
                    let d: Vec<f64> = (0..3).map(|_| rng.gen_range(-1.2..1.2)).collect();
                    for (ni, nj) in [(i, j), (i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)] {
                        if ni < n && nj < n {
                            let w = if (ni, nj) == (i, j) { 1.0 } else { 0.5 };
                            for a in 0..3 {
                                cur[3 * point(ni, nj, k) + a] += w * d[a];
                            }
                        }
                    }
                }
            }
        }
        keys.push(t, cur.clone());
    }
    let local: Vec<usize> = (0..idx.len()).collect();
    let mut row = vec![0.0; idx.len()];
    for f in 0..frames {
        keys.sample_into(f as f64, &local, &mut row);
        for (j, &i) in idx.iter().enumerate() {
            v[f * c + i] = row[j];
        }
    }
}
