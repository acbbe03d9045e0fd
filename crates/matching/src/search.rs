//! Nearest-feature search (method.md §7.2): the cost of frame $t$ for a normalised query
//! $\hat q$ is $c(t) = \sum_j (\hat q_j - \hat f_{tj})^2$, minimised over the allowed,
//! searchable frames.
//!
//! - [`FeatureDb::search_brute`]: every candidate, full sums — the oracle.
//! - [`FeatureDb::search`]: Holden's acceleration. Axis-aligned boxes of the features of
//!   the searchable frames in aligned blocks of 64 and 16 consecutive frames; a block is
//!   skipped when its lower bound $\sum_j(\hat q_j - \operatorname{clamp}(\hat q_j, lo_j,
//!   hi_j))^2$ exceeds the best cost so far, a candidate's sum stops once it does. Unlike
//!   the reference, the 64-blocks are visited best bound first, so a good match is found
//!   early and the rest is cut off at once.
//!
//! Both return the *lowest* frame of minimal cost, with the same cost bit for bit: sums run
//! over columns in the same order, the box bound is termwise ≤ the cost in floating point
//! too (rounding is monotone), and pruning is strict (`>`), so no minimiser — not even a
//! tied one — is ever cut off.

use crate::database::FrameSet;
use crate::error::{check_finite, check_len, MatchError, Result};
use crate::features::FeatureDb;

/// Frames per small block (a quarter of a bitset word).
const SMALL: usize = 16;
/// Frames per large block (one bitset word).
const LARGE: usize = 64;

/// The best frame of a search and its cost $c(t)$.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Database frame.
    pub frame: usize,
    /// Squared normalised feature distance.
    pub cost: f64,
}

/// Frames near the playing one that a search must not return (the reference's
/// `ignore_surrounding`): every $t$ with $|t - \text{center}| \le \text{radius}$.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Exclusion {
    /// The playing frame.
    pub center: usize,
    /// Half-width in frames.
    pub radius: usize,
}

impl Exclusion {
    /// The excluded frames as a mask over word `w` (frames `64w..64w + 63`).
    fn mask(self, w: usize) -> u64 {
        let lo = self.center.saturating_sub(self.radius);
        let hi = self.center.saturating_add(self.radius);
        let (w0, w1) = (w * LARGE, w * LARGE + LARGE - 1);
        if hi < w0 || lo > w1 {
            return 0;
        }
        let (a, b) = (lo.max(w0) - w0, hi.min(w1) - w0);
        let width = b - a + 1;
        let ones = if width == 64 { u64::MAX } else { (1u64 << width) - 1 };
        ones << a
    }
}

/// Bounding boxes of the searchable frames' features per block.
#[derive(Debug, Clone)]
pub(crate) struct Blocks {
    small_lo: Vec<f64>,
    small_hi: Vec<f64>,
    large_lo: Vec<f64>,
    large_hi: Vec<f64>,
}

impl Blocks {
    pub(crate) fn build(features: &[f64], dim: usize, searchable: &FrameSet) -> Self {
        let n = searchable.universe();
        let boxes = |size: usize| {
            let nb = n.div_ceil(size);
            let mut lo = vec![f64::INFINITY; nb * dim];
            let mut hi = vec![f64::NEG_INFINITY; nb * dim];
            for t in searchable.iter() {
                let b = t / size;
                let row = &features[t * dim..(t + 1) * dim];
                for ((l, h), v) in lo[b * dim..(b + 1) * dim].iter_mut().zip(&mut hi[b * dim..(b + 1) * dim]).zip(row) {
                    *l = l.min(*v);
                    *h = h.max(*v);
                }
            }
            (lo, hi)
        };
        let (small_lo, small_hi) = boxes(SMALL);
        let (large_lo, large_hi) = boxes(LARGE);
        Self { small_lo, small_hi, large_lo, large_hi }
    }
}

/// $\sum_j(q_j - f_j)^2$, stopping once the partial sum exceeds `stop`.
#[inline]
fn cost_until(query: &[f64], row: &[f64], stop: f64) -> f64 {
    let mut sum = 0.0;
    for (q, f) in query.iter().zip(row) {
        sum += (q - f) * (q - f);
        if sum > stop {
            break;
        }
    }
    sum
}

/// Lower bound of the cost over a box, stopping once it exceeds `stop`.
#[inline]
fn box_bound(query: &[f64], lo: &[f64], hi: &[f64], stop: f64) -> f64 {
    let mut sum = 0.0;
    for ((q, l), h) in query.iter().zip(lo).zip(hi) {
        let d = q - q.clamp(*l, *h);
        sum += d * d;
        if sum > stop {
            break;
        }
    }
    sum
}

impl FeatureDb {
    fn check_search(&self, query: &[f64], allowed: &FrameSet) -> Result<()> {
        check_len("query", self.dim, query.len())?;
        check_finite("query", query, self.dim)?;
        if allowed.universe() != self.n {
            return Err(MatchError::Mismatch { what: "allowed frames", expected: self.n, actual: allowed.universe() });
        }
        Ok(())
    }

    /// The frames of word `w` a search may return.
    fn candidates(&self, allowed: &FrameSet, exclude: Option<Exclusion>, w: usize) -> u64 {
        let word = allowed.words()[w] & self.searchable.words()[w];
        exclude.map_or(word, |e| word & !e.mask(w))
    }

    /// Exhaustive search over `allowed ∩ searchable` minus `exclude`: the lowest frame of
    /// minimal cost, `None` if no frame qualifies. `query` is normalised
    /// ([`FeatureDb::features`] of a frame, or [`FeatureDb::normalize`]).
    ///
    /// # Errors
    /// [`MatchError::Length`] / [`MatchError::NonFinite`] for a bad query,
    /// [`MatchError::Mismatch`] if `allowed` belongs to another database.
    pub fn search_brute(&self, query: &[f64], allowed: &FrameSet, exclude: Option<Exclusion>) -> Result<Option<Match>> {
        self.check_search(query, allowed)?;
        let mut best: Option<Match> = None;
        for w in 0..allowed.words().len() {
            let mut bits = self.candidates(allowed, exclude, w);
            while bits != 0 {
                let t = w * LARGE + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let cost = cost_until(query, self.features(t), f64::INFINITY);
                if best.is_none_or(|b| cost < b.cost) {
                    best = Some(Match { frame: t, cost });
                }
            }
        }
        Ok(best)
    }

    /// The `k` best frames of the search [`FeatureDb::search_brute`] makes, best first:
    /// increasing cost, ties to the lower frame, so the first is that search's answer.
    /// Fewer than `k` where fewer frames qualify. Exhaustive, $O(n\,d + n \log k)$: for
    /// showing a search's runners-up, not for the search itself.
    ///
    /// # Errors
    /// As [`FeatureDb::search_brute`].
    pub fn search_top(
        &self,
        query: &[f64],
        allowed: &FrameSet,
        exclude: Option<Exclusion>,
        k: usize,
    ) -> Result<Vec<Match>> {
        self.check_search(query, allowed)?;
        let mut top: Vec<Match> = Vec::with_capacity(k + 1);
        let kth = |top: &Vec<Match>| if top.len() < k { f64::INFINITY } else { top[k - 1].cost };
        for w in 0..allowed.words().len() {
            let mut bits = self.candidates(allowed, exclude, w);
            while bits != 0 && k > 0 {
                let t = w * LARGE + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let cost = cost_until(query, self.features(t), f64::INFINITY);
                // Frames come in increasing order, so an equal cost goes after the ones kept.
                if top.len() < k || cost < kth(&top) {
                    let at = top.partition_point(|m| m.cost <= cost);
                    top.insert(at, Match { frame: t, cost });
                    top.truncate(k);
                }
            }
        }
        Ok(top)
    }

    /// Same answer as [`FeatureDb::search_brute`] (frame and cost), faster.
    ///
    /// Branch and bound: the 64-frame blocks holding candidates are visited in increasing
    /// order of their box bound, stopping at the first bound above the best cost; inside a
    /// block, each 16-frame block is skipped if its bound is above the best cost, and each
    /// candidate's sum stops once above it. Ties go to the lower frame, as in the brute
    /// force, so the answer does not depend on the visiting order.
    ///
    /// # Errors
    /// As [`FeatureDb::search_brute`].
    pub fn search(&self, query: &[f64], allowed: &FrameSet, exclude: Option<Exclusion>) -> Result<Option<Match>> {
        self.check_search(query, allowed)?;
        let d = self.dim;
        let b = &self.blocks;
        let mut order: Vec<(f64, usize, u64)> = (0..allowed.words().len())
            .filter_map(|w| {
                let word = self.candidates(allowed, exclude, w);
                (word != 0).then(|| {
                    let (lo, hi) = (&b.large_lo[w * d..(w + 1) * d], &b.large_hi[w * d..(w + 1) * d]);
                    (box_bound(query, lo, hi, f64::INFINITY), w, word)
                })
            })
            .collect();
        order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut best: Option<Match> = None;
        // Until a first candidate is kept nothing may be pruned (costs can be +∞).
        let stop = |best: Option<Match>| best.map_or(f64::INFINITY, |m| m.cost);
        let better = |best: Option<Match>, t: usize, cost: f64| {
            best.is_none_or(|m| cost < m.cost || (cost == m.cost && t < m.frame))
        };
        for (bound, w, word) in order {
            if bound > stop(best) {
                break;
            }
            for s in 0..LARGE / SMALL {
                let mut bits = (word >> (s * SMALL)) & ((1 << SMALL) - 1);
                if bits == 0 {
                    continue;
                }
                let sb = w * (LARGE / SMALL) + s;
                let (lo, hi) = (&b.small_lo[sb * d..(sb + 1) * d], &b.small_hi[sb * d..(sb + 1) * d]);
                if box_bound(query, lo, hi, stop(best)) > stop(best) {
                    continue;
                }
                while bits != 0 {
                    let t = sb * SMALL + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let cost = cost_until(query, self.features(t), stop(best));
                    if better(best, t, cost) {
                        best = Some(Match { frame: t, cost });
                    }
                }
            }
        }
        Ok(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::database::Database;
    use crate::features::FeatureParams;
    use crate::testutil::{random_walk, random_walk_with_short_label, SHORT_LABEL};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// §7.6 (a): a database frame's own normalised features find it with cost 0.
    #[test]
    fn own_features_find_the_frame() {
        let (db, feats) = random_walk(2000, 5, 11);
        let all = FrameSet::all(db.len());
        let mut checked = 0;
        for t in feats.searchable().iter().step_by(37) {
            let q = feats.features(t).to_vec();
            for m in [feats.search(&q, &all, None), feats.search_brute(&q, &all, None)] {
                let m = m.unwrap().unwrap();
                assert_eq!((m.frame, m.cost), (t, 0.0));
            }
            checked += 1;
        }
        assert!(checked > 40);
        // Excluding the frame itself finds another frame, at a positive cost.
        let t = feats.searchable().iter().nth(100).unwrap();
        let ex = Some(Exclusion { center: t, radius: 3 });
        let m = feats.search(feats.features(t), &all, ex).unwrap().unwrap();
        assert!(m.frame.abs_diff(t) > 3 && m.cost > 0.0);
    }

    /// The top-k search starts with the search's answer, is sorted by (cost, frame), has
    /// min(k, candidates) entries, and each is a candidate no left-out frame beats.
    #[test]
    fn top_k_is_the_search_and_its_runners_up() {
        let (db, feats) = random_walk(600, 4, 5);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let all = FrameSet::all(db.len());
        for i in 0..40 {
            let base = rng.gen_range(0..db.len());
            let q: Vec<f64> = feats.features(base).iter().map(|v| v + rng.gen_range(-0.3..0.3)).collect();
            let ex = (i % 2 == 0).then_some(Exclusion { center: base, radius: 5 });
            let k = [1, 5, 10][i % 3];
            let top = feats.search_top(&q, &all, ex, k).unwrap();
            let best = feats.search_brute(&q, &all, ex).unwrap().unwrap();
            assert_eq!(top[0], best);
            assert_eq!(top.len(), k);
            assert!(top.windows(2).all(|p| (p[0].cost, p[0].frame) < (p[1].cost, p[1].frame)));
            // Every other candidate costs at least the k-th.
            let kth = top[k - 1].cost;
            for t in feats.searchable().iter().filter(|t| ex.is_none_or(|e| t.abs_diff(e.center) > e.radius)) {
                if top.iter().all(|m| m.frame != t) {
                    let c: f64 = q.iter().zip(feats.features(t)).map(|(a, b)| (a - b) * (a - b)).sum();
                    assert!(c >= kth, "frame {t} costs {c} < the k-th's {kth}");
                }
            }
        }
        // Fewer candidates than k: all of them; k = 0: none.
        let one = FrameSet::from_frames(db.len(), [feats.searchable().iter().next().unwrap()]).unwrap();
        assert_eq!(feats.search_top(feats.features(0), &one, None, 5).unwrap().len(), 1);
        assert!(feats.search_top(feats.features(0), &all, None, 0).unwrap().is_empty());
    }

    /// §7.6 (b): the accelerated search equals brute force (frame and cost) on 500 random
    /// queries with random allowed subsets and exclusions, over a 2000-frame random walk.
    #[test]
    fn accelerated_equals_brute_force() {
        let (db, feats) = random_walk(2000, 5, 7);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = db.len();
        let mut pruned_any = false;
        for i in 0..500 {
            let base = rng.gen_range(0..n);
            let noise = [0.0, 0.05, 0.5, 3.0][i % 4];
            let q: Vec<f64> = feats.features(base).iter().map(|v| v + noise * rng.gen_range(-1.0..1.0)).collect();
            let allowed = match i % 3 {
                0 => FrameSet::all(n),
                1 => FrameSet::from_predicate(n, |_| rng.gen_bool(0.3)),
                _ => {
                    let a = rng.gen_range(0..n);
                    let b = (a + rng.gen_range(1..400)).min(n);
                    FrameSet::from_frames(n, a..b).unwrap()
                }
            };
            let ex = (i % 5 == 0).then(|| Exclusion { center: base, radius: rng.gen_range(0..80) });
            let fast = feats.search(&q, &allowed, ex).unwrap();
            let slow = feats.search_brute(&q, &allowed, ex).unwrap();
            assert_eq!(fast, slow, "query {i}");
            if let Some(m) = slow {
                assert!(allowed.contains(m.frame) && feats.searchable().contains(m.frame));
                assert!(ex.is_none_or(|e| m.frame.abs_diff(e.center) > e.radius));
                pruned_any |= m.cost > 0.0;
            }
        }
        assert!(pruned_any);
    }

    /// The same on a label whose segments are all shorter than the 12-frame continuation
    /// (6 and 11 frames, searched with 5 and 10), mixed with long segments: queries near
    /// any frame, allowed sets of the short label's searchable frames (all, a random half)
    /// or of every frame; a short label's own searchable frames find themselves at cost 0.
    #[test]
    fn accelerated_equals_brute_force_on_a_short_label() {
        for short in [6, 11] {
            let (db, feats) = random_walk_with_short_label(4000, 4, 21, short);
            assert_eq!(feats.continuation_of(SHORT_LABEL), Some(short - 1));
            let mine = feats.searchable_with_label(&db, SHORT_LABEL).unwrap();
            assert!(mine.len() > 10, "{} short segments", mine.len());
            assert!(mine.iter().all(|t| db.segment_start(t) == t && db.segment_end(t) == t + short - 1));
            let mut rng = ChaCha8Rng::seed_from_u64(short as u64);
            let n = db.len();
            for i in 0..300 {
                let base = rng.gen_range(0..n);
                let noise = [0.0, 0.05, 0.5, 3.0][i % 4];
                let q: Vec<f64> = feats.features(base).iter().map(|v| v + noise * rng.gen_range(-1.0..1.0)).collect();
                let allowed = match i % 3 {
                    0 => mine.clone(),
                    1 => mine.intersection(&FrameSet::from_predicate(n, |_| rng.gen_bool(0.5))),
                    _ => FrameSet::all(n),
                };
                let ex = (i % 5 == 0).then(|| Exclusion { center: base, radius: rng.gen_range(0..80) });
                let fast = feats.search(&q, &allowed, ex).unwrap();
                assert_eq!(fast, feats.search_brute(&q, &allowed, ex).unwrap(), "short {short}, query {i}");
                if i % 3 == 0 {
                    assert_eq!(db.label(fast.unwrap().frame), SHORT_LABEL);
                }
            }
            for t in mine.iter() {
                let m = feats.search(feats.features(t), &mine, None).unwrap().unwrap();
                assert_eq!((m.frame, m.cost), (t, 0.0));
            }
        }
    }

    /// Exact ties (three identical takes) go to the lowest allowed frame in both searches,
    /// although the accelerated one visits blocks out of order.
    #[test]
    fn ties_go_to_the_lowest_frame() {
        let (take, _) = random_walk(300, 3, 5);
        let rows: Vec<f64> = take.controls().repeat(3);
        let segments: Vec<u32> = (0..900).map(|t| t / 300).collect();
        let db = Database::new(rows.clone(), 3, vec![0; 900], &segments, 24.0).unwrap();
        let feats = FeatureDb::build(&db, &rows, 3, &FeatureParams::default()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for i in 0..200 {
            let t = rng.gen_range(0..900);
            let allowed =
                if i % 2 == 0 { FrameSet::all(900) } else { FrameSet::from_predicate(900, |_| rng.gen_bool(0.5)) };
            let fast = feats.search(feats.features(t), &allowed, None).unwrap();
            let slow = feats.search_brute(feats.features(t), &allowed, None).unwrap();
            assert_eq!(fast, slow);
            if i % 2 == 0 && feats.searchable().contains(t) {
                assert_eq!(fast.unwrap().frame, t % 300);
            }
        }
    }

    #[test]
    fn exclusion_masks() {
        let e = Exclusion { center: 70, radius: 10 };
        assert_eq!(e.mask(0), u64::MAX << 60);
        assert_eq!(e.mask(1), (1 << 17) - 1);
        assert_eq!(e.mask(2), 0);
        assert_eq!(Exclusion { center: 5, radius: 1000 }.mask(3), u64::MAX);
    }

    #[test]
    fn bad_queries_are_errors() {
        let db = Database::new(vec![0.0; 40], 1, vec![0; 40], &[0; 40], 24.0).unwrap();
        let y: Vec<f64> = (0..40).map(f64::from).collect();
        let f = FeatureDb::build(&db, &y, 1, &FeatureParams::default()).unwrap();
        let all = FrameSet::all(40);
        assert!(matches!(f.search(&[0.0], &all, None), Err(MatchError::Length { .. })));
        let mut q = vec![0.0; f.dim()];
        q[2] = f64::NAN;
        assert!(matches!(f.search_brute(&q, &all, None), Err(MatchError::NonFinite { .. })));
        let q = vec![0.0; f.dim()];
        assert!(matches!(f.search(&q, &FrameSet::all(41), None), Err(MatchError::Mismatch { .. })));
        assert_eq!(f.search(&q, &FrameSet::empty(40), None).unwrap(), None);
    }
}
