//! Brute-force vs AABB-accelerated search on a synthetic 4,000-frame database.
//!
//! `cargo run --release -p reprise-matching --example search_speed [frames] [q]`
//!
//! The database is a smooth random walk in q = 8 dimensions (y = z), cut into takes of
//! 40–300 frames with four labels; the 4,000 queries are database frames' features plus
//! noise, searched over one label's frames (as the controller does) and over all frames.
//! Prints the time ratio; absolute times depend on the machine.

use reprise_matching::{Database, FeatureDb, FeatureParams, FrameSet};
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// A small deterministic generator (xorshift64*) so the example needs no dependency.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        bits as f64 / (1u64 << 53) as f64
    }

    fn below(&mut self, n: usize) -> usize {
        let i = (self.uniform() * n as f64) as usize;
        i.min(n - 1)
    }
}

fn main() -> Res<()> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(Ok(4000), |a| a.parse())?;
    let q: usize = args.next().map_or(Ok(8), |a| a.parse())?;
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut z, mut v) = (vec![0.0; q], vec![0.0; q]);
    let (mut rows, mut labels, mut segments) = (Vec::new(), Vec::new(), Vec::new());
    let (mut seg, mut left, mut label) = (0u32, 0usize, 0u32);
    for _ in 0..n {
        if left == 0 {
            seg += 1;
            left = 40 + rng.below(260);
            label = u32::try_from(rng.below(4))?;
        }
        left -= 1;
        for (x, dx) in z.iter_mut().zip(&mut v) {
            *dx = 0.9 * *dx + 0.2 * (rng.uniform() - 0.5);
            *x += *dx;
        }
        rows.extend_from_slice(&z);
        labels.push(label);
        segments.push(seg);
    }
    let db = Database::new(rows.clone(), q, labels, &segments, 24.0)?;
    let feats = FeatureDb::build(&db, &rows, q, &FeatureParams::default())?;
    let sets: Vec<FrameSet> = (0..4)
        .map(|l| feats.searchable_with_label(&db, l))
        .chain(std::iter::once(Ok(FrameSet::all(n))))
        .collect::<Result<_, _>>()?;
    let queries: Vec<(Vec<f64>, usize)> = (0..4000)
        .map(|i| {
            let base = feats.features(rng.below(n));
            let noise = [0.05, 0.3, 1.0][i % 3];
            let query = base.iter().map(|x| x + noise * (rng.uniform() - 0.5)).collect();
            (query, i % sets.len())
        })
        .collect();
    let time = |accelerated: bool| -> Res<(f64, Vec<Option<usize>>)> {
        let start = Instant::now();
        let mut found = Vec::with_capacity(queries.len());
        for (query, s) in &queries {
            let m = if accelerated {
                feats.search(query, &sets[*s], None)?
            } else {
                feats.search_brute(query, &sets[*s], None)?
            };
            found.push(m.map(|m| m.frame));
        }
        Ok((start.elapsed().as_secs_f64(), found))
    };
    time(true)?; // warm caches
    let (brute, a) = time(false)?;
    let (fast, b) = time(true)?;
    assert_eq!(a, b, "accelerated and brute-force answers differ");
    println!(
        "{n} frames, feature dim {}, {} queries: brute {:.1} ms, accelerated {:.1} ms, ratio {:.1}x",
        feats.dim(),
        queries.len(),
        brute * 1e3,
        fast * 1e3,
        brute / fast
    );
    Ok(())
}
